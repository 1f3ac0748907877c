// A measurement description of images (sim/image_views.hpp): flange poses from pose files (a 4x4 text
// matrix in mm, a YAML position + quaternion in m) or joint readings of a robot, the board's frame
// conventions, circle grids (their layout and half turn), and the one-line errors of bad input.
#include <tuple>

#include "orbcal/sim/image_views.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "test_util.hpp"

using namespace orbcal;

namespace {

void write(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

const char* kHead =
    "format: orbcal-measurements-1\n"
    "files: [views.csv]\n"
    "images: {column: image, ignore: coloured, rectangles: [[0, 0, 100, 20]]}\n"
    "camera: {width_px: 640, height_px: 480, fx_px: 500, fy_px: 500, cx_px: 320, cy_px: 240}\n"
    "board: {charuco: {squares: [7, 5], square_mm: 30, marker_mm: 22, dictionary: DICT_4X4_50}, frame: legacy}\n"
    "setup: eye_in_hand\n";

}  // namespace

TEST_CASE("image descriptions: pose files per row, as a 4x4 text matrix in mm and a YAML position + quaternion", "[image-views]") {
  const std::string dir = test::tempDir("image-views-files");
  write(dir + "/a.txt", "1 0 0 447.0\n0 -1 0 0\n0 0 -1 395.5\n0 0 0 1\n");
  write(dir + "/b.yaml", "x: 0.1\ny: 0.2\nz: 0.3\nqx: 0\nqy: 0\nqz: 0.7071067811865476\nqw: 0.7071067811865476\n");
  write(dir + "/views.csv", "image,pose\nimg_a.png,a.txt\nimg_b.png,b.yaml\n");
  write(dir + "/d.yaml", std::string(kHead) + "flange_pose: {file_column: pose, length_unit: mm}\n");
  const sim::ImageViews v = sim::loadImageViews(dir + "/d.yaml");
  REQUIRE(v.views.size() == 2);
  CHECK(v.views[0].image == (std::filesystem::path(dir) / "img_a.png").lexically_normal().string());
  CHECK(v.views[0].base_T_flange.translation().isApprox(Eigen::Vector3d(0.447, 0.0, 0.3955)));
  CHECK(v.views[0].base_T_flange.linear().isApprox(Eigen::Vector3d(1, -1, -1).asDiagonal().toDenseMatrix()));
  // length_unit applies to the YAML file's numbers too: mm here.
  CHECK(v.views[1].base_T_flange.translation().isApprox(Eigen::Vector3d(1e-4, 2e-4, 3e-4)));
  CHECK(std::abs(sim::rotationAngle(v.views[1].base_T_flange.linear()) - sim::kPi / 2) < 1e-12);
  CHECK(v.mask.ignore_coloured);
  REQUIRE(v.mask.rectangles.size() == 1);
  CHECK(v.mask.rectangles[0][2] == 100);
  CHECK(v.board.corners_x == 6);
  CHECK(v.board.corners_y == 4);
  CHECK(v.setup == sim::HandEyeSetup::kEyeInHand);
  // The legacy frame: inner corner 0 (orbcal's origin) sits at (s, H - s, 0) with H = 5 squares; z flips.
  const Eigen::Isometry3d printed_T_board = sim::printedFromBoard(v.board, v.board_frame);
  CHECK((printed_T_board * Eigen::Vector3d::Zero()).isApprox(Eigen::Vector3d(0.03, 0.12, 0.0)));
  CHECK((printed_T_board.linear() * Eigen::Vector3d::UnitZ()).isApprox(-Eigen::Vector3d::UnitZ()));
}

TEST_CASE("image descriptions: joint readings give the nominal arm's flange pose", "[image-views]") {
  const std::string dir = test::tempDir("image-views-joints");
  write(dir + "/views.csv", "image,q1,q2,q3,q4,q5,q6,q7\nimg.png,10,20,30,40,50,60,70\n");
  write(dir + "/d.yaml", std::string(kHead) + "robot: " + test::sourcePath("scenes/iiwa7.yaml") +
                             "\njoints: {columns: [q1, q2, q3, q4, q5, q6, q7], unit: deg}\n");
  const sim::ImageViews v = sim::loadImageViews(dir + "/d.yaml");
  REQUIRE(v.views.size() == 1);
  REQUIRE(v.arm);
  Eigen::VectorXd q(7);
  q << 10, 20, 30, 40, 50, 60, 70;
  q *= sim::kDegToRad;
  CHECK(v.views[0].base_T_flange.isApprox(sim::forwardKinematics(*v.arm, q)));
}

TEST_CASE("image descriptions: bad input is one line naming the file and the key", "[image-views]") {
  const std::string dir = test::tempDir("image-views-bad");
  write(dir + "/views.csv", "image,pose\nimg.png,p.txt\n");
  const std::string d = dir + "/d.yaml";
  write(d, std::string(kHead));
  CHECK_THROWS_WITH(sim::loadImageViews(d), Catch::Contains("d.yaml: flange_pose: give either flange_pose"));
  write(d, std::string(kHead) + "flange_pose: {file_column: pose, length_unit: inch}\n");
  CHECK_THROWS_WITH(sim::loadImageViews(d), Catch::Contains("length_unit"));
  // A rotation off orthonormal by 1e-2: refused with the CSV's line and the pose file.
  write(dir + "/p.txt", "0.99 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  write(d, std::string(kHead) + "flange_pose: {file_column: pose, length_unit: m}\n");
  CHECK_THROWS_WITH(sim::loadImageViews(d), Catch::Contains("views.csv: line 2") && Catch::Contains("not orthonormal"));
  // Four printed decimals (0.7071): re-orthonormalised with a warning.
  write(dir + "/p.txt", "0.7071 -0.7071 0 0\n0.7071 0.7071 0 0\n0 0 1 0\n0 0 0 1\n");
  const sim::ImageViews v = sim::loadImageViews(d);
  REQUIRE(v.warnings.size() == 1);
  CHECK(v.warnings[0].find("re-orthonormalised") != std::string::npos);
  const Eigen::Matrix3d R = v.views[0].base_T_flange.linear();
  CHECK((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-12);
  // A description of images is not tracker data: loadMeasuredData names the key.
  CHECK(sim::describesImages(d));
  write(d, std::string(kHead) + "flange_pose: {file_column: pose, length_unit: m}\ncircles: 1\n");
  CHECK_THROWS_WITH(sim::loadImageViews(d), Catch::Contains("d.yaml") && Catch::Contains("circles"));
}

TEST_CASE("image descriptions: circle grids, their layout, half turn and one-line errors", "[image-views][circles]") {
  const std::string dir = test::tempDir("image-views-circles");
  write(dir + "/views.csv", "image,pose\nimg.png,p.txt\n");
  write(dir + "/p.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  const std::string head =
      "format: orbcal-measurements-1\nfiles: [views.csv]\nimages: {column: image}\n"
      "camera: {width_px: 640, height_px: 480, fx_px: 500, fy_px: 500, cx_px: 320, cy_px: 240}\n"
      "flange_pose: {file_column: pose, length_unit: m}\nsetup: eye_in_hand\n";
  const std::string d = dir + "/d.yaml";
  write(d, head + "board: {circles: {grid: [4, 11], spacing_mm: 20, diameter_mm: 15, asymmetric: true}, margin_mm: 10}\n");
  const sim::ImageViews a = sim::loadImageViews(d);
  CHECK(a.board.type == sim::BoardType::kCircles);
  CHECK(a.board.asymmetric);
  CHECK(a.board.corners_x == 4);
  CHECK(a.board.corners_y == 11);
  CHECK(a.board.square_m == Approx(0.020));
  CHECK(a.board.diameter_m == Approx(0.015));
  CHECK(a.board.margin_m == Approx(0.010));
  // OpenCV's sample layout: ((2 j + i % 2) s, i s) for circle i * cols + j.
  CHECK(sim::cornerInBoard(a.board, 0).isApprox(Eigen::Vector3d(0, 0, 0)));
  CHECK(sim::cornerInBoard(a.board, 5).isApprox(Eigen::Vector3d(0.060, 0.020, 0)));  // row 1, column 1: x = 3 s
  CHECK(sim::printedFromBoard(a.board, a.board_frame).isApprox(Eigen::Isometry3d::Identity()));
  CHECK_FALSE(sim::halfTurnSymmetric(a.board));  // 11 rows: the half turn puts even rows on odd ones' places
  // The half turn maps corner k onto corner N - 1 - k where the board has the symmetry.
  for (const auto& [cols, rows, asym] : {std::make_tuple(9, 6, false), std::make_tuple(4, 10, true)}) {
    sim::Board b;
    b.type = sim::BoardType::kCircles;
    b.corners_x = cols, b.corners_y = rows, b.asymmetric = asym, b.square_m = 0.03;
    REQUIRE(sim::halfTurnSymmetric(b));
    const Eigen::Isometry3d F = sim::halfTurn(b);
    for (int k = 0; k < b.numCorners(); ++k) {
      CHECK((F * sim::cornerInBoard(b, b.numCorners() - 1 - k) - sim::cornerInBoard(b, k)).norm() < 1e-12);
    }
    CHECK((F * sim::boardCentre(b) - sim::boardCentre(b)).norm() < 1e-12);
  }
  // Bad values and keys: one line naming the file and the key.
  const std::vector<std::pair<std::string, std::string>> bad{
      {"{circles: {grid: [4.5, 11], spacing_mm: 20, diameter_mm: 15}}", "grid"},
      {"{circles: {grid: [5, 5], spacing_mm: 20, diameter_mm: 15}}", "grid"},
      {"{circles: {grid: [4, 11], spacing_mm: 20, diameter_mm: 19}}", "diameter_mm"},
      {"{circles: {grid: [4, 11], spacing_mm: 20, diameter_mm: 15, radius_mm: 7}}", "radius_mm"},
      {"{circles: {grid: [4, 11], diameter_mm: 15}}", "spacing_mm"},
      {"{circles: {grid: [4, 11], spacing_mm: 20, diameter_mm: 15, asymmetric: maybe}}", "asymmetric"},
      {"{circles: {grid: [4, 11], spacing_mm: 20, diameter_mm: 15}, frame: legacy}", "frame"},
      {"{circles: {grid: [4, 11], spacing_mm: 20, diameter_mm: 15}, chessboard: {squares: [10, 7], square_mm: 25}}", "board"},
  };
  for (const auto& [board, key] : bad) {
    CAPTURE(board);
    write(d, head + "board: " + board + "\n");
    try {
      sim::loadImageViews(d);
      FAIL("accepted");
    } catch (const sim::InputError& e) {
      const std::string what = e.what();
      CHECK(what.find("d.yaml") != std::string::npos);
      CHECK(what.find(key) != std::string::npos);
      CHECK(what.find('\n') == std::string::npos);
    }
  }
}
