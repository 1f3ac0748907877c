#pragma once
// Validation on a separate configuration set: the pose errors of a model (nominal, or nominal plus the
// identified errors) against the true plant, before and after compensation, laid out like Wang et al. 2023's
// Table 4 (position, and X/Y/Z orientation: average and extreme, improvement ratio).
#include <Eigen/Geometry>
#include <random>
#include <string>
#include <vector>

#include "orbcal/sim/arm.hpp"
#include "orbcal/sim/sample.hpp"
#include "orbcal/sim/truth.hpp"

namespace orbcal::calib {

/// A simulated plant at a set of commanded configurations: the true joints (commanded + control noise)
/// and the true flange poses (the true arm at the true joints).
struct PlantSamples {
  std::vector<Eigen::VectorXd> q_commanded;
  std::vector<Eigen::VectorXd> q_true;
  std::vector<Eigen::Isometry3d> base_T_flange_true;
  /// Where the plant has effects (sim::TrueArm): each commanded configuration with the covariates the
  /// effects read there (TrueArm::sample of its index in the run, approach direction from the previous
  /// commanded configuration), so that a plant filtered to some of its samples keeps them. May be
  /// empty: poseErrors(TrueArm, ...) then takes sample k of q_commanded in order.
  std::vector<sim::JointSample> commanded_samples;
};
PlantSamples simulatePlant(const sim::Arm& true_arm, const std::vector<Eigen::VectorXd>& q_commanded,
                           double joint_noise_sigma_rad, std::mt19937_64& rng);
/// The same with a plant that may have effects: sample k's true pose is truth.flangePose(k, q_true[k],
/// q_true[k - 1]). Without effects the same poses (bit for bit) and the same noise draws as above.
PlantSamples simulatePlant(const sim::TrueArm& truth, const std::vector<Eigen::VectorXd>& q_commanded,
                           double joint_noise_sigma_rad, std::mt19937_64& rng);
/// The commanded samples of a run of configurations (TrueArm::sample of each, in order).
std::vector<sim::JointSample> commandedSamples(const sim::TrueArm& truth,
                                               const std::vector<Eigen::VectorXd>& q_commanded);

/// Pose errors of `model` (driven by the commanded joints) against the plant's true poses.
struct PoseErrors {
  std::vector<double> position_m;               ///< |p_true - p_model|
  std::vector<Eigen::Vector3d> position_xyz_m;  ///< |components| of p_true - p_model, base frame X/Y/Z
  std::vector<Eigen::Vector3d> orientation_rad;  ///< |components| of log(R_true R_model^T), base frame X/Y/Z
};
PoseErrors poseErrors(const sim::Arm& model, const PlantSamples& plant);
/// The errors of the true model itself, effects included, driven by the commanded joints and their
/// covariates (plant.commanded_samples): the floor, what the control noise alone leaves.
PoseErrors poseErrors(const sim::TrueArm& truth, const PlantSamples& plant);

struct ErrorSummary {
  double position_avg_m = 0, position_max_m = 0;
  Eigen::Vector3d orientation_avg_rad = Eigen::Vector3d::Zero();
  Eigen::Vector3d orientation_max_rad = Eigen::Vector3d::Zero();
};
ErrorSummary summarize(const PoseErrors& errors);

/// Per base-frame axis (Liu et al. 2012 Table 5, eq. 16): the RMS sqrt(mean e_x^2) and the largest |e_x|
/// of the position and of the orientation components, over the configurations.
struct AxisErrorSummary {
  Eigen::Vector3d position_rms_m = Eigen::Vector3d::Zero(), position_max_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d orientation_rms_rad = Eigen::Vector3d::Zero(), orientation_max_rad = Eigen::Vector3d::Zero();
};
AxisErrorSummary summarizeAxes(const PoseErrors& errors);

/// (initial - calibrated) / initial, the paper's ratio.
inline double improvement(double initial, double calibrated) { return (initial - calibrated) / initial; }

/// Wang et al. 2023 Table 4 layout: rows position / X / Y / Z orientation x extreme / average; one column
/// pair (value, ratio) per method after the initial column. Markdown, mm and deg.
std::string formatTable4(const ErrorSummary& initial, const std::vector<std::pair<std::string, ErrorSummary>>& methods);

}  // namespace orbcal::calib
