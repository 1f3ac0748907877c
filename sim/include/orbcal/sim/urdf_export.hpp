#pragma once
// A calibrated arm as a URDF, for programs outside orbcal (ROS, MoveIt, Pinocchio, simulators):
//   - an arm read from a URDF (Arm::urdf names the file): that file with the <origin> of every chain
//     joint replaced by the calibrated one (sim::replaceUrdfOrigins), everything else kept as it was
//     (links, inertials, visuals, other joints, limits);
//   - any other arm (a DH table): a URDF of the chain alone, from link "base_link" to link "flange",
//     one link per DH frame. Joint i ("joint<i>") turns about its link's z axis (its own axis for a
//     URDF-convention table) after a fixed origin, which holds what of the DH row does not turn with
//     q_i: for modified DH {i-1}_T_{i} = [Rx(alpha) Tx(a) Rz(theta) Tz(d)] Rz(q) (Rz(q) and Tz(d)
//     commute), so the row is joint i's origin; for standard and Hayati DH {i-1}_T_{i} = Rz(q) [Rz(theta)
//     Tz(d) Tx(a) Rx(alpha) (Ry(beta))], so the row goes into joint i+1's origin, and the last row with the
//     tool into a fixed joint "flange_joint". The base transform is joint 1's origin. Limits are the
//     arm's (effort and velocity 0: orbcal knows none). With a mass model, each link carries its body's
//     mass as a point mass at its centre of mass (zero inertia tensor) and the payload sits on
//     "flange", so that a URDF reader lumping the links (sim::armFromUrdf) gets the same gravity
//     torques; a URDF has no gravity vector: the one it implies is -9.80665 m/s^2 along -z of the base.
// In both cases forwardKinematics of the URDF's chain (base and tip link of Arm::urdf for the first;
// the root link to the only leaf for the second) is that of the arm.
#include <string>

#include "orbcal/sim/arm.hpp"

namespace orbcal::sim {

/// The URDF text of `calibrated` (above). `comment` (if not empty) goes in an XML comment before <robot>.
/// For an arm from a URDF the file Arm::urdf.file is read (InputError naming it when unreadable).
std::string calibratedUrdf(const Arm& calibrated, const std::string& comment = "");

/// calibratedUrdf written to `path` atomically (sim::writeFileAtomic).
void writeCalibratedUrdf(const Arm& calibrated, const std::string& path, const std::string& comment = "");

/// The URDF of a DH-table arm's chain (the second case above).
std::string urdfFromDh(const Arm& arm, const std::string& comment = "");

/// The name of joint j (from 0) as the URDF that calibratedUrdf writes calls it: the URDF's own name for
/// an arm read from one, else "joint<j+1>".
std::string urdfJointName(const Arm& arm, int j);

}  // namespace orbcal::sim
