#include "orbcal/sim/scene.hpp"

#include <cmath>

namespace orbcal::sim {

bool Camera::hasDistortion() const {
  for (double k : distortion) {
    if (k != 0.0) return true;
  }
  return false;
}

Eigen::Vector2d distortNormalized(const std::array<double, 5>& k, const Eigen::Vector2d& xy,
                                  Eigen::Matrix2d* J_distorted_xy) {
  const double k1 = k[0], k2 = k[1], p1 = k[2], p2 = k[3], k3 = k[4];
  const double x = xy.x(), y = xy.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  const double xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
  const double yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
  if (J_distorted_xy) {
    const double dradial = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2);  // d radial / d r2
    const double cross = 2.0 * x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y;
    *J_distorted_xy << radial + 2.0 * x * x * dradial + 2.0 * p1 * y + 6.0 * p2 * x, cross,
        cross, radial + 2.0 * y * y * dradial + 6.0 * p1 * y + 2.0 * p2 * x;
  }
  return {xd, yd};
}

Eigen::Vector2d project(const Camera& camera, const Eigen::Vector3d& p_cam) {
  const Eigen::Vector2d d = distortNormalized(camera.distortion, Eigen::Vector2d(p_cam.x() / p_cam.z(), p_cam.y() / p_cam.z()));
  return {camera.fx_px * d.x() + camera.cx_px, camera.fy_px * d.y() + camera.cy_px};
}

Eigen::Vector3d cornerInBoard(const Board& board, int k) {
  const int c = k % board.corners_x, r = k / board.corners_x;
  if (board.type == BoardType::kCircles && board.asymmetric) return {(2 * c + r % 2) * board.square_m, r * board.square_m, 0.0};
  return {c * board.square_m, r * board.square_m, 0.0};
}

namespace {
/// The corners' extent along x and y (m): the largest x and y of cornerInBoard (the smallest are 0).
Eigen::Vector2d cornerExtent(const Board& board) {
  const double cols = board.type == BoardType::kCircles && board.asymmetric ? 2 * board.corners_x - (board.corners_y > 1 ? 1 : 2)
                                                                             : board.corners_x - 1;
  return {cols * board.square_m, (board.corners_y - 1) * board.square_m};
}
}  // namespace

bool halfTurnSymmetric(const Board& board) {
  if (board.type == BoardType::kCharuco) return false;
  if (board.type == BoardType::kChessboard) return board.corners_x % 2 == board.corners_y % 2;
  return !board.asymmetric || board.corners_y % 2 == 0;
}

Eigen::Isometry3d halfTurn(const Board& board) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Vector3d(-1.0, -1.0, 1.0).asDiagonal();
  T.translation().head<2>() = cornerExtent(board);
  return T;
}

bool isBlackSquare(int i, int j) { return (i + j) % 2 == 0; }

bool arucoDictionary(const std::string& name, ArucoDictionaryInfo* info) {
  // cv::aruco::DICT_4X4_50 = 0, DICT_4X4_100, DICT_4X4_250, DICT_4X4_1000, DICT_5X5_50, ... DICT_7X7_1000 = 15.
  static const int kCounts[4] = {50, 100, 250, 1000};
  for (int bits = 4; bits <= 7; ++bits) {
    for (int c = 0; c < 4; ++c) {
      const std::string n = "DICT_" + std::to_string(bits) + "X" + std::to_string(bits) + "_" + std::to_string(kCounts[c]);
      if (n != name) continue;
      if (info) *info = {(bits - 4) * 4 + c, kCounts[c], bits};
      return true;
    }
  }
  return false;
}

std::vector<CharucoMarker> charucoMarkers(const Board& board) {
  std::vector<CharucoMarker> markers;
  const double s = board.square_m, inset = 0.5 * (board.square_m - board.marker_m);
  for (int j = 0; j <= board.corners_y; ++j) {
    for (int i = 0; i <= board.corners_x; ++i) {
      if (isBlackSquare(i, j)) continue;
      const int id = static_cast<int>(markers.size());
      markers.push_back({id, i, j, Eigen::Vector3d((i - 1) * s + inset, (j - 1) * s + inset, 0.0)});
    }
  }
  return markers;
}

std::vector<Eigen::Vector3d> boardCorners(const Board& board) {
  std::vector<Eigen::Vector3d> corners;
  corners.reserve(board.numCorners());
  for (int k = 0; k < board.numCorners(); ++k) corners.push_back(cornerInBoard(board, k));
  return corners;
}

std::array<Eigen::Vector3d, 4> squaresOutline(const Board& board) {
  const double s = board.square_m;
  const Eigen::Vector2d e = cornerExtent(board);
  const double x0 = -s, y0 = -s, x1 = e.x() + s, y1 = e.y() + s;
  return {Eigen::Vector3d(x0, y0, 0), Eigen::Vector3d(x1, y0, 0), Eigen::Vector3d(x1, y1, 0),
          Eigen::Vector3d(x0, y1, 0)};
}

std::array<Eigen::Vector3d, 4> boardOutline(const Board& board) {
  const double m = board.margin_m;
  std::array<Eigen::Vector3d, 4> outline = squaresOutline(board);
  const std::array<Eigen::Vector3d, 4> grow{Eigen::Vector3d(-m, -m, 0), Eigen::Vector3d(m, -m, 0),
                                            Eigen::Vector3d(m, m, 0), Eigen::Vector3d(-m, m, 0)};
  for (int i = 0; i < 4; ++i) outline[i] += grow[i];
  return outline;
}

Eigen::Vector3d boardCentre(const Board& board) {
  const Eigen::Vector2d e = cornerExtent(board);
  return {0.5 * e.x(), 0.5 * e.y(), 0.0};
}

Visibility boardVisibility(const Scene& scene, const Eigen::Isometry3d& camera_T_board) {
  const Eigen::Vector3d centre = camera_T_board * boardCentre(scene.board);
  const Eigen::Vector3d normal = camera_T_board.linear().col(2);  // away from the printed face
  // The printed face looks along -z_board, so it faces the camera when the camera sits on the -z side.
  if (centre.z() <= 0.0 || normal.dot(centre) <= 0.0) return Visibility::kBehind;
  const double distance = centre.norm();
  if (distance > scene.views.max_distance_m) return Visibility::kTooFar;
  if (distance < scene.views.min_distance_m) return Visibility::kTooNear;
  const double tilt = std::acos(std::min(1.0, normal.dot(centre) / distance));
  if (tilt > scene.views.max_tilt_rad) return Visibility::kTooOblique;
  const double m = scene.views.image_margin_px;
  const auto inside = [&](const Eigen::Vector3d& p_board) {
    const Eigen::Vector3d p = camera_T_board * p_board;
    if (p.z() <= 0.0) return false;
    const Eigen::Vector2d uv = project(scene.camera, p);
    return uv.x() >= m - 0.5 && uv.y() >= m - 0.5 && uv.x() <= scene.camera.width_px - 0.5 - m &&
           uv.y() <= scene.camera.height_px - 0.5 - m;
  };
  for (const Eigen::Vector3d& p : squaresOutline(scene.board)) {
    if (!inside(p)) return Visibility::kOutsideImage;
  }
  for (int k = 0; k < scene.board.numCorners(); ++k) {
    if (!inside(cornerInBoard(scene.board, k))) return Visibility::kOutsideImage;
  }
  return Visibility::kVisible;
}

const char* toString(Visibility v) {
  switch (v) {
    case Visibility::kVisible: return "visible";
    case Visibility::kBehind: return "board behind the camera or facing away";
    case Visibility::kOutsideImage: return "board not wholly inside the image";
    case Visibility::kTooFar: return "board too far";
    case Visibility::kTooNear: return "board too near";
    case Visibility::kTooOblique: return "board seen too obliquely";
  }
  return "?";
}

}  // namespace orbcal::sim
