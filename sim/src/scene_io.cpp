#include <algorithm>
#include <cmath>
#include <filesystem>

#include "orbcal/sim/camera_io.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::sim {

const std::vector<std::string>& sceneTopLevelKeys() {
  static const std::vector<std::string> keys{"name",  "camera",   "board",        "base_T_board", "flange_T_camera",
                                             "views", "lighting", "degradations", "meshes",       "render"};
  return keys;
}

namespace {

/// A circle grid's keys of the scene's board (type: circles): grid: [cols, rows], spacing_m, diameter_m, asymmetric.
void parseSceneCircles(const ConfigNode& board, Board& b) {
  for (const char* key : {"inner_corners_x", "inner_corners_y", "square_m", "dictionary", "marker_m"}) {
    if (board.has(key)) board[key].fail("not for a circle grid (type: circles: grid, spacing_m, diameter_m, asymmetric)");
  }
  const Eigen::VectorXd grid = board["grid"].asVectorWithin(2, 2, 100, "2 to 100 circles a row and rows");
  if (grid[0] != std::floor(grid[0]) || grid[1] != std::floor(grid[1])) board["grid"].fail("expected whole numbers");
  b.corners_x = static_cast<int>(grid[0]);
  b.corners_y = static_cast<int>(grid[1]);
  b.asymmetric = board.optional("asymmetric").asBool(false);
  if (!b.asymmetric && b.corners_x == b.corners_y) board["grid"].fail("a symmetric grid needs unequal sides (a square one looks the same after a quarter turn)");
  b.square_m = board["spacing_m"].asDoubleWithin(1e-4, 10.0, "0.1 mm to 10 m");
  b.diameter_m = board["diameter_m"].asDoubleWithin(1e-4, 10.0, "0.1 mm to 10 m");
  const double nearest = b.asymmetric ? std::sqrt(2.0) * b.square_m : b.square_m;
  if (b.diameter_m >= 0.9 * nearest) board["diameter_m"].fail("must be below 0.9 of the nearest circles' distance");
  b.margin_m = board.has("margin_m") ? board["margin_m"].asDoubleWithin(0.0, 10.0, "0 m to 10 m") : b.square_m;
}

Board parseSceneBoard(const ConfigNode& board) {
  Board b;
  board.requireOnlyKeys({"type", "inner_corners_x", "inner_corners_y", "square_m", "margin_m", "dictionary", "marker_m", "grid",
                         "spacing_m", "diameter_m", "asymmetric"});
  const std::string type = board.optional("type").asString("chessboard");
  if (type == "circles") {
    b.type = BoardType::kCircles;
    parseSceneCircles(board, b);
    return b;
  }
  for (const char* key : {"grid", "spacing_m", "diameter_m", "asymmetric"}) {
    if (board.has(key)) board[key].fail("only for a circle grid (type: circles)");
  }
  if (type == "charuco") {
    b.type = BoardType::kCharuco;
  } else if (type != "chessboard") {
    board["type"].fail("expected chessboard, charuco or circles, got '" + type + "'");
  }
  b.corners_x = board["inner_corners_x"].asInt();
  b.corners_y = board["inner_corners_y"].asInt();
  if (b.corners_x < 2) board["inner_corners_x"].fail("must be at least 2");
  if (b.corners_y < 2) board["inner_corners_y"].fail("must be at least 2");
  if (b.type == BoardType::kChessboard) {
    for (const char* key : {"dictionary", "marker_m"}) {
      if (board.has(key)) board[key].fail("only for a ChArUco board (type: charuco)");
    }
    if (b.corners_x % 2 == b.corners_y % 2) {
      // An even-by-even or odd-by-odd square count looks the same after a half turn: the corner order
      // could flip. The squares are inner corners + 1 along each side. (A ChArUco board's markers
      // identify its corners: no such rule.)
      board.fail("inner_corners_x and inner_corners_y must differ in parity (an even-by-odd square count), "
                 "so that the board's orientation is unambiguous");
    }
  }
  b.square_m = board["square_m"].asDoubleWithin(1e-4, 10.0, "0.1 mm to 10 m");
  b.margin_m = board.has("margin_m") ? board["margin_m"].asDoubleWithin(0.0, 10.0, "0 m to 10 m") : b.square_m;
  if (b.type == BoardType::kCharuco) {
    b.dictionary = board["dictionary"].asString();
    ArucoDictionaryInfo info;
    if (!arucoDictionary(b.dictionary, &info)) {
      board["dictionary"].fail("unknown ArUco dictionary '" + b.dictionary +
                               "' (expected DICT_NxN_M, N = 4..7, M = 50, 100, 250 or 1000)");
    }
    const int markers = static_cast<int>(charucoMarkers(b).size());
    if (markers > info.markers) {
      board["dictionary"].fail(b.dictionary + " has " + std::to_string(info.markers) + " markers, the board needs " +
                               std::to_string(markers));
    }
    b.marker_m = board["marker_m"].asDouble();
    if (!(b.marker_m > 0.0 && b.marker_m < b.square_m)) {
      board["marker_m"].fail("must be positive and smaller than square_m");
    }
  }
  return b;
}

}  // namespace

Scene loadScene(const std::string& path) {
  const ConfigNode root = ConfigNode::load(path);
  root.requireOnlyKeys(sceneTopLevelKeys());
  Scene s;
  s.source = path;
  s.name = printable(root["name"].asString());  // a label printed as is: no raw control bytes

  std::string scene_dir;
  if (path.rfind("builtin:", 0) != 0) scene_dir = std::filesystem::path(path).parent_path().string();
  s.camera = parseSceneCamera(root["camera"], scene_dir, &s.camera_file);

  s.board = parseSceneBoard(root["board"]);

  s.base_T_board = root["base_T_board"].asTransform();
  s.flange_T_camera = root["flange_T_camera"].asTransform();

  const ConfigNode v = root.optional("views");
  if (v.defined()) {
    v.requireOnlyKeys({"distance_m", "max_tilt_deg", "image_margin_px", "min_singular_value", "locked_joint"});
    if (v.has("distance_m")) {
      const Eigen::VectorXd d = v["distance_m"].asVector(2);
      if (!(0 < d[0] && d[0] < d[1])) v["distance_m"].fail("expected [min, max] with 0 < min < max");
      if (d[1] > kMaxLengthM) v["distance_m"].fail("max is outside 0 m to 10000 m");  // kMaxLengthM
      s.views.min_distance_m = d[0];
      s.views.max_distance_m = d[1];
    }
    s.views.max_tilt_rad = v.optional("max_tilt_deg").asDouble(s.views.max_tilt_rad * kRadToDeg) * kDegToRad;
    if (!(s.views.max_tilt_rad >= 0 && s.views.max_tilt_rad < 0.5 * kPi)) v["max_tilt_deg"].fail("must be within [0, 90)");
    if (v.has("image_margin_px")) {
      s.views.image_margin_px = v["image_margin_px"].asDoubleWithin(
          0.0, 0.5 * std::min(s.camera.width_px, s.camera.height_px), "0 px to half the image's smaller side");
    }
    s.views.min_singular_value = v.optional("min_singular_value").asDouble(s.views.min_singular_value);
    const int locked = v.optional("locked_joint").asInt(s.views.locked_joint + 1);
    if (locked < 0) v["locked_joint"].fail("must be a joint number (1-based) or 0 for none");
    s.views.locked_joint = locked - 1;
  }
  return s;
}

}  // namespace orbcal::sim
