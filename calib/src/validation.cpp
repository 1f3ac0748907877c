#include "orbcal/calib/validation.hpp"

#include <cstdio>

#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::calib {

PlantSamples simulatePlant(const sim::Arm& true_arm, const std::vector<Eigen::VectorXd>& q_commanded,
                           double joint_noise_sigma_rad, std::mt19937_64& rng) {
  PlantSamples p;
  p.q_commanded = q_commanded;
  for (const Eigen::VectorXd& q : q_commanded) {
    p.q_true.push_back(sim::addJointNoise(q, joint_noise_sigma_rad, rng));
    p.base_T_flange_true.push_back(sim::forwardKinematics(true_arm, p.q_true.back()));
  }
  return p;
}

PlantSamples simulatePlant(const sim::TrueArm& truth, const std::vector<Eigen::VectorXd>& q_commanded,
                           double joint_noise_sigma_rad, std::mt19937_64& rng) {
  PlantSamples p;
  p.q_commanded = q_commanded;
  p.commanded_samples = commandedSamples(truth, q_commanded);
  for (std::size_t k = 0; k < q_commanded.size(); ++k) {
    p.q_true.push_back(sim::addJointNoise(q_commanded[k], joint_noise_sigma_rad, rng));
    const Eigen::VectorXd* previous = k > 0 ? &p.q_true[k - 1] : nullptr;
    p.base_T_flange_true.push_back(truth.flangePose(static_cast<int>(k), p.q_true[k], previous));
  }
  return p;
}

std::vector<sim::JointSample> commandedSamples(const sim::TrueArm& truth, const std::vector<Eigen::VectorXd>& q) {
  std::vector<sim::JointSample> out;
  for (std::size_t k = 0; k < q.size(); ++k) {
    out.push_back(truth.sample(static_cast<int>(k), q[k], k > 0 ? &q[k - 1] : nullptr));
  }
  return out;
}

namespace {
/// Pose errors of predicted flange poses against the plant's true ones.
template <class Predict>
PoseErrors poseErrorsOf(const PlantSamples& plant, Predict predict) {
  PoseErrors e;
  for (std::size_t k = 0; k < plant.q_commanded.size(); ++k) {
    const Eigen::Isometry3d T = predict(k);
    const Eigen::Isometry3d& truth = plant.base_T_flange_true[k];
    e.position_m.push_back((truth.translation() - T.translation()).norm());
    e.position_xyz_m.push_back((truth.translation() - T.translation()).cwiseAbs());
    e.orientation_rad.push_back(sim::logSO3(truth.linear() * T.linear().transpose()).cwiseAbs());
  }
  return e;
}
}  // namespace

PoseErrors poseErrors(const sim::Arm& model, const PlantSamples& plant) {
  return poseErrorsOf(plant, [&](std::size_t k) { return sim::forwardKinematics(model, plant.q_commanded[k]); });
}

PoseErrors poseErrors(const sim::TrueArm& truth, const PlantSamples& plant) {
  const std::vector<sim::JointSample> samples = plant.commanded_samples.size() == plant.q_commanded.size()
                                                    ? plant.commanded_samples
                                                    : commandedSamples(truth, plant.q_commanded);
  return poseErrorsOf(plant, [&](std::size_t k) { return truth.flangePose(samples[k]); });
}

ErrorSummary summarize(const PoseErrors& e) {
  ErrorSummary s;
  const double n = static_cast<double>(e.position_m.size());
  for (std::size_t k = 0; k < e.position_m.size(); ++k) {
    s.position_avg_m += e.position_m[k] / n;
    s.position_max_m = std::max(s.position_max_m, e.position_m[k]);
    s.orientation_avg_rad += e.orientation_rad[k] / n;
    s.orientation_max_rad = s.orientation_max_rad.cwiseMax(e.orientation_rad[k]);
  }
  return s;
}

AxisErrorSummary summarizeAxes(const PoseErrors& e) {
  AxisErrorSummary s;
  const double n = static_cast<double>(e.position_xyz_m.size());
  for (std::size_t k = 0; k < e.position_xyz_m.size(); ++k) {
    s.position_rms_m += e.position_xyz_m[k].cwiseAbs2() / n;
    s.orientation_rms_rad += e.orientation_rad[k].cwiseAbs2() / n;
    s.position_max_m = s.position_max_m.cwiseMax(e.position_xyz_m[k]);
    s.orientation_max_rad = s.orientation_max_rad.cwiseMax(e.orientation_rad[k]);
  }
  s.position_rms_m = s.position_rms_m.cwiseSqrt();
  s.orientation_rms_rad = s.orientation_rms_rad.cwiseSqrt();
  return s;
}

std::string formatTable4(const ErrorSummary& initial, const std::vector<std::pair<std::string, ErrorSummary>>& methods) {
  std::string out = "| Quantity | Stat | Initial |";
  for (const auto& [name, s] : methods) out += " " + name + " | ratio |";
  out += "\n|---|---|---|";
  for (std::size_t i = 0; i < methods.size(); ++i) out += "---|---|";
  out += "\n";
  char buf[64];
  const auto row = [&](const char* quantity, const char* stat, auto get, double scale) {
    std::snprintf(buf, sizeof buf, "| %s | %s | %.4f |", quantity, stat, get(initial) * scale);
    out += buf;
    for (const auto& [name, s] : methods) {
      std::snprintf(buf, sizeof buf, " %.4f | %.2f%% |", get(s) * scale, 100.0 * improvement(get(initial), get(s)));
      out += buf;
    }
    out += "\n";
  };
  row("Position (mm)", "extreme", [](const ErrorSummary& s) { return s.position_max_m; }, 1e3);
  row("", "average", [](const ErrorSummary& s) { return s.position_avg_m; }, 1e3);
  const char* axes[3] = {"X orient. (deg)", "Y orient. (deg)", "Z orient. (deg)"};
  for (int a = 0; a < 3; ++a) {
    row(axes[a], "extreme", [a](const ErrorSummary& s) { return s.orientation_max_rad[a]; }, sim::kRadToDeg);
    row("", "average", [a](const ErrorSummary& s) { return s.orientation_avg_rad[a]; }, sim::kRadToDeg);
  }
  return out;
}

}  // namespace orbcal::calib
