#include "orbcal/sim/hemisphere.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "orbcal/sim/ik.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::sim {

std::vector<Eigen::Vector3d> fibonacciHemisphere(int n) {
  if (n < 1) throw std::invalid_argument("fibonacciHemisphere: count " + std::to_string(n) + " < 1");
  const double golden_angle = kPi * (3.0 - std::sqrt(5.0));
  std::vector<Eigen::Vector3d> out;
  out.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const double c = 1.0 - (i + 0.5) / n;  // cos(polar angle): equal-area bands from the pole to the rim
    const double s = std::sqrt(std::max(0.0, 1.0 - c * c));
    const double phi = golden_angle * i;
    out.emplace_back(s * std::cos(phi), s * std::sin(phi), c);
  }
  return out;
}

Eigen::Matrix3d pointingRotation(const Eigen::Matrix3d& R_ref, const Eigen::Vector3d& z) {
  const Eigen::Vector3d z_ref = R_ref.col(2);
  const Eigen::Vector3d axis = z_ref.cross(z);
  const double angle = std::atan2(axis.norm(), z_ref.dot(z));
  if (axis.norm() < 1e-12) {
    if (z_ref.dot(z) > 0.0) return R_ref;
    throw std::invalid_argument("pointingRotation: target axis opposite to the reference's (swing axis undefined)");
  }
  return expSO3(axis.normalized() * angle) * R_ref;
}

HemisphereConfigurations hemisphereConfigurations(const Arm& arm, const Eigen::VectorXd& q_ref,
                                                  const HemisphereSettings& settings) {
  checkJointVector(arm, q_ref, "hemisphereConfigurations");
  if (settings.radius_m <= 0.0 || settings.target_distance_m <= 0.0) {
    throw std::invalid_argument("hemisphereConfigurations: radius and target distance must be positive");
  }
  if (settings.locked_joint < -1 || settings.locked_joint >= arm.numJoints()) {
    throw std::invalid_argument("hemisphereConfigurations: locked joint " + std::to_string(settings.locked_joint + 1) +
                                " of " + std::to_string(arm.numJoints()));
  }
  if (!withinLimits(arm, q_ref)) throw std::invalid_argument("hemisphereConfigurations: q_ref outside the joint limits");
  const std::vector<Eigen::Vector3d> lattice = fibonacciHemisphere(settings.count);

  HemisphereConfigurations out;
  out.reference_pose = forwardKinematics(arm, q_ref);
  const Eigen::Matrix3d R_ref = out.reference_pose.linear();
  const Eigen::Vector3d p_ref = out.reference_pose.translation();
  out.target = p_ref + settings.target_distance_m * R_ref.col(2);
  // The hemisphere's own frame: its pole -z_ref (away from the board), x along x_ref (right-handed).
  Eigen::Matrix3d H;
  H << R_ref.col(0), -R_ref.col(1), -R_ref.col(2);
  IkOptions ik;
  ik.locked_joint = settings.locked_joint;
  ik.least_motion = true;
  for (int i = 0; i < settings.count; ++i) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = p_ref + settings.radius_m * (H * lattice[static_cast<std::size_t>(i)]);
    pose.linear() = pointingRotation(R_ref, (out.target - pose.translation()).normalized());
    out.poses.push_back(pose);
    const IkResult r = inverseKinematics(arm, pose, q_ref, ik);
    if (r.converged && withinLimits(arm, r.q)) {
      out.q.push_back(r.q);
      out.reached.push_back(i);
    } else {
      out.unreachable.push_back(i);
    }
  }
  return out;
}

}  // namespace orbcal::sim
