#pragma once
// Joint readings past a joint's limits: one rule for every reader of joint readings (measured CSVs,
// datasets' samples.csv, Python arrays), and the warnings of what it accepts.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "orbcal/sim/arm.hpp"

namespace orbcal::sim {

/// Readings past a joint's limits, one rule for every reader (measured CSVs, datasets' samples.csv,
/// Python arrays): a real encoder reads past a URDF's soft limit (the TIAGo data of FIGAROH, Nguyen et
/// al. 2023, has a torso reading of 0.350181 m against a 0.35 m limit), so a reading beyond a limit by
/// at most kJointLimitTolerance of the joint's range is accepted with a warning; further out it is
/// refused as no reading of this arm.
inline constexpr double kJointLimitTolerance = 0.02;
/// How far q (SI) lies beyond joint j's limits: > 0 above the upper, < 0 below the lower, 0 within.
double jointLimitExcess(const Arm& arm, int joint, double q);
/// True when q lies beyond a limit of joint j by more than kJointLimitTolerance of its range.
bool clearlyOutsideLimits(const Arm& arm, int joint, double q);
/// "is outside the joint limits [-90, 90] deg of FILE by more than 2% of the joint's range (3.6 deg)":
/// the tail of a refusal, in the joint's edge unit.
std::string outsideLimitsText(const Arm& arm, int joint);
/// Readings accepted within the tolerance, counted per joint with the largest excess, for one warning
/// per joint: "joint 1 (torso_lift_joint): 1 reading past its upper limit 350 mm, by up to 0.181 mm
/// (within 2% of the joint's range, 7 mm: accepted as the encoder reading past a soft limit)".
class JointLimitWarnings {
 public:
  /// Checks q against joint j's limits: nothing within them; counted within the tolerance; false (the
  /// caller refuses it) beyond.
  bool accept(const Arm& arm, int joint, double q);
  std::vector<std::string> lines(const Arm& arm) const;

 private:
  std::vector<int> count_;
  std::vector<double> worst_;  ///< signed excess of largest magnitude, per joint
};
/// The warnings of every reading in `readings` (one joint vector each) past a limit within the
/// tolerance, one line per joint (JointLimitWarnings); readings beyond it are the readers' refusals.
std::vector<std::string> nearLimitWarnings(const Arm& arm, const std::vector<Eigen::VectorXd>& readings);

}  // namespace orbcal::sim
