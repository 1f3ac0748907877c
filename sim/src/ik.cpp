#include "orbcal/sim/ik.hpp"

#include <cmath>
#include <limits>

#include "orbcal/sim/jacobian.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::sim {

namespace {

/// Base-frame pose error [p_t - p; log(R_t R^T)] with the position part divided by L.
Vector6d scaledError(const Eigen::Isometry3d& target, const Eigen::Isometry3d& current, double L) {
  Vector6d e;
  e << (target.translation() - current.translation()) / L, logSO3(target.linear() * current.linear().transpose());
  return e;
}

/// One damped-Newton descent from q0 (locked joint fixed). Returns the final q and whether it converged.
bool newtonDescent(const Arm& arm, const Eigen::Isometry3d& target, Eigen::VectorXd& q, const IkOptions& opt,
                   int& iterations, double& pos_err, double& rot_err) {
  const int n = arm.numJoints();
  const double L = characteristicLength(arm);
  std::vector<int> free;
  for (int j = 0; j < n; ++j) {
    if (j != opt.locked_joint) free.push_back(j);
  }
  const int m = static_cast<int>(free.size());
  Vector6d e = scaledError(target, forwardKinematics(arm, q), L);
  double cost = e.squaredNorm();
  double lambda = 1e-6;
  Eigen::MatrixXd Jf(6, m);
  // A prismatic joint's variable in units of L, a revolute one's in rad (scaledManipulatorJacobian): a
  // step of 0.5 is half a radian or half the arm's length.
  Eigen::VectorXd unit(m);
  for (int k = 0; k < m; ++k) unit[k] = arm.isPrismatic(free[k]) ? L : 1.0;
  for (int it = 0; it < opt.max_iterations; ++it) {
    pos_err = e.head<3>().norm() * L;
    rot_err = e.tail<3>().norm();
    if (pos_err < opt.position_tol_m && rot_err < opt.rotation_tol_rad) return true;
    ++iterations;
    const Matrix6Xd J = scaledManipulatorJacobian(arm, q, L);
    for (int k = 0; k < m; ++k) Jf.col(k) = J.col(free[k]);
    // Levenberg-Marquardt on the scaled error; the damping vanishes as the iteration converges.
    bool improved = false;
    for (int tries = 0; tries < 12 && !improved; ++tries) {
      const Eigen::MatrixXd A = Jf * Jf.transpose() + lambda * Matrix6d::Identity();
      Eigen::VectorXd dq = Jf.transpose() * A.ldlt().solve(e);
      const double step = dq.cwiseAbs().maxCoeff();
      if (step > 0.5) dq *= 0.5 / step;  // keep steps within the region where the model is linear
      Eigen::VectorXd q_new = q;
      for (int k = 0; k < m; ++k) q_new[free[k]] += dq[k] * unit[k];
      const Vector6d e_new = scaledError(target, forwardKinematics(arm, q_new), L);
      const double cost_new = e_new.squaredNorm();
      if (cost_new < cost) {
        q = q_new;
        e = e_new;
        cost = cost_new;
        lambda = std::max(lambda * 0.1, 1e-15);
        improved = true;
      } else {
        lambda *= 10.0;
      }
    }
    if (!improved) break;  // stuck in a local minimum
  }
  pos_err = e.head<3>().norm() * L;
  rot_err = e.tail<3>().norm();
  return pos_err < opt.position_tol_m && rot_err < opt.rotation_tol_rad;
}

}  // namespace

double nearestEquivalentAngle(double q, double reference, double lower, double upper) {
  constexpr double kTwoPi = 2.0 * kPi;
  const double base = q + kTwoPi * std::round((reference - q) / kTwoPi);
  double best = q;
  double best_dist = std::numeric_limits<double>::infinity();
  for (int k = -2; k <= 2; ++k) {
    const double c = base + k * kTwoPi;
    if (c < lower || c > upper) continue;
    if (std::abs(c - reference) < best_dist) {
      best_dist = std::abs(c - reference);
      best = c;
    }
  }
  return best;
}

IkResult inverseKinematics(const Arm& arm, const Eigen::Isometry3d& target, const Eigen::VectorXd& q_start,
                           const IkOptions& opt) {
  checkJointVector(arm, q_start, "inverseKinematics: q_start");
  const int n = arm.numJoints();
  std::vector<Eigen::VectorXd> seeds{q_start};
  if (opt.least_motion) {
    // Other branches: each free revolute joint turned by +-pi from the start (wrist and elbow flips).
    for (int j = 0; j < n; ++j) {
      if (j == opt.locked_joint || arm.isPrismatic(j)) continue;
      for (double s : {kPi, -kPi}) {
        Eigen::VectorXd seed = q_start;
        seed[j] += s;
        seeds.push_back(seed);
      }
    }
  }
  IkResult best;
  best.q = q_start;
  double best_motion = std::numeric_limits<double>::infinity();
  for (const Eigen::VectorXd& seed : seeds) {
    Eigen::VectorXd q = seed;
    double pos = 0, rot = 0;
    if (!newtonDescent(arm, target, q, opt, best.iterations, pos, rot)) {
      if (!best.converged) {
        best.position_error_m = pos;
        best.rotation_error_rad = rot;
      }
      continue;
    }
    for (int j = 0; j < n; ++j) {
      if (!arm.isPrismatic(j)) q[j] = nearestEquivalentAngle(q[j], q_start[j], arm.lower_rad[j], arm.upper_rad[j]);
    }
    if (!withinLimits(arm, q)) continue;
    const double motion = (q - q_start).norm();
    if (motion < best_motion) {
      best_motion = motion;
      best.converged = true;
      best.q = q;
      best.position_error_m = pos;
      best.rotation_error_rad = rot;
    }
    if (!opt.least_motion) break;
  }
  return best;
}

}  // namespace orbcal::sim
