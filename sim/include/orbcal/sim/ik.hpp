#pragma once
// Inverse kinematics by damped Newton steps on the flange pose. One joint may be locked at its
// start value (Wang et al. 2023 eq. 4 locks theta_2, the "arm plane"), which leaves a 7-joint arm with six.
#include <Eigen/Geometry>

#include "orbcal/sim/arm.hpp"

namespace orbcal::sim {

struct IkOptions {
  int locked_joint = -1;          ///< 0-based joint held at q_start (Wang et al. 2023: 1, i.e. theta_2); -1 for none
  int max_iterations = 200;
  double position_tol_m = 1e-11;  ///< convergence: flange position error below this ...
  double rotation_tol_rad = 1e-11;  ///< ... and rotation error below this
  /// Also start from the other wrist/elbow branches and from the 2 pi equivalents of each solution,
  /// and return, among the solutions within the joint limits, the one closest to q_start.
  bool least_motion = true;
};

struct IkResult {
  bool converged = false;       ///< a solution within the joint limits was found
  Eigen::VectorXd q;            ///< the solution (rad); q_start when not converged
  int iterations = 0;           ///< Newton iterations, all starts together
  double position_error_m = 0.0;
  double rotation_error_rad = 0.0;
};

IkResult inverseKinematics(const Arm& arm, const Eigen::Isometry3d& base_T_flange_target,
                           const Eigen::VectorXd& q_start, const IkOptions& options = {});

/// The value of q_j + 2 pi m (integer m) nearest to `reference` within [lower, upper]; q_j if none.
double nearestEquivalentAngle(double q, double reference, double lower, double upper);

}  // namespace orbcal::sim
