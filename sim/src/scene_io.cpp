#include <algorithm>

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

  const ConfigNode cam = root["camera"];
  cam.requireOnlyKeys({"width_px", "height_px", "fx_px", "fy_px", "cx_px", "cy_px", "distortion"});
  s.camera.width_px = cam["width_px"].asInt();
  s.camera.height_px = cam["height_px"].asInt();
  if (s.camera.width_px < 16 || s.camera.width_px > 16384) cam["width_px"].fail("must be within 16..16384");
  if (s.camera.height_px < 16 || s.camera.height_px > 16384) cam["height_px"].fail("must be within 16..16384");
  // Physical ranges, so that an absurd value is named at its key and not found later as "no
  // configuration sees the board": a focal length of 1 px to 1e6 px, the principal point in the image,
  // OpenCV's radial k1 k2 k3 within +-10 and tangential p1 p2 within +-1.
  const char* kFocal = "1 px to 1e6 px (a focal length in pixels)";
  s.camera.fx_px = cam["fx_px"].asDoubleWithin(1.0, 1e6, kFocal);
  s.camera.fy_px = cam["fy_px"].asDoubleWithin(1.0, 1e6, kFocal);
  s.camera.cx_px = cam["cx_px"].asDoubleWithin(0.0, s.camera.width_px, "the image: 0 to width_px px");
  s.camera.cy_px = cam["cy_px"].asDoubleWithin(0.0, s.camera.height_px, "the image: 0 to height_px px");
  if (cam.has("distortion")) {
    const ConfigNode k = cam["distortion"];
    if (!k.isSequence() || k.size() != 5) k.fail("expected a sequence of 5 numbers (OpenCV k1 k2 p1 p2 k3)");
    for (std::size_t i = 0; i < 5; ++i) {
      const bool tangential = i == 2 || i == 3;
      s.camera.distortion[static_cast<Eigen::Index>(i)] =
          tangential ? k[i].asDoubleWithin(-1.0, 1.0, "-1 to 1 (a tangential coefficient p1, p2)")
                     : k[i].asDoubleWithin(-10.0, 10.0, "-10 to 10 (a radial coefficient k1, k2, k3)");
    }
  }

  const ConfigNode board = root["board"];
  board.requireOnlyKeys({"inner_corners_x", "inner_corners_y", "square_m", "margin_m"});
  s.board.corners_x = board["inner_corners_x"].asInt();
  s.board.corners_y = board["inner_corners_y"].asInt();
  if (s.board.corners_x < 2) board["inner_corners_x"].fail("must be at least 2");
  if (s.board.corners_y < 2) board["inner_corners_y"].fail("must be at least 2");
  if (s.board.corners_x % 2 == s.board.corners_y % 2) {
    // An even-by-even or odd-by-odd square count looks the same after a half turn: the corner order
    // could flip. The squares are inner corners + 1 along each side.
    board.fail("inner_corners_x and inner_corners_y must differ in parity (an even-by-odd square count), "
               "so that the board's orientation is unambiguous");
  }
  s.board.square_m = board["square_m"].asDoubleWithin(1e-4, 10.0, "0.1 mm to 10 m");
  s.board.margin_m = board.has("margin_m") ? board["margin_m"].asDoubleWithin(0.0, 10.0, "0 m to 10 m") : s.board.square_m;

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
