#include "orbcal/sim/joint_limits.hpp"

#include <cmath>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"

namespace orbcal::sim {

double jointLimitExcess(const Arm& arm, int joint, double q) {
  if (q > arm.upper_rad[joint]) return q - arm.upper_rad[joint];
  if (q < arm.lower_rad[joint]) return q - arm.lower_rad[joint];
  return 0.0;
}

namespace {
double limitTolerance(const Arm& arm, int joint) {
  return kJointLimitTolerance * (arm.upper_rad[joint] - arm.lower_rad[joint]);
}
std::string edgeValue(const Arm& arm, int joint, double si) { return formatNumber("%.6g", si * jointEdgeScale(arm, joint)); }
}  // namespace

bool clearlyOutsideLimits(const Arm& arm, int joint, double q) {
  return !(std::abs(jointLimitExcess(arm, joint, q)) <= limitTolerance(arm, joint));  // NaN: outside
}

std::string outsideLimitsText(const Arm& arm, int joint) {
  const std::string unit = jointEdgeUnit(arm, joint);
  return "is outside the joint limits [" + edgeValue(arm, joint, arm.lower_rad[joint]) + ", " + edgeValue(arm, joint, arm.upper_rad[joint]) +
         "] " + unit + " of " + arm.source + " by more than " + formatNumber("%g", kJointLimitTolerance * 100.0) +
         "% of the joint's range (" + edgeValue(arm, joint, limitTolerance(arm, joint)) + " " + unit + ")";
}

bool JointLimitWarnings::accept(const Arm& arm, int joint, double q) {
  const double excess = jointLimitExcess(arm, joint, q);
  if (excess == 0.0) return true;
  if (clearlyOutsideLimits(arm, joint, q)) return false;
  const auto j = static_cast<std::size_t>(joint);
  if (count_.size() <= j) count_.resize(j + 1, 0), worst_.resize(j + 1, 0.0);
  ++count_[j];
  if (std::abs(excess) > std::abs(worst_[j])) worst_[j] = excess;
  return true;
}

std::vector<std::string> JointLimitWarnings::lines(const Arm& arm) const {
  std::vector<std::string> out;
  for (std::size_t j = 0; j < count_.size(); ++j) {
    if (count_[j] == 0) continue;
    const int i = static_cast<int>(j);
    const std::string unit = jointEdgeUnit(arm, i);
    const std::string name = j < arm.urdf.joint_names.size() ? " (" + arm.urdf.joint_names[j] + ")" : "";
    const bool upper = worst_[j] > 0.0;
    out.push_back("joint " + std::to_string(i + 1) + name + ": " + std::to_string(count_[j]) + (count_[j] == 1 ? " reading" : " readings") +
                  " past its " + (upper ? "upper" : "lower") + " limit " + edgeValue(arm, i, upper ? arm.upper_rad[i] : arm.lower_rad[i]) +
                  " " + unit + " of " + arm.source + ", by up to " + edgeValue(arm, i, std::abs(worst_[j])) + " " + unit + " (within " +
                  formatNumber("%g", kJointLimitTolerance * 100.0) + "% of the joint's range, " + edgeValue(arm, i, limitTolerance(arm, i)) +
                  " " + unit + ": accepted as an encoder reading past a soft limit)");
  }
  return out;
}

std::vector<std::string> nearLimitWarnings(const Arm& arm, const std::vector<Eigen::VectorXd>& readings) {
  JointLimitWarnings w;
  for (const Eigen::VectorXd& q : readings) {
    for (int j = 0; j < q.size() && j < arm.numJoints(); ++j) w.accept(arm, j, q[j]);
  }
  return w.lines(arm);
}

}  // namespace orbcal::sim
