#include <algorithm>
#include <filesystem>
#include <sstream>
#include <string>
#include <tuple>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/sim/urdf.hpp"

namespace orbcal::sim {

namespace {

const char* kLengthRange = "-10000 m to 10000 m";  // kMaxLengthM
const char* kAngleRange = "-360 deg to 360 deg";

/// A DH row; `beta_deg` (optional, default 0) only in the Hayati convention.
DhRow readRow(const ConfigNode& n, const char* theta_key, DhConvention convention) {
  DhRow r;
  r.a_m = n["a_m"].asDoubleWithin(-kMaxLengthM, kMaxLengthM, kLengthRange);
  r.alpha_rad = n["alpha_deg"].asDoubleWithin(-360.0, 360.0, kAngleRange) * kDegToRad;
  r.d_m = n["d_m"].asDoubleWithin(-kMaxLengthM, kMaxLengthM, kLengthRange);
  r.theta_rad = n[theta_key].asDoubleWithin(-360.0, 360.0, kAngleRange) * kDegToRad;
  if (n.has("beta_deg")) {
    if (convention != DhConvention::kHayati) {
      n["beta_deg"].fail(std::string("is accepted only with convention hayati, not ") + conventionName(convention));
    }
    r.beta_rad = n["beta_deg"].asDoubleWithin(-360.0, 360.0, kAngleRange) * kDegToRad;
  }
  return r;
}

/// A fixed transform: {dh: {a_m, alpha_deg, d_m, theta_deg[, beta_deg]}} in the arm's convention, or
/// {xyz_m: [...], rpy_deg: [...]}; absent means identity.
Eigen::Isometry3d readFixed(const ConfigNode& n, DhConvention convention) {
  if (!n.defined()) return Eigen::Isometry3d::Identity();
  if (n.has("dh")) {
    if (convention == DhConvention::kUrdf) n["dh"].fail("is not accepted with convention urdf (use xyz_m, rpy_deg)");
    n.requireOnlyKeys({"dh"});
    const ConfigNode dh = n["dh"];
    dh.requireOnlyKeys({"a_m", "alpha_deg", "d_m", "theta_deg", "beta_deg"});
    return linkTransform(convention, readRow(dh, "theta_deg", convention), 0.0);
  }
  return n.asTransform();
}

/// A non-negative finite mass (kg).
double readMass(const ConfigNode& n) {
  return n.asDoubleWithin(0.0, 1e6, "0 kg to 1e6 kg");
}

/// The optional `masses:` section (sim/gravity.hpp): gravity, one link per joint, an optional payload.
MassModel readMasses(const ConfigNode& n, int num_joints) {
  MassModel masses;
  if (!n.defined()) return masses;
  n.requireOnlyKeys({"gravity_m_s2", "links", "payload"});
  const ConfigNode gravity = n.optional("gravity_m_s2");
  // Within 10 g: Jupiter's surface gravity is 24.8 m/s^2.
  if (gravity.defined()) masses.gravity_base = gravity.asVectorWithin(3, -100.0, 100.0, "-100 m/s^2 to 100 m/s^2 (10 g)");
  const ConfigNode links = n.optional("links");
  if (links.defined()) {
    if (static_cast<int>(links.size()) != num_joints) {
      links.fail("expected one entry per joint (" + std::to_string(num_joints) + "), got " + std::to_string(links.size()));
    }
    for (std::size_t i = 0; i < links.size(); ++i) {
      const ConfigNode l = links[i];
      l.requireOnlyKeys({"mass_kg", "com_m"});
      LinkMass link;
      link.mass_kg = readMass(l["mass_kg"]);
      link.com_m = l["com_m"].asVectorWithin(3, -kMaxLengthM, kMaxLengthM, kLengthRange);
      masses.links.push_back(link);
    }
  }
  const ConfigNode payload = n.optional("payload");
  if (payload.defined()) {
    payload.requireOnlyKeys({"mass_kg", "com_m"});
    masses.payload_kg = readMass(payload["mass_kg"]);
    const ConfigNode com = payload.optional("com_m");
    if (com.defined()) masses.payload_com_flange_m = com.asVectorWithin(3, -kMaxLengthM, kMaxLengthM, kLengthRange);
  }
  return masses;
}

}  // namespace

namespace {

/// A joint of a URDF-convention robot YAML.
/// A joint's optional `type:` (default revolute).
JointType readJointType(const ConfigNode& j) {
  const ConfigNode t = j.optional("type");
  if (!t.defined()) return JointType::kRevolute;
  const std::string v = t.asString();
  if (v == "revolute") return JointType::kRevolute;
  if (v == "prismatic") return JointType::kPrismatic;
  t.fail("expected 'revolute' or 'prismatic', got " + quoteInput(v));
}

/// A joint's limits in SI: min_deg/max_deg (a revolute joint, within ten turns) or min_m/max_m (a
/// prismatic one, within kMaxLengthM).
std::pair<double, double> readJointLimits(const ConfigNode& j, JointType type) {
  const bool slide = type == JointType::kPrismatic;
  const char* lo_key = slide ? "min_m" : "min_deg";
  const char* hi_key = slide ? "max_m" : "max_deg";
  const char* other = slide ? "min_deg" : "min_m";
  if (j.has(other)) j[other].fail(std::string("is not accepted for a ") + jointTypeName(type) + " joint (use " + lo_key + ", " + hi_key + ")");
  const double bound = slide ? kMaxLengthM : 3600.0;
  const char* range = slide ? kLengthRange : "-3600 deg to 3600 deg (ten turns)";
  const double lo = j[lo_key].asDoubleWithin(-bound, bound, range);
  const double hi = j[hi_key].asDoubleWithin(-bound, bound, range);
  if (!(lo < hi)) j[hi_key].fail(std::string("must be greater than ") + lo_key);
  const double scale = slide ? 1.0 : kDegToRad;
  return {lo * scale, hi * scale};
}

void readUrdfJoint(const ConfigNode& j, Arm& arm, JointType type) {
  j.requireOnlyKeys({"name", "type", "xyz_m", "rpy_deg", "axis", type == JointType::kPrismatic ? "offset_m" : "theta_offset_deg",
                     "fixed_before", "min_deg", "max_deg", "min_m", "max_m"});
  DhRow r;
  r.type = type;
  const ConfigNode slide_offset = j.optional("offset_m");
  if (slide_offset.defined()) r.d_m = slide_offset.asDoubleWithin(-kMaxLengthM, kMaxLengthM, kLengthRange);
  r.xyz_m = j["xyz_m"].asVectorWithin(3, -kMaxLengthM, kMaxLengthM, kLengthRange);
  r.rpy_rad = j["rpy_deg"].asVectorWithin(3, -360.0, 360.0, kAngleRange) * kDegToRad;
  const Eigen::Vector3d axis = j["axis"].asVectorWithin(3, -1e6, 1e6, "-1e6 to 1e6 (a direction, normalised)");
  if (!(axis.norm() > 1e-9)) j["axis"].fail("must not be zero");
  r.axis = axis.normalized();
  const ConfigNode offset = j.optional("theta_offset_deg");
  r.theta_rad = (offset.defined() ? offset.asDoubleWithin(-360.0, 360.0, kAngleRange) : 0.0) * kDegToRad;
  arm.joints.push_back(r);
  arm.urdf.joint_names.push_back(j.optional("name").asString(""));
  const ConfigNode before = j.optional("fixed_before");
  arm.urdf.fixed_before.push_back(before.defined() ? before.asTransform() : Eigen::Isometry3d::Identity());
}

std::string lowerExtension(const std::string& path) {
  std::string e = std::filesystem::path(path).extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return e;
}

}  // namespace

Arm loadArm(const std::string& path) { return loadArm(RobotSource{path, "", ""}); }

Arm loadArm(const RobotSource& robot) { return loadArm(robot, ""); }

namespace {
Arm parseArm(const RobotSource& robot, const std::string& text);
}  // namespace

Arm loadArm(const RobotSource& robot, const std::string& named_by) {
  const std::string text = readTextNamedBy(robot.path, named_by);
  try {
    return parseArm(robot, text);
  } catch (const InputError& e) {  // named with the file and key that named it, as readTextNamedBy does
    if (named_by.empty()) throw;
    throw InputError(named_by + ": " + e.what());
  }
}

namespace {
/// The arm of robot file `robot` (its text): a URDF or a robot YAML, told by the content.
Arm parseArm(const RobotSource& robot, const std::string& text) {
  const std::string& path = robot.path;
  const std::string ext = lowerExtension(path);
  const bool xml = looksLikeXml(text);
  if ((ext == ".urdf" || ext == ".xml") && !xml) {
    throw InputError(path + ": the extension says URDF, but the file is not XML (" +
                     (text.find(':') != std::string::npos ? "it looks like a robot YAML: rename it to .yaml" : "empty or text") + ")");
  }
  if ((ext == ".yaml" || ext == ".yml") && xml) {
    throw InputError(path + ": the extension says YAML, but the file is XML (" +
                     (text.find("<robot") != std::string::npos ? "a URDF: rename it to .urdf" : "not a robot YAML") + ")");
  }
  if (xml) return armFromUrdf(text, path, robot.base_link, robot.tip_link);
  if (!robot.base_link.empty() || !robot.tip_link.empty()) {
    throw InputError(path + ": --base-link and --tip-link choose a chain in a URDF; this robot file is YAML");
  }
  const ConfigNode root = ConfigNode::parse(text, path);
  root.requireOnlyKeys({"name", "convention", "base", "joints", "tool", "masses", "source_notes", "urdf"});
  Arm arm;
  arm.source = path;
  arm.name = printable(root["name"].asString());  // a label printed as is: no raw control bytes
  const ConfigNode conv = root["convention"];
  const std::string c = conv.asString();
  if (c == "modified") {
    arm.convention = DhConvention::kModified;
  } else if (c == "standard") {
    arm.convention = DhConvention::kStandard;
  } else if (c == "hayati") {
    arm.convention = DhConvention::kHayati;
  } else if (c == "urdf") {
    arm.convention = DhConvention::kUrdf;
  } else {
    conv.fail("expected 'modified' (Craig), 'standard', 'hayati' or 'urdf', got " + quoteInput(c));
  }
  const ConfigNode urdf = root.optional("urdf");
  if (urdf.defined()) {
    if (arm.convention != DhConvention::kUrdf) urdf.fail("is accepted only with convention urdf");
    urdf.requireOnlyKeys({"file", "base_link", "tip_link"});
    const std::filesystem::path file = urdf["file"].asString();
    // Absolute and builtin: names as they are; a YAML that is itself builtin names its URDF beside it.
    arm.urdf.file = file.is_absolute() || path.rfind("builtin:", 0) == 0 || file.string().rfind("builtin:", 0) == 0
                        ? file.string()
                        : (std::filesystem::path(path).parent_path() / file).lexically_normal().string();
    arm.urdf.base_link = urdf["base_link"].asString();
    arm.urdf.tip_link = urdf["tip_link"].asString();
  }
  arm.base_T_first = readFixed(root.optional("base"), arm.convention);
  arm.last_T_flange = readFixed(root.optional("tool"), arm.convention);
  const ConfigNode joints = root["joints"];
  const std::size_t n = joints.size();
  if (n == 0) joints.fail("expected at least one joint");
  arm.lower_rad.resize(static_cast<Eigen::Index>(n));
  arm.upper_rad.resize(static_cast<Eigen::Index>(n));
  for (std::size_t i = 0; i < n; ++i) {
    const ConfigNode j = joints[i];
    const JointType type = readJointType(j);
    if (arm.convention == DhConvention::kUrdf) {
      readUrdfJoint(j, arm, type);
    } else {
      j.requireOnlyKeys({"type", "a_m", "alpha_deg", "d_m", "theta_offset_deg", "beta_deg", "min_deg", "max_deg", "min_m", "max_m"});
      arm.joints.push_back(readRow(j, "theta_offset_deg", arm.convention));
      arm.joints.back().type = type;
    }
    std::tie(arm.lower_rad[static_cast<Eigen::Index>(i)], arm.upper_rad[static_cast<Eigen::Index>(i)]) = readJointLimits(j, type);
  }
  arm.masses = readMasses(root.optional("masses"), arm.numJoints());
  return arm;
}
}  // namespace

std::string transformYaml(const Eigen::Isometry3d& T) {
  // R = Rz(yaw) Ry(pitch) Rx(roll), as ConfigNode::asTransform reads it.
  const Eigen::Vector3d ypr = T.linear().eulerAngles(2, 1, 0);
  const Eigen::Vector3d t = T.translation();
  return "{xyz_m: [" + exactNumber(t.x()) + ", " + exactNumber(t.y()) + ", " + exactNumber(t.z()) + "], rpy_deg: [" +
         exactNumber(ypr[2] * kRadToDeg) + ", " + exactNumber(ypr[1] * kRadToDeg) + ", " + exactNumber(ypr[0] * kRadToDeg) +
         "]}";
}
namespace {

std::string vectorYaml(const Eigen::Vector3d& v) {
  return "[" + exactNumber(v.x()) + ", " + exactNumber(v.y()) + ", " + exactNumber(v.z()) + "]";
}

/// True when `m` is what loadArm makes of a file without a `masses:` section (nothing to write).
bool isDefault(const MassModel& m) {
  const MassModel d;
  return m.empty() && m.gravity_base == d.gravity_base && m.payload_com_flange_m == d.payload_com_flange_m;
}

std::string massesYaml(const MassModel& m) {
  std::ostringstream s;
  s << "masses:\n";
  s << "  gravity_m_s2: " << vectorYaml(m.gravity_base) << "\n";
  if (!m.links.empty()) {
    s << "  links:\n";
    for (const LinkMass& l : m.links) {
      s << "    - {mass_kg: " << exactNumber(l.mass_kg) << ", com_m: " << vectorYaml(l.com_m) << "}\n";
    }
  }
  if (m.payload_kg != 0.0 || !m.payload_com_flange_m.isZero(0.0)) {
    s << "  payload: {mass_kg: " << exactNumber(m.payload_kg) << ", com_m: " << vectorYaml(m.payload_com_flange_m) << "}\n";
  }
  return s.str();
}

/// ", min_deg: .., max_deg: .." (or min_m, max_m for a prismatic joint).
std::string limitsYaml(const Arm& arm, int j) {
  if (arm.isPrismatic(j)) return ", min_m: " + exactNumber(arm.lower_rad[j]) + ", max_m: " + exactNumber(arm.upper_rad[j]);
  return ", min_deg: " + exactNumber(arm.lower_rad[j] * kRadToDeg) + ", max_deg: " + exactNumber(arm.upper_rad[j] * kRadToDeg);
}
}  // namespace

std::string formatArm(const Arm& arm, const std::string& header) {
  std::ostringstream s;
  std::istringstream lines(header);
  for (std::string line; std::getline(lines, line);) s << "# " << line << "\n";
  s << "name: " << arm.name << "\n";
  s << "convention: " << conventionName(arm.convention) << "\n";
  if (arm.convention == DhConvention::kUrdf && !arm.urdf.empty()) {
    s << "urdf: {file: \"" << arm.urdf.file << "\", base_link: \"" << arm.urdf.base_link << "\", tip_link: \""
      << arm.urdf.tip_link << "\"}\n";
  }
  s << "base: " << transformYaml(arm.base_T_first) << "\n";
  s << "joints:\n";
  for (int j = 0; j < arm.numJoints(); ++j) {
    const DhRow& r = arm.joints[j];
    if (arm.convention == DhConvention::kUrdf) {
      const std::size_t u = static_cast<std::size_t>(j);
      s << "  - {";
      if (u < arm.urdf.joint_names.size() && !arm.urdf.joint_names[u].empty()) s << "name: \"" << arm.urdf.joint_names[u] << "\", ";
      s << "xyz_m: " << vectorYaml(r.xyz_m) << ", rpy_deg: " << vectorYaml(r.rpy_rad * kRadToDeg) << ", axis: " << vectorYaml(r.axis)
        << (arm.isPrismatic(j) ? ", type: prismatic, offset_m: " + exactNumber(r.d_m) : ", theta_offset_deg: " + exactNumber(r.theta_rad * kRadToDeg));
      if (u < arm.urdf.fixed_before.size() && !arm.urdf.fixed_before[u].isApprox(Eigen::Isometry3d::Identity(), 0.0)) {
        s << ", fixed_before: " << transformYaml(arm.urdf.fixed_before[u]);
      }
      s << limitsYaml(arm, j) << "}\n";
      continue;
    }
    s << "  - {" << (arm.isPrismatic(j) ? "type: prismatic, " : "") << "a_m: " << exactNumber(r.a_m) << ", alpha_deg: " << exactNumber(r.alpha_rad * kRadToDeg)
      << ", d_m: " << exactNumber(r.d_m) << ", theta_offset_deg: " << exactNumber(r.theta_rad * kRadToDeg);
    if (arm.convention == DhConvention::kHayati) s << ", beta_deg: " << exactNumber(r.beta_rad * kRadToDeg);
    s << limitsYaml(arm, j) << "}\n";
  }
  s << "tool: " << transformYaml(arm.last_T_flange) << "\n";
  if (!isDefault(arm.masses)) s << massesYaml(arm.masses);
  return s.str();
}

}  // namespace orbcal::sim
