#include "orbcal/sim/urdf_export.hpp"

#include <sstream>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/urdf.hpp"

namespace orbcal::sim {

namespace {

std::string triple(const Eigen::Vector3d& v) {
  const Eigen::Vector3d w = v.array() + 0.0;  // -0 written as 0
  return exactNumber(w.x()) + " " + exactNumber(w.y()) + " " + exactNumber(w.z());
}

/// <origin xyz=".." rpy=".."/> of T, numbers written exactly.
std::string originTag(const Eigen::Isometry3d& T) {
  return "<origin xyz=\"" + triple(T.translation()) + "\" rpy=\"" + triple(rpyFromRotation(T.linear())) + "\"/>";
}

/// Row j's transform split around its joint's rotation: linkTransform(q) = before * Rot(axis, q) * after.
struct SplitRow {
  Eigen::Isometry3d before = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d after = Eigen::Isometry3d::Identity();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
};
SplitRow splitRow(DhConvention convention, const DhRow& row) {
  SplitRow s;
  const Eigen::Isometry3d fixed = linkTransform(convention, row, 0.0);
  switch (convention) {
    case DhConvention::kModified: s.before = fixed; break;  // Rx Tx Rz(theta) Tz(d), then Rz(q)
    case DhConvention::kUrdf:
      s.before = fixed;  // T(xyz) R(rpy) Rot(axis, theta), then Rot(axis, q)
      s.axis = row.axis;
      break;
    case DhConvention::kStandard:
    case DhConvention::kHayati: s.after = fixed; break;  // Rz(q), then Rz(theta) Tz(d) Tx(a) Rx(alpha) (Ry(beta))
  }
  return s;
}

/// A link with the point mass `mass_kg` at `com_m` (its frame), or a bare link when the mass is 0.
std::string linkElement(const std::string& name, double mass_kg, const Eigen::Vector3d& com_m) {
  if (mass_kg == 0.0) return "  <link name=\"" + name + "\"/>\n";
  return "  <link name=\"" + name + "\">\n    <inertial>\n      <origin xyz=\"" + triple(com_m) + "\" rpy=\"0 0 0\"/>\n      <mass value=\"" +
         exactNumber(mass_kg) + "\"/>\n      <inertia ixx=\"0\" ixy=\"0\" ixz=\"0\" iyy=\"0\" iyz=\"0\" izz=\"0\"/>\n    </inertial>\n  </link>\n";
}

std::string jointElement(const std::string& name, const char* type, const std::string& parent, const std::string& child,
                         const Eigen::Isometry3d& origin, const std::string& extra) {
  return "  <joint name=\"" + name + "\" type=\"" + type + "\">\n    <parent link=\"" + parent + "\"/>\n    <child link=\"" + child +
         "\"/>\n    " + originTag(origin) + "\n" + extra + "  </joint>\n";
}

}  // namespace

std::string urdfJointName(const Arm& arm, int j) {
  const std::size_t u = static_cast<std::size_t>(j);
  if (u < arm.urdf.joint_names.size() && !arm.urdf.joint_names[u].empty()) return arm.urdf.joint_names[u];
  return "joint" + std::to_string(j + 1);
}

std::string urdfFromDh(const Arm& arm, const std::string& comment) {
  const int n = arm.numJoints();
  const bool masses = !arm.masses.links.empty();
  std::ostringstream s;
  s << "<?xml version=\"1.0\"?>\n";
  if (!comment.empty()) s << xmlComment(comment);
  s << "<robot name=\"" << xmlEscaped(arm.name.empty() ? "arm" : arm.name) << "\">\n";
  s << linkElement("base_link", 0.0, Eigen::Vector3d::Zero());
  Eigen::Isometry3d pending = arm.base_T_first;  // what lies between the last joint written and the next
  for (int j = 0; j < n; ++j) {
    const SplitRow r = splitRow(arm.convention, arm.joints[static_cast<std::size_t>(j)]);
    const std::string parent = j == 0 ? "base_link" : "link" + std::to_string(j), child = "link" + std::to_string(j + 1);
    const std::string limits = "    <axis xyz=\"" + triple(r.axis) + "\"/>\n    <limit lower=\"" + exactNumber(arm.lower_rad[j]) +
                               "\" upper=\"" + exactNumber(arm.upper_rad[j]) + "\" effort=\"0\" velocity=\"0\"/>\n";
    s << jointElement(urdfJointName(arm, j), "revolute", parent, child, pending * r.before, limits);
    // The body of joint j has its COM in the DH frame after the whole row: r.after maps it into the link's frame.
    const LinkMass m = masses ? arm.masses.links[static_cast<std::size_t>(j)] : LinkMass{};
    s << linkElement(child, m.mass_kg, r.after * m.com_m);
    pending = r.after;
  }
  s << jointElement("flange_joint", "fixed", "link" + std::to_string(n), "flange", pending * arm.last_T_flange, "");
  s << linkElement("flange", arm.masses.payload_kg, arm.masses.payload_com_flange_m);
  s << "</robot>\n";
  return s.str();
}

std::string calibratedUrdf(const Arm& calibrated, const std::string& comment) {
  if (calibrated.convention == DhConvention::kUrdf && !calibrated.urdf.empty()) {
    return replaceUrdfOrigins(readTextSource(calibrated.urdf.file), calibrated, comment);
  }
  return urdfFromDh(calibrated, comment);
}

void writeCalibratedUrdf(const Arm& calibrated, const std::string& path, const std::string& comment) {
  writeFileAtomic(path, calibratedUrdf(calibrated, comment));
}

}  // namespace orbcal::sim
