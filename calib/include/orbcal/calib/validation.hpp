#pragma once
// Validation on a separate configuration set: the pose errors of a model (nominal, or nominal plus the
// identified errors) against the true plant, before and after compensation, laid out like seed 000's
// Table 4 (position, and X/Y/Z orientation: average and extreme, improvement ratio).
#include <Eigen/Geometry>
#include <random>
#include <string>
#include <vector>

#include "orbcal/sim/arm.hpp"

namespace orbcal::calib {

/// A simulated plant at a set of commanded configurations: the true joints (commanded + control noise)
/// and the true flange poses (the true arm at the true joints).
struct PlantSamples {
  std::vector<Eigen::VectorXd> q_commanded;
  std::vector<Eigen::VectorXd> q_true;
  std::vector<Eigen::Isometry3d> base_T_flange_true;
};
PlantSamples simulatePlant(const sim::Arm& true_arm, const std::vector<Eigen::VectorXd>& q_commanded,
                           double joint_noise_sigma_rad, std::mt19937_64& rng);

/// Pose errors of `model` (driven by the commanded joints) against the plant's true poses.
struct PoseErrors {
  std::vector<double> position_m;               ///< |p_true - p_model|
  std::vector<Eigen::Vector3d> orientation_rad;  ///< |components| of log(R_true R_model^T), base frame X/Y/Z
};
PoseErrors poseErrors(const sim::Arm& model, const PlantSamples& plant);

struct ErrorSummary {
  double position_avg_m = 0, position_max_m = 0;
  Eigen::Vector3d orientation_avg_rad = Eigen::Vector3d::Zero();
  Eigen::Vector3d orientation_max_rad = Eigen::Vector3d::Zero();
};
ErrorSummary summarize(const PoseErrors& errors);

/// (initial - calibrated) / initial, the paper's ratio.
inline double improvement(double initial, double calibrated) { return (initial - calibrated) / initial; }

/// Seed 000 Table 4 layout: rows position / X / Y / Z orientation x extreme / average; one column
/// pair (value, ratio) per method after the initial column. Markdown, mm and deg.
std::string formatTable4(const ErrorSummary& initial, const std::vector<std::pair<std::string, ErrorSummary>>& methods);

}  // namespace orbcal::calib
