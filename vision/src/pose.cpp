#include "orbcal/vision/pose.hpp"

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <set>
#include <sstream>
#include <stdexcept>

namespace orbcal::vision {

namespace {
// LM refinement: stop after this many iterations or when the update is below machine level.
constexpr int kRefineIterations = 50;
constexpr double kRefineEps = 1e-12;

cv::Mat distortionMat(const sim::Camera& camera) {
  cv::Mat d(5, 1, CV_64F);
  for (int i = 0; i < 5; ++i) d.at<double>(i) = camera.distortion[i];
  return d;
}
cv::Matx33d cameraMatrix(const sim::Camera& c) { return {c.fx_px, 0, c.cx_px, 0, c.fy_px, c.cy_px, 0, 0, 1}; }

BoardPose failure(std::string reason, std::string detail) {
  BoardPose p;
  p.reason = std::move(reason);
  p.detail = std::move(detail);
  return p;
}
}  // namespace

std::vector<Eigen::Vector2d> projectBoard(const sim::Camera& camera, const sim::Board& board,
                                          const Eigen::Isometry3d& camera_T_board) {
  std::vector<Eigen::Vector2d> uv;
  uv.reserve(board.numCorners());
  for (int k = 0; k < board.numCorners(); ++k) uv.push_back(sim::project(camera, camera_T_board * sim::cornerInBoard(board, k)));
  return uv;
}

Eigen::Matrix<double, 2, 3> projectionJacobian(const sim::Camera& camera, const Eigen::Vector3d& p) {
  const double iz = 1.0 / p.z();
  const double x = p.x() * iz, y = p.y() * iz;
  Eigen::Matrix<double, 2, 3> J_xy_p;
  J_xy_p << iz, 0.0, -x * iz, 0.0, iz, -y * iz;
  const auto& k = camera.distortion;  // k1 k2 p1 p2 k3
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (k[0] + r2 * (k[1] + r2 * k[4]));
  const double dradial = k[0] + r2 * (2.0 * k[1] + 3.0 * r2 * k[4]);  // d radial / d r2
  Eigen::Matrix2d J_d_xy;
  J_d_xy(0, 0) = radial + 2.0 * x * x * dradial + 2.0 * k[2] * y + 6.0 * k[3] * x;
  J_d_xy(0, 1) = 2.0 * x * y * dradial + 2.0 * k[2] * x + 2.0 * k[3] * y;
  J_d_xy(1, 0) = 2.0 * x * y * dradial + 2.0 * k[2] * x + 2.0 * k[3] * y;
  J_d_xy(1, 1) = radial + 2.0 * y * y * dradial + 6.0 * k[2] * y + 2.0 * k[3] * x;
  const Eigen::Matrix2d J_uv_d = Eigen::Vector2d(camera.fx_px, camera.fy_px).asDiagonal();
  return J_uv_d * J_d_xy * J_xy_p;
}

namespace {
/// J_uv_ec of one point at p (camera frame): J_uv_pc [-I, S(p)] (the file comment of pose.hpp).
Eigen::Matrix<double, 2, 6> pointJacobian(const sim::Camera& camera, const Eigen::Vector3d& p) {
  Eigen::Matrix<double, 3, 6> J_pc_ec;
  J_pc_ec << -Eigen::Matrix3d::Identity(), sim::skew(p);
  return projectionJacobian(camera, p) * J_pc_ec;
}
}  // namespace

Eigen::MatrixXd reprojectionJacobian(const sim::Camera& camera, const sim::Board& board,
                                     const Eigen::Isometry3d& camera_T_board) {
  Eigen::MatrixXd J(2 * board.numCorners(), 6);
  for (int k = 0; k < board.numCorners(); ++k) {
    J.middleRows<2>(2 * k) = pointJacobian(camera, camera_T_board * sim::cornerInBoard(board, k));
  }
  return J;
}

namespace {
/// PnP + LM + covariance on the board points P[n] (board frame) seen at corners_px[n].
BoardPose solvePose(const sim::Camera& camera, const std::vector<Eigen::Vector3d>& P,
                    const std::vector<Eigen::Vector2d>& corners_px) {
  const int n = static_cast<int>(P.size());
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  for (int k = 0; k < n; ++k) {
    object.emplace_back(P[k].x(), P[k].y(), P[k].z());
    image.emplace_back(corners_px[k].x(), corners_px[k].y());
  }
  const cv::Matx33d K = cameraMatrix(camera);
  const cv::Mat dist = distortionMat(camera);
  cv::Mat rvec, tvec;
  bool solved = false;
  try {
    solved = cv::solvePnP(object, image, K, dist, rvec, tvec, false, cv::SOLVEPNP_IPPE);
    if (solved) {
      cv::solvePnPRefineLM(object, image, K, dist, rvec, tvec,
                           cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, kRefineIterations, kRefineEps));
    }
  } catch (const cv::Exception& e) {
    return failure("pose not solved", std::string("solvePnP: ") + e.what());
  }
  if (!solved) return failure("pose not solved", "solvePnP (IPPE) found no solution");

  BoardPose pose;
  cv::Matx33d R;
  cv::Rodrigues(rvec, R);
  Eigen::Matrix3d Re;
  cv::cv2eigen(R, Re);
  pose.camera_T_board.linear() = Re;
  pose.camera_T_board.translation() = Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  if (!pose.camera_T_board.matrix().allFinite()) return failure("pose not solved", "solvePnP returned a non-finite pose");
  for (int k = 0; k < n; ++k) {
    if ((pose.camera_T_board * P[k]).z() <= 0.0) return failure("pose not solved", "the solved board lies behind the camera");
  }

  double sse = 0.0;
  Eigen::MatrixXd J(2 * n, 6);
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector3d p = pose.camera_T_board * P[k];
    sse += (corners_px[k] - sim::project(camera, p)).squaredNorm();
    J.middleRows<2>(2 * k) = pointJacobian(camera, p);
  }
  const sim::Matrix6d JtJ = J.transpose() * J;
  const double s2 = sse / (2.0 * n - 6.0);
  pose.covariance_camera = s2 * JtJ.ldlt().solve(sim::Matrix6d::Identity());
  pose.covariance_camera = 0.5 * (pose.covariance_camera + pose.covariance_camera.transpose()).eval();
  pose.rms_px = std::sqrt(sse / n);
  pose.sigma_px = std::sqrt(s2);
  pose.num_corners = n;
  pose.ok = true;
  return pose;
}
}  // namespace

BoardPose estimateBoardPose(const sim::Camera& camera, const sim::Board& board,
                            const std::vector<Eigen::Vector2d>& corners_px) {
  const int n = board.numCorners();
  if (static_cast<int>(corners_px.size()) != n || n < 4) {
    throw std::invalid_argument("estimateBoardPose: expected " + std::to_string(n) + " corners (>= 4), got " +
                                std::to_string(corners_px.size()));
  }
  return solvePose(camera, sim::boardCorners(board), corners_px);
}

BoardPose estimateBoardPose(const sim::Camera& camera, const sim::Board& board,
                            const std::vector<Eigen::Vector2d>& corners_px, const std::vector<int>& ids) {
  if (corners_px.size() != ids.size() || ids.size() < 6) {
    throw std::invalid_argument("estimateBoardPose: expected >= 6 corners with one id each, got " +
                                std::to_string(corners_px.size()) + " corners and " + std::to_string(ids.size()) + " ids");
  }
  std::vector<Eigen::Vector3d> P;
  std::vector<bool> seen(static_cast<std::size_t>(board.numCorners()), false);
  std::set<int> rows, cols;
  for (const int id : ids) {
    if (id < 0 || id >= board.numCorners() || seen[static_cast<std::size_t>(id)]) {
      throw std::invalid_argument("estimateBoardPose: corner id " + std::to_string(id) + " out of range or repeated");
    }
    seen[static_cast<std::size_t>(id)] = true;
    rows.insert(id / board.corners_x);
    cols.insert(id % board.corners_x);
    P.push_back(sim::cornerInBoard(board, id));
  }
  if (rows.size() < 2 || cols.size() < 2) {
    throw std::invalid_argument("estimateBoardPose: the corners lie on one row or column of the board");
  }
  return solvePose(camera, P, corners_px);
}

sim::Matrix6d flangeCovariance(const Eigen::Isometry3d& flange_T_camera, const sim::Matrix6d& covariance_camera) {
  const sim::Matrix6d Ad = sim::adjoint(flange_T_camera);
  const sim::Matrix6d S = Ad * covariance_camera * Ad.transpose();
  return 0.5 * (S + S.transpose());  // exactly symmetric (the table stores one triangle)
}

Eigen::Isometry3d measuredFlangePose(const sim::Scene& scene, const Eigen::Isometry3d& camera_T_board) {
  return scene.base_T_board * camera_T_board.inverse(Eigen::Isometry) * scene.flange_T_camera.inverse(Eigen::Isometry);
}

}  // namespace orbcal::vision
