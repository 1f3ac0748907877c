#pragma once
// URDF in and out (urdfdom, Debian's liburdfdom-dev). The chain between two links of a URDF becomes an
// Arm of the URDF convention (arm.hpp): one row per movable joint with its origin (xyz, rpy), axis and
// a zero offset, 7 error parameters a joint. Along the chain:
//   - a fixed joint folds into the next movable joint's origin (Arm::urdf.fixed_before keeps it, so
//     that the joint's own origin can be written back), or, after the last one, into the tool;
//   - a continuous joint is a revolute joint without limits: it gets [-180, 180] deg;
//   - a prismatic, planar or floating joint is an error.
// base_T_first is the identity: the base link is the arm's base frame; the tip link is the flange.
// Masses (Arm::masses, for static gravity torques, sim/gravity.hpp) come from the links' <inertial>
// (mass, and COM = its origin's position; the inertia tensor is not used): LinkMass j lumps exactly
// (total mass, COM = sum(m c) / sum(m)) every link that moves rigidly with movable joint j, its COM in
// joint j's child link frame: the child link, links below it through fixed joints (also after the
// tip) and side branches (e.g. gripper fingers) through joints off the chain, a movable one taken at
// its zero position (the static torques of one fixed posture). Links before the first movable joint
// do not move and are left out. Gravity is -9.80665 m/s^2 along -z of the base link (a URDF has no
// gravity); no payload. No <inertial> on any moving link: no mass model, as before; a joint whose
// links have none gets mass 0. A negative or non-finite mass is an error naming the link.
// Errors are InputError "<file>: <what>", naming the link or joint.
#include <string>
#include <string_view>

#include "orbcal/sim/arm.hpp"

namespace orbcal::sim {

/// True when `text` starts (after a UTF-8 BOM and white space) with '<': XML, not YAML.
bool looksLikeXml(const std::string& text);

/// The chain from `base_link` to `tip_link` of the URDF `xml` (read from `source`, for messages and
/// Arm::urdf.file). An empty base_link means the root link; an empty tip_link the only leaf link
/// (an error naming them when there are several). Arm::masses lumps the moving links' <inertial>
/// (above), empty when they have none.
Arm armFromUrdf(const std::string& xml, const std::string& source, const std::string& base_link = "",
                const std::string& tip_link = "");

/// Joint j's own URDF origin in `arm` (URDF convention): fixed_before^-1 T(xyz) R(rpy) Rot(axis, theta),
/// the zero offset folded in, so that the URDF's joint at q = 0 is the arm's joint at its offset.
Eigen::Isometry3d urdfJointOrigin(const Arm& arm, int j);

/// "<!-- text -->\n", every "--" of `text` (which would end the comment) written "- -".
std::string xmlComment(const std::string& text);
/// `text` as XML (and HTML) character data or an attribute value: & < > " ' escaped.
std::string xmlEscaped(std::string_view text);

/// `xml` (the URDF `arm` was read from) with the <origin> of every chain joint replaced by
/// urdfJointOrigin (full precision), everything else kept byte for byte; `comment` (if not empty)
/// goes in an XML comment before <robot>.
std::string replaceUrdfOrigins(const std::string& xml, const Arm& arm, const std::string& comment = "");

/// Roll, pitch, yaw (rad) of R = Rz(yaw) Ry(pitch) Rx(roll), pitch in [-pi/2, pi/2].
Eigen::Vector3d rpyFromRotation(const Eigen::Matrix3d& R);

}  // namespace orbcal::sim
