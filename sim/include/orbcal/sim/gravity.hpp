#pragma once
// Static joint torques under gravity: the torque each joint must exert to hold the arm (its links'
// masses and a payload at the flange) still at joint angles q. Used where an effect needs torques
// that were not measured (compliance), and by the simulator to write a torque column.
//
// Sign convention: tau_j is the torque the joint's actuator applies about its own z axis (the DH
// joint axis), the quantity a joint torque sensor reports: tau_j = -z_j . sum_{i >= j}
// (c_i - o_j) x (m_i g), with g the gravity vector in the base frame, c_i the centre of mass of link i
// and o_j a point on axis j; equivalently tau_j = dU/dq_j, U the arm's potential energy. Every torque
// orbcal reads or writes follows it (a measurement description's `sense: load` flips a sensor that
// reports the load's torque instead); a compliance c_j > 0 makes the joint yield against it, i.e. sag
// (sim/src/effects/compliance.cpp). A prismatic joint's entry is the force (N) its actuator applies
// along its axis, -M z_j . g with M the mass outboard of it: dU/dq_j again.
#include <Eigen/Geometry>
#include <vector>

#include "orbcal/sim/arm.hpp"

namespace orbcal::sim {

/// Joint torques (N m) holding the arm still at q under the mass model (payload included). Joints and
/// links numbered from 1: link i's COM is in DH frame i (chainFrames(...)[i]) in both conventions;
/// joint i turns about z of frame i in modified DH and about z of frame i - 1 in standard DH; the
/// payload's COM is in the flange frame. Link masses may be empty (payload only), else one per joint.
/// Throws std::invalid_argument on a wrong q or link count.
Eigen::VectorXd gravityTorques(const Arm& arm, const MassModel& masses, const Eigen::VectorXd& q);

}  // namespace orbcal::sim
