#pragma once
// Shared by the render tests: camera poses that look at the board, and corner detection against the
// ground truth (cv::projectPoints of the true corners).
#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "orbcal/render/renderer.hpp"
#include "orbcal/sim/scene.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "test_util.hpp"

namespace orbcal::test {

/// camera_T_board of a camera `distance_m` from the board centre, its optical axis through the
/// centre at `tilt_deg` from the board normal (azimuth `azimuth_deg` about z_board), rolled by
/// `roll_deg` about the optical axis. The camera sits on the printed side (-z_board).
inline Eigen::Isometry3d lookAtBoard(const sim::Board& board, double distance_m, double tilt_deg, double azimuth_deg,
                                     double roll_deg, const Eigen::Vector3d& aim_offset_board = Eigen::Vector3d::Zero()) {
  const double t = tilt_deg * sim::kDegToRad, a = azimuth_deg * sim::kDegToRad, r = roll_deg * sim::kDegToRad;
  const Eigen::Vector3d target = sim::boardCentre(board) + aim_offset_board;
  const Eigen::Vector3d z(std::sin(t) * std::cos(a), std::sin(t) * std::sin(a), std::cos(t));  // toward the board
  Eigen::Vector3d x0 = Eigen::Vector3d::UnitX() - z * z.x();
  x0.normalize();
  const Eigen::Vector3d y0 = z.cross(x0);
  const Eigen::Vector3d x = std::cos(r) * x0 + std::sin(r) * y0;
  Eigen::Isometry3d board_T_camera = Eigen::Isometry3d::Identity();
  board_T_camera.linear() << x, z.cross(x), z;
  board_T_camera.translation() = target - distance_m * z;
  return board_T_camera.inverse();
}

/// The noise-free image of `scene` under `settings` from camera_T_board, by a renderer (and OSMesa
/// context) of its own, released before returning: tests compare images of two settings this way.
inline cv::Mat renderCleanWith(const sim::Scene& scene, const render::RenderSettings& settings,
                               const Eigen::Isometry3d& camera_T_board) {
  render::BoardRenderer r(scene, settings);
  return r.renderClean(camera_T_board);
}

/// The default scene's text with its `meshes: []` replaced by `meshes_yaml`.
inline std::string defaultSceneWithMeshes(const std::string& meshes_yaml) {
  std::string text = sim::readTextSource(sim::kDefaultScene);
  const std::string marker = "meshes: []";
  const auto at = text.find(marker);
  if (at == std::string::npos) throw std::runtime_error("the default scene has no '" + marker + "' any more");
  return text.replace(at, marker.size(), meshes_yaml);
}

/// defaultSceneWithMeshes(meshes_yaml) + extra, written to dir/scene.yaml, with the test plate copied to
/// dir/meshes/occluder_plate.obj (so the scene refers to it by a relative path). Returns the scene's path.
inline std::string writeSceneWithPlate(const std::string& dir, const std::string& meshes_yaml, const std::string& extra = "") {
  std::filesystem::create_directories(dir + "/meshes");
  std::filesystem::copy_file(sourcePath("scenes/meshes/occluder_plate.obj"), dir + "/meshes/occluder_plate.obj",
                             std::filesystem::copy_options::overwrite_existing);
  const std::string path = dir + "/scene.yaml";
  std::ofstream(path) << defaultSceneWithMeshes(meshes_yaml) + extra;
  return path;
}

inline cv::Mat toCvMat(const Eigen::Matrix3d& R) {
  cv::Mat m(3, 3, CV_64F);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) m.at<double>(i, j) = R(i, j);
  return m;
}

/// cv::projectPoints of every inner corner under the camera's distorted model.
inline std::vector<cv::Point2d> trueCorners(const sim::Scene& scene, const Eigen::Isometry3d& camera_T_board) {
  std::vector<cv::Point3d> obj;
  for (const Eigen::Vector3d& p : sim::boardCorners(scene.board)) obj.emplace_back(p.x(), p.y(), p.z());
  cv::Mat rvec;
  cv::Rodrigues(toCvMat(camera_T_board.linear()), rvec);
  const Eigen::Vector3d t = camera_T_board.translation();
  const cv::Mat tvec = (cv::Mat_<double>(3, 1) << t.x(), t.y(), t.z());
  const sim::Camera& c = scene.camera;
  const cv::Mat K = (cv::Mat_<double>(3, 3) << c.fx_px, 0, c.cx_px, 0, c.fy_px, c.cy_px, 0, 0, 1);
  const cv::Mat dist = (cv::Mat_<double>(1, 5) << c.distortion[0], c.distortion[1], c.distortion[2], c.distortion[3],
                        c.distortion[4]);
  std::vector<cv::Point2d> uv;
  cv::projectPoints(obj, rvec, tvec, K, dist, uv);
  return uv;
}

/// Classic detector + cornerSubPix (11 x 11, eps 1e-4); nullopt when the board is not found.
/// The order is matched to `truth` (identity or reversed, whichever is closer).
inline std::optional<std::vector<cv::Point2d>> detectCorners(const cv::Mat& gray, const sim::Board& board,
                                                             const std::vector<cv::Point2d>& truth) {
  std::vector<cv::Point2f> c;
  const cv::Size pattern(board.corners_x, board.corners_y);
  if (!cv::findChessboardCorners(gray, pattern, c, cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE)) {
    return std::nullopt;
  }
  cv::cornerSubPix(gray, c, cv::Size(5, 5), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-4));
  std::vector<cv::Point2d> d(c.begin(), c.end());
  double fwd = 0, rev = 0;
  for (std::size_t k = 0; k < d.size(); ++k) {
    fwd += cv::norm(d[k] - truth[k]);
    rev += cv::norm(d[d.size() - 1 - k] - truth[k]);
  }
  if (rev < fwd) std::reverse(d.begin(), d.end());
  return d;
}

}  // namespace orbcal::test
