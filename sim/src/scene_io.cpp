#include <algorithm>
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

Scene loadScene(const std::string& path) {
  const ConfigNode root = ConfigNode::load(path);
  root.requireOnlyKeys(sceneTopLevelKeys());
  Scene s;
  s.source = path;
  s.name = printable(root["name"].asString());  // a label printed as is: no raw control bytes

  std::string scene_dir;
  if (path.rfind("builtin:", 0) != 0) scene_dir = std::filesystem::path(path).parent_path().string();
  s.camera = parseSceneCamera(root["camera"], scene_dir, &s.camera_file);

  const ConfigNode board = root["board"];
  board.requireOnlyKeys({"type", "inner_corners_x", "inner_corners_y", "square_m", "margin_m", "dictionary", "marker_m"});
  const std::string type = board.optional("type").asString("chessboard");
  if (type == "charuco") {
    s.board.type = BoardType::kCharuco;
  } else if (type != "chessboard") {
    board["type"].fail("expected chessboard or charuco, got '" + type + "'");
  }
  s.board.corners_x = board["inner_corners_x"].asInt();
  s.board.corners_y = board["inner_corners_y"].asInt();
  if (s.board.corners_x < 2) board["inner_corners_x"].fail("must be at least 2");
  if (s.board.corners_y < 2) board["inner_corners_y"].fail("must be at least 2");
  if (s.board.type == BoardType::kChessboard) {
    for (const char* key : {"dictionary", "marker_m"}) {
      if (board.has(key)) board[key].fail("only for a ChArUco board (type: charuco)");
    }
    if (s.board.corners_x % 2 == s.board.corners_y % 2) {
      // An even-by-even or odd-by-odd square count looks the same after a half turn: the corner order
      // could flip. The squares are inner corners + 1 along each side. (A ChArUco board's markers
      // identify its corners: no such rule.)
      board.fail("inner_corners_x and inner_corners_y must differ in parity (an even-by-odd square count), "
                 "so that the board's orientation is unambiguous");
    }
  }
  s.board.square_m = board["square_m"].asDoubleWithin(1e-4, 10.0, "0.1 mm to 10 m");
  s.board.margin_m = board.has("margin_m") ? board["margin_m"].asDoubleWithin(0.0, 10.0, "0 m to 10 m") : s.board.square_m;
  if (s.board.type == BoardType::kCharuco) {
    s.board.dictionary = board["dictionary"].asString();
    ArucoDictionaryInfo info;
    if (!arucoDictionary(s.board.dictionary, &info)) {
      board["dictionary"].fail("unknown ArUco dictionary '" + s.board.dictionary +
                               "' (expected DICT_NxN_M, N = 4..7, M = 50, 100, 250 or 1000)");
    }
    const int markers = static_cast<int>(charucoMarkers(s.board).size());
    if (markers > info.markers) {
      board["dictionary"].fail(s.board.dictionary + " has " + std::to_string(info.markers) + " markers, the board needs " +
                               std::to_string(markers));
    }
    s.board.marker_m = board["marker_m"].asDouble();
    if (!(s.board.marker_m > 0.0 && s.board.marker_m < s.board.square_m)) {
      board["marker_m"].fail("must be positive and smaller than square_m");
    }
  }

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
