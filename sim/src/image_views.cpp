#include "orbcal/sim/image_views.hpp"

#include <cmath>
#include <filesystem>
#include <sstream>

#include "orbcal/sim/camera_io.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "measured_columns.hpp"

namespace orbcal::sim {

using namespace measured_columns;  // NOLINT: valueOf, readUnit, the length units

namespace {

constexpr double kExactRotation = 1e-6;  ///< as sim/measured.hpp's pose tolerance

std::string resolveBeside(const std::string& file, const std::string& path) {
  const std::filesystem::path p(path);
  return (p.is_absolute() ? p : std::filesystem::path(file).parent_path() / p).lexically_normal().string();
}

/// How each row's flange pose is given.
struct PoseColumns {
  std::string file_column;                 ///< a pose file per row
  std::vector<std::string> matrix, position, quaternion;  ///< or columns
  std::vector<std::string> joints;         ///< or joint readings (with a robot)
  Unit length, angle;
};

PoseColumns readPoseColumns(const ConfigNode& root, ImageViews& v) {
  PoseColumns c;
  ColumnClaims claims;
  const auto pose = optionalValueOf(root, "flange_pose");
  const auto joints = optionalValueOf(root, "joints");
  if (pose.has_value() == joints.has_value()) {
    throw InputError(root.source() + ": flange_pose: give either flange_pose (the controller's base_T_flange per image) or "
                     "robot + joints (joint readings per image)");
  }
  if (joints) {
    const ConfigNode robot = valueOf(root, "robot");
    v.robot_file = resolveBeside(v.description, robot.asString());
    v.arm = loadArm(RobotSource{v.robot_file, "", ""}, robot.source() + ": robot");
    joints->requireOnlyKeys({"columns", "unit"});
    c.angle = readUnit(valueOf(*joints, "unit"), kAngleUnits);
    c.joints = readNames(valueOf(*joints, "columns"), static_cast<std::size_t>(v.arm->numJoints()),
                         "one per joint of " + v.robot_file, claims);
    return c;
  }
  if (root.has("robot")) root["robot"].fail("not with flange_pose (the flange poses need no robot model)");
  pose->requireOnlyKeys({"file_column", "matrix", "position", "quaternion_wxyz", "length_unit"});
  c.length = readUnit(valueOf(*pose, "length_unit"), kLengthUnits);
  const int given = pose->has("file_column") + pose->has("matrix") + pose->has("position");
  if (given != 1 || pose->has("position") != pose->has("quaternion_wxyz")) {
    pose->fail("expected one of file_column (a pose file per row), matrix (16 column names) or position (3) with "
               "quaternion_wxyz (4)");
  }
  if (pose->has("file_column")) c.file_column = claimColumn(valueOf(*pose, "file_column"), claims);
  if (pose->has("matrix")) c.matrix = readNames(valueOf(*pose, "matrix"), 16, "a row-major 4x4 matrix", claims);
  if (pose->has("position")) {
    c.position = readNames(valueOf(*pose, "position"), 3, "x, y, z", claims);
    c.quaternion = readNames(valueOf(*pose, "quaternion_wxyz"), 4, "w, x, y, z", claims);
  }
  return c;
}

/// A pose file: 16 numbers (row-major 4x4) or a YAML map {x, y, z, qx, qy, qz, qw}. Returns the matrix
/// as read (lengths in the file's unit).
Eigen::Matrix4d readPoseFile(const std::string& path, const std::string& named_by) {
  const std::string text = readTextNamedBy(path, named_by);
  if (text.find(':') != std::string::npos) {
    const ConfigNode n = ConfigNode::parse(text, path);
    n.requireOnlyKeys({"x", "y", "z", "qx", "qy", "qz", "qw"});
    Eigen::Quaterniond q(n["qw"].asDouble(), n["qx"].asDouble(), n["qy"].asDouble(), n["qz"].asDouble());
    if (std::abs(q.norm() - 1.0) > kControllerRotationTolerance) n.fail("the quaternion's norm is not 1 (" + formatNumber("%.9g", q.norm()) + ")");
    Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
    T.topLeftCorner<3, 3>() = q.normalized().toRotationMatrix();
    T.topRightCorner<3, 1>() << n["x"].asDouble(), n["y"].asDouble(), n["z"].asDouble();
    return T;
  }
  std::istringstream in(text);
  std::vector<double> values;
  std::string word;
  while (in >> word) {
    char* end = nullptr;
    const double value = std::strtod(word.c_str(), &end);
    if (end == word.c_str() || *end != '\0' || !std::isfinite(value)) {
      throw InputError(path + ": expected 16 numbers (a row-major 4x4 pose), got " + quoteInput(word));
    }
    values.push_back(value);
  }
  if (values.size() != 16) throw InputError(path + ": expected 16 numbers (a row-major 4x4 pose), got " + std::to_string(values.size()));
  return Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(values.data());
}

/// base_T_flange in SI from a matrix as read: bottom row checked, rotation made orthonormal (or refused).
Eigen::Isometry3d flangePose(const Eigen::Matrix4d& M, const Unit& length, const std::string& where, std::vector<std::string>& warnings) {
  if ((M.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > kExactRotation) {
    throw InputError(where + ": the pose's bottom row is not [0 0 0 1]");
  }
  std::string warning;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = controllerRotation(M.topLeftCorner<3, 3>(), where, &warning);
  for (int i = 0; i < 3; ++i) T.translation()[i] = length.toSi(M(i, 3));
  if (T.translation().norm() > kMaxLengthM) throw InputError(where + ": the flange position is beyond 10 km");
  if (!warning.empty()) warnings.push_back(warning);
  return T;
}

void readRows(const std::string& file, const PoseColumns& c, const ConfigNode& images, ImageViews& v) {
  const CsvTable t = CsvTable::parse(readTextNamedBy(file, v.description + ": files"), file);
  if (t.rows() == 0) throw InputError(file + ": no data rows");
  const int image_col = t.requireColumn(valueOf(images, "column").asString());
  const int mask_col = images.has("mask_column") ? t.requireColumn(images["mask_column"].asString()) : -1;
  const auto columns = [&t](const std::vector<std::string>& names) {
    std::vector<int> out;
    for (const std::string& n : names) out.push_back(t.requireColumn(n));
    return out;
  };
  const std::vector<int> joints = columns(c.joints), matrix = columns(c.matrix), position = columns(c.position),
                         quaternion = columns(c.quaternion);
  const int file_col = c.file_column.empty() ? -1 : t.requireColumn(c.file_column);
  for (std::size_t r = 0; r < t.rows(); ++r) {
    ImageView view;
    view.where = t.where(r);
    if (t.cell(r, image_col).empty()) throw InputError(view.where + ": " + t.header()[image_col] + ": empty (an image path)");
    view.image = resolveBeside(file, t.cell(r, image_col));
    if (mask_col >= 0 && !t.cell(r, mask_col).empty()) view.mask = resolveBeside(file, t.cell(r, mask_col));
    if (!joints.empty()) {
      view.sample.q_rad.resize(static_cast<Eigen::Index>(joints.size()));
      for (std::size_t j = 0; j < joints.size(); ++j) view.sample.q_rad[static_cast<Eigen::Index>(j)] = c.angle.toSi(t.number(r, joints[j]));
      view.base_T_flange = forwardKinematics(*v.arm, view.sample.q_rad);
    } else {
      Eigen::Matrix4d M = Eigen::Matrix4d::Identity();
      std::string where = view.where;
      if (file_col >= 0) {
        const std::string path = resolveBeside(file, t.cell(r, file_col));
        M = readPoseFile(path, view.where + ": " + c.file_column);
        where = view.where + ": " + path;
      } else if (!matrix.empty()) {
        for (int i = 0; i < 16; ++i) M(i / 4, i % 4) = t.number(r, matrix[static_cast<std::size_t>(i)]);
      } else {
        Eigen::Quaterniond q(t.number(r, quaternion[0]), t.number(r, quaternion[1]), t.number(r, quaternion[2]), t.number(r, quaternion[3]));
        if (std::abs(q.norm() - 1.0) > kControllerRotationTolerance) throw InputError(view.where + ": the quaternion's norm is not 1");
        M.topLeftCorner<3, 3>() = q.normalized().toRotationMatrix();
        for (int i = 0; i < 3; ++i) M(i, 3) = t.number(r, position[static_cast<std::size_t>(i)]);
      }
      view.base_T_flange = flangePose(M, c.length, where, v.warnings);
    }
    v.views.push_back(std::move(view));
  }
}

void readMask(const ConfigNode& images, ImageViews& v) {
  images.requireOnlyKeys({"column", "ignore", "mask", "mask_column", "rectangles"});
  if (const auto ignore = optionalValueOf(images, "ignore")) {
    if (ignore->asString() != "coloured" && ignore->asString() != "colored") ignore->fail("expected coloured (pixels of clear colour are ignored)");
    v.mask.ignore_coloured = true;
  }
  if (const auto mask = optionalValueOf(images, "mask")) v.mask.mask_file = resolveBeside(v.description, mask->asString());
  if (const auto rects = optionalValueOf(images, "rectangles")) {
    for (std::size_t i = 0; i < rects->size(); ++i) {
      const Eigen::VectorXd r = (*rects)[i].asVectorWithin(4, 0, 16384, "pixels within 0..16384");
      if (r[2] <= r[0] || r[3] <= r[1]) (*rects)[i].fail("expected [x0, y0, x1, y1] with x1 > x0 and y1 > y0");
      v.mask.rectangles.push_back({static_cast<int>(r[0]), static_cast<int>(r[1]), static_cast<int>(r[2]), static_cast<int>(r[3])});
    }
  }
}

/// circles: {grid: [cols, rows], spacing_mm, diameter_mm, asymmetric} (sim::BoardType::kCircles).
void readCircles(const ConfigNode& b, Board& board) {
  b.requireOnlyKeys({"grid", "spacing_mm", "diameter_mm", "asymmetric"});
  board.type = BoardType::kCircles;
  const Eigen::VectorXd grid = valueOf(b, "grid").asVectorWithin(2, 2, 100, "2 to 100 circles a row and rows");
  if (grid[0] != std::floor(grid[0]) || grid[1] != std::floor(grid[1])) b["grid"].fail("expected whole numbers");
  board.corners_x = static_cast<int>(grid[0]);
  board.corners_y = static_cast<int>(grid[1]);
  board.asymmetric = b.optional("asymmetric").asBool(false);
  if (!board.asymmetric && board.corners_x == board.corners_y) {
    b["grid"].fail("a symmetric grid of as many circles a row as rows looks the same after a quarter turn: give unequal sides");
  }
  board.square_m = valueOf(b, "spacing_mm").asDoubleWithin(1, 1000, "1 to 1000 mm") * 1e-3;
  board.diameter_m = valueOf(b, "diameter_mm").asDoubleWithin(0.5, 1000, "0.5 to 1000 mm") * 1e-3;
  // Nearest neighbours: s apart (symmetric), s sqrt(2) (asymmetric: 2 s along a row, diagonally to the next row).
  const double nearest = board.asymmetric ? std::sqrt(2.0) * board.square_m : board.square_m;
  if (board.diameter_m >= 0.9 * nearest) {
    b["diameter_mm"].fail("must be below 0.9 of the nearest circles' distance (" + formatNumber("%.4g", nearest * 1e3) +
                          " mm), so that neighbouring circles stay apart in an image");
  }
}

/// board: {charuco | chessboard: {squares: [X, Y], square_mm, [marker_mm, dictionary]} | circles: {...}, frame, margin_mm}.
void readBoard(const ConfigNode& node, ImageViews& v) {
  node.requireOnlyKeys({"charuco", "chessboard", "circles", "frame", "margin_mm"});
  if (node.has("charuco") + node.has("chessboard") + node.has("circles") != 1) node.fail("expected one of charuco, chessboard or circles");
  Board& board = v.board;
  board.margin_m = node.has("margin_mm") ? node["margin_mm"].asDoubleWithin(0, 1000, "0 to 1000 mm") * 1e-3 : 0.0;
  if (node.has("circles")) {
    readCircles(node["circles"], board);
    if (const auto frame = optionalValueOf(node, "frame"); frame && frame->asString() != "opencv") {
      frame->fail("a circle grid has one board frame (OpenCV's calibration sample's: origin at the first circle's centre): opencv");
    }
    return;
  }
  const bool charuco = node.has("charuco");
  const ConfigNode b = charuco ? node["charuco"] : node["chessboard"];
  if (charuco) {
    b.requireOnlyKeys({"squares", "square_mm", "marker_mm", "dictionary"});
  } else {
    b.requireOnlyKeys({"squares", "square_mm"});
  }
  board.type = charuco ? BoardType::kCharuco : BoardType::kChessboard;
  const Eigen::VectorXd squares = valueOf(b, "squares").asVectorWithin(2, 3, 100, "3 to 100 squares per side");
  if (squares[0] != std::floor(squares[0]) || squares[1] != std::floor(squares[1])) b["squares"].fail("expected whole numbers");
  board.corners_x = static_cast<int>(squares[0]) - 1;
  board.corners_y = static_cast<int>(squares[1]) - 1;
  board.square_m = valueOf(b, "square_mm").asDoubleWithin(1, 1000, "1 to 1000 mm") * 1e-3;
  if (charuco) {
    board.marker_m = valueOf(b, "marker_mm").asDoubleWithin(0.5, 1000, "0.5 to 1000 mm") * 1e-3;
    if (board.marker_m >= board.square_m) b["marker_mm"].fail("must be smaller than square_mm");
    board.dictionary = valueOf(b, "dictionary").asString();
    ArucoDictionaryInfo info;
    if (!arucoDictionary(board.dictionary, &info)) b["dictionary"].fail("expected one of OpenCV's DICT_NxN_M (N 4..7, M 50, 100, 250, 1000)");
  }
  if (const auto frame = optionalValueOf(node, "frame")) {
    const std::string f = frame->asString();
    if (f != "opencv" && f != "legacy") frame->fail("expected opencv (OpenCV >= 4.6's board frame) or legacy (<= 4.5's)");
    v.board_frame = f == "legacy" ? BoardFrameConvention::kLegacy : BoardFrameConvention::kOpenCv;
  }
}

}  // namespace

const char* handEyeSetupName(HandEyeSetup s) { return s == HandEyeSetup::kEyeInHand ? "eye_in_hand" : "eye_to_hand"; }

Eigen::Matrix3d controllerRotation(const Eigen::Matrix3d& R, const std::string& where, std::string* warning) {
  const double off = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (R.determinant() <= 0.0 || off > kControllerRotationTolerance) {
    throw InputError(where + ": the rotation is not orthonormal (max |R^T R - I| = " + formatNumber("%.3g", off) +
                     ", or a reflection; up to 1e-4 is re-orthonormalised)");
  }
  if (off <= kExactRotation) return R;
  if (warning) *warning = where + ": rotation off orthonormal by " + formatNumber("%.2g", off) + " (rounded digits?): re-orthonormalised";
  return projectToSO3(R);
}

Eigen::Isometry3d printedFromBoard(const Board& board, BoardFrameConvention convention) {
  if (board.type == BoardType::kCircles) return Eigen::Isometry3d::Identity();  // one frame: the first circle's centre
  // orbcal's frame is OpenCV's shifted by (-s, -s, 0): opencv_T_board translates by (s, s, 0).
  Eigen::Isometry3d opencv_T_board = Eigen::Isometry3d::Identity();
  opencv_T_board.translation() << board.square_m, board.square_m, 0.0;
  if (convention == BoardFrameConvention::kOpenCv) return opencv_T_board;
  // legacy = (x, H - y, -z) of OpenCV's, H the squares' extent along y.
  Eigen::Isometry3d legacy_T_opencv = Eigen::Isometry3d::Identity();
  legacy_T_opencv.linear() = Eigen::Vector3d(1, -1, -1).asDiagonal();
  legacy_T_opencv.translation() << 0.0, (board.corners_y + 1) * board.square_m, 0.0;
  return legacy_T_opencv * opencv_T_board;
}

bool describesImages(const std::string& description_path) {
  return ConfigNode::load(description_path).has("images");
}

ImageViews loadImageViews(const std::string& description_path) {
  ImageViews v;
  v.description = description_path;
  const ConfigNode root = ConfigNode::load(description_path);
  root.requireOnlyKeys({"format", "files", "images", "flange_pose", "robot", "joints", "camera", "board", "setup"});
  const ConfigNode format = valueOf(root, "format");
  if (format.asString() != "orbcal-measurements-1") format.fail("expected 'orbcal-measurements-1', got " + quoteInput(format.asString()));
  const ConfigNode setup = valueOf(root, "setup");
  if (setup.asString() != "eye_in_hand" && setup.asString() != "eye_to_hand") {
    setup.fail("expected eye_in_hand (the camera on the flange) or eye_to_hand (a static camera, the board on the flange)");
  }
  v.setup = setup.asString() == "eye_in_hand" ? HandEyeSetup::kEyeInHand : HandEyeSetup::kEyeToHand;
  const ConfigNode camera = valueOf(root, "camera");
  if (camera.isMap()) {
    v.camera = parseSceneCamera(camera, std::filesystem::path(description_path).parent_path().string(), &v.camera_file);
  } else {
    v.camera_file = resolveBeside(description_path, camera.asString());
    v.camera = loadCameraFile(v.camera_file);
  }
  readBoard(valueOf(root, "board"), v);
  const ConfigNode images = valueOf(root, "images");
  readMask(images, v);
  const PoseColumns columns = readPoseColumns(root, v);
  const ConfigNode files = valueOf(root, "files");
  if (files.size() == 0) files.fail("expected at least one CSV file");
  for (std::size_t i = 0; i < files.size(); ++i) {
    v.files.push_back(resolveBeside(description_path, files[i].asString()));
    readRows(v.files.back(), columns, images, v);
  }
  if (v.warnings.size() > 1) {  // one line for all: which rows, the first's message
    v.warnings = {std::to_string(v.warnings.size()) + " flange rotations were re-orthonormalised; the first: " + v.warnings.front()};
  }
  return v;
}

}  // namespace orbcal::sim
