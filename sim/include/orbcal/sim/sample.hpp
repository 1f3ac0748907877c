#pragma once
// One configuration of the arm as a measurement sees it: the joint readings and the covariates that
// physical effects depend on (measured joint torques, temperature, time, the session it belongs to,
// the direction each joint approached from). SI units.
#include <Eigen/Core>
#include <limits>

namespace orbcal::sim {

struct JointSample {
  Eigen::VectorXd q_rad;   ///< joint readings (encoder side), one per joint
  Eigen::VectorXd tau_Nm;  ///< measured joint torques, one per joint; empty when not measured
  double temperature_C = std::numeric_limits<double>::quiet_NaN();  ///< NaN when not measured
  double time_s = std::numeric_limits<double>::quiet_NaN();         ///< NaN when not measured
  int session = 0;         ///< index of the file (session) the sample came from
  /// Direction each joint approached this configuration from: +1, -1, or 0 (did not move). Empty
  /// when unknown; loaders fill it from the sample order within a session (see approachDirections).
  Eigen::VectorXd direction;

  bool hasTorque() const { return tau_Nm.size() > 0; }
  bool hasTemperature() const { return temperature_C == temperature_C; }
  bool hasTime() const { return time_s == time_s; }
};

}  // namespace orbcal::sim
