#include "orbcal/sim/gravity.hpp"

#include <stdexcept>
#include <string>

namespace orbcal::sim {

Eigen::VectorXd gravityTorques(const Arm& arm, const MassModel& masses, const Eigen::VectorXd& q) {
  checkJointVector(arm, q, "gravityTorques");
  const int n = arm.numJoints();
  if (!masses.links.empty() && static_cast<int>(masses.links.size()) != n) {
    throw std::invalid_argument("gravityTorques: expected " + std::to_string(n) + " link masses, got " +
                                std::to_string(masses.links.size()));
  }
  const std::vector<Eigen::Isometry3d> frames = chainFrames(arm, q);  // frames[0] base_T_first ... frames[n+1] flange
  const Eigen::Vector3d& g = masses.gravity_base;

  // The joint axis (z, and a point on it) of joint j, and the frame carrying link j's body.
  //   modified DH (Craig): joint j rotates about z of frame j = frames[j + 1]; link j's frame is frame j.
  //   standard and Hayati DH: joint j rotates about z of frame j-1 = frames[j]; link j's frame is frame j = frames[j + 1].
  // Either way link j's body frame is frames[j + 1]; only the axis differs.
  const int axis_offset = arm.convention == DhConvention::kModified || arm.convention == DhConvention::kUrdf ? 1 : 0;

  // Backward sweep: the total mass and first moment (sum m_i c_i) of everything outboard of joint j.
  // The moment about o_j of the gravity on that is (S - M o_j) x g, S = sum m_i c_i, M = sum m_i.
  double M = masses.payload_kg;
  Eigen::Vector3d S = masses.payload_kg * (frames.back() * masses.payload_com_flange_m);
  Eigen::VectorXd tau(n);
  for (int j = n - 1; j >= 0; --j) {
    if (!masses.links.empty()) {
      const LinkMass& link = masses.links[static_cast<std::size_t>(j)];
      M += link.mass_kg;
      S += link.mass_kg * (frames[static_cast<std::size_t>(j + 1)] * link.com_m);
    }
    const Eigen::Isometry3d& axis = frames[static_cast<std::size_t>(j + axis_offset)];
    // The URDF convention: joint j turns frame j = frames[j + 1] about its own axis (axis_offset 1).
    const Eigen::Vector3d z = arm.convention == DhConvention::kUrdf ? Eigen::Vector3d(axis.linear() * arm.joints[static_cast<std::size_t>(j)].axis)
                                                                  : Eigen::Vector3d(axis.linear().col(2));
    const Eigen::Vector3d o = axis.translation();
    // A prismatic joint carries a force (N) along its axis: dU/dq_j = -M z . g, everything outboard
    // moving by z per metre of travel.
    tau[j] = arm.isPrismatic(j) ? -M * z.dot(g) : -z.dot((S - M * o).cross(g));
  }
  return tau;
}

}  // namespace orbcal::sim
