#pragma once
// Closed-form starting values for the unknown registration frames of measured data: the measuring
// system's frame relative to the arm's base (world_T_base) and the marker on the flange
// (flange_T_marker), from measured marker poses and the nominal model's flange poses, with no guess
// from the user. The estimators then refine them together with the arm's parameters.
//
//   world_T_marker_k = world_T_base * base_T_flange_k * flange_T_marker      (AX = YB)
//
// Full poses: a robot-world / hand-eye solution: both rotations from Shah's (2013) Kronecker-product
// closed form (OpenCV's calibrateRobotWorldHandEye, CALIB_ROBOT_WORLD_HAND_EYE_SHAH), then both
// translations by linear least squares on the marker positions (the residual rms_position_m reports).
// Positions only: p_world_k = R_wb (R_bf_k m + p_bf_k) + t_wb, solved by alternating a point-set
// registration (Kabsch/Umeyama) for (R_wb, t_wb) with a linear least-squares solve for (m, t_wb).
#include <Eigen/Geometry>
#include <vector>

namespace orbcal::calib {

struct RegistrationGuess {
  Eigen::Isometry3d world_T_base = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d flange_T_marker = Eigen::Isometry3d::Identity();  ///< rotation identity for position-only data
  double rms_position_m = 0.0;  ///< RMS position residual of the guess over the samples
};

/// world_T_marker: measured; base_T_flange: the nominal model's at the same joint readings.
/// `use_rotation` false: only the translations of world_T_marker are used. Needs at least 3 samples
/// (full poses) or 4 positions not in one plane (positions only), and flange orientations that turn
/// about at least two axes (else the frames' rotations about that axis, and the marker offset along
/// it, cannot be told apart); throws std::invalid_argument when the samples are degenerate.
RegistrationGuess initialRegistration(const std::vector<Eigen::Isometry3d>& world_T_marker,
                                      const std::vector<Eigen::Isometry3d>& base_T_flange, bool use_rotation);

/// The same with the base frame known (world_T_base given): the marker alone, as the mean over the
/// samples of base_T_flange_k^-1 * world_T_base^-1 * world_T_marker_k (rotation: chordal mean; identity
/// when `use_rotation` is false). Throws std::invalid_argument for no samples or mismatched counts.
Eigen::Isometry3d initialMarker(const std::vector<Eigen::Isometry3d>& world_T_marker,
                                const std::vector<Eigen::Isometry3d>& base_T_flange,
                                const Eigen::Isometry3d& world_T_base, bool use_rotation);

}  // namespace orbcal::calib
