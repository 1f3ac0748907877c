#pragma once
// The board pose from its detected corners (PnP), its covariance, and the measured flange pose.
//
// Perturbation conventions (6-vectors [translation m; rotation rad], as sim::poseMinus / posePlus):
//
//  * PnP: e_c is the error of the CAMERA pose in the board frame, expressed in the camera frame:
//        board_T_camera_true = sim::posePlus(board_T_camera_est, e_c),
//        e_c = sim::poseMinus(board_T_camera_true, board_T_camera_est),
//    where board_T_camera = camera_T_board^-1. A corner P_b then sits at
//        p_c(e_c) = camera_T_board_true * P_b = exp(-e_c) p_c  ~  p_c - v + S(p_c) w,
//    so J_pc_ec = [-I, S(p_c)] and J_uv_ec = J_uv_pc * J_pc_ec (reprojectionJacobian).
//    Covariance: Sigma_c = s^2 (J^T J)^-1, J the 2N x 6 stacked J_uv_ec at the estimate and
//    s^2 = SSE / (2N - 6) the residual variance per pixel coordinate (Gauss-Newton, i.i.d. corner
//    noise; the fit's own residual sets the scale, so no noise level has to be known in advance).
//
//  * Flange: the measured flange pose is
//        base_T_flange = base_T_board * board_T_camera * camera_T_flange,   camera_T_flange = flange_T_camera^-1,
//    and its error e_f is the right perturbation in the flange frame:
//        base_T_flange_true = sim::posePlus(base_T_flange_est, e_f),  e_f = sim::poseMinus(true, est).
//    Since base_T_flange_true = base_T_flange_est * camera_T_flange^-1 * exp(e_c) * camera_T_flange,
//        e_f = Ad(flange_T_camera) e_c   (to first order; sim::adjoint),
//        Sigma_f = Ad Sigma_c Ad^T.
//    base_T_board and flange_T_camera are taken as exact (they are calibrated elsewhere or are
//    part of the model being identified).
//
//  * Pose error against the nominal model (Wang et al. 2023 eq. 13):
//        sim::poseMinus(base_T_flange_measured, sim::forwardKinematics(nominal_arm, q)),
//    whose covariance, for an exact nominal, is Sigma_f (same frame, same ordering).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "orbcal/sim/arm.hpp"
#include "orbcal/sim/scene.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::vision {

struct BoardPose {
  bool ok = false;
  std::string reason;  ///< short fixed phrase when !ok
  std::string detail;
  Eigen::Isometry3d camera_T_board = Eigen::Isometry3d::Identity();
  sim::Matrix6d covariance_camera = sim::Matrix6d::Zero();  ///< of e_c (see the file comment)
  double rms_px = 0.0;      ///< sqrt(SSE / N): RMS distance between detected and reprojected corners
  double sigma_px = 0.0;    ///< s = sqrt(SSE / (2N - 6)): estimated noise per pixel coordinate
  int num_corners = 0;
};

/// Pixels of the board's corners seen from camera_T_board (sim::project, with distortion).
std::vector<Eigen::Vector2d> projectBoard(const sim::Camera& camera, const sim::Board& board,
                                          const Eigen::Isometry3d& camera_T_board);

/// J_uv_pc: d pixel / d point in camera coordinates, OpenCV's model with distortion (2 x 3).
Eigen::Matrix<double, 2, 3> projectionJacobian(const sim::Camera& camera, const Eigen::Vector3d& p_cam);

/// J_uv_ec (2N x 6; rows u0 v0 u1 v1 ...): corner pixels w.r.t. e_c (see the file comment).
Eigen::MatrixXd reprojectionJacobian(const sim::Camera& camera, const sim::Board& board,
                                     const Eigen::Isometry3d& camera_T_board);

/// solvePnP (IPPE on the undistorted plane) then Levenberg-Marquardt refinement (solvePnPRefineLM),
/// then the covariance. Throws std::invalid_argument unless corners_px has board.numCorners()
/// entries (>= 4). A failed solve or a board behind the camera is returned as !ok.
[[nodiscard]] BoardPose estimateBoardPose(const sim::Camera& camera, const sim::Board& board,
                                          const std::vector<Eigen::Vector2d>& corners_px);

/// The same from a subset of the corners, known by identity (a ChArUco detection, a partly visible
/// board): corners_px[n] is inner corner ids[n] (sim::cornerInBoard). Needs >= 6 corners, distinct ids
/// in range, not all on one row or column of the board (std::invalid_argument otherwise: check first).
[[nodiscard]] BoardPose estimateBoardPose(const sim::Camera& camera, const sim::Board& board,
                                          const std::vector<Eigen::Vector2d>& corners_px, const std::vector<int>& ids);

/// Sigma_f = Ad(flange_T_camera) Sigma_c Ad(flange_T_camera)^T (see the file comment).
sim::Matrix6d flangeCovariance(const Eigen::Isometry3d& flange_T_camera, const sim::Matrix6d& covariance_camera);

/// base_T_board * camera_T_board^-1 * flange_T_camera^-1.
Eigen::Isometry3d measuredFlangePose(const sim::Scene& scene, const Eigen::Isometry3d& camera_T_board);

}  // namespace orbcal::vision
