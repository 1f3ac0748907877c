#include "orbcal/sim/urdf.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <console_bridge/console.h>
#include <mutex>
#include <urdf_parser/urdf_parser.h>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::sim {

bool looksLikeXml(const std::string& text) {
  std::size_t i = text.compare(0, 3, "\xEF\xBB\xBF") == 0 ? 3 : 0;
  while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
  return i < text.size() && text[i] == '<';
}

Eigen::Vector3d rpyFromRotation(const Eigen::Matrix3d& R) {
  const double pitch = std::asin(std::clamp(-R(2, 0), -1.0, 1.0));
  if (std::abs(R(2, 0)) > 1.0 - 1e-12) {
    // Gimbal lock: only roll - yaw (pitch +90 deg) or roll + yaw (-90 deg) is defined; put it in roll.
    return Eigen::Vector3d(std::atan2(-R(1, 2), R(1, 1)), pitch, 0.0);
  }
  return Eigen::Vector3d(std::atan2(R(2, 1), R(2, 2)), pitch, std::atan2(R(1, 0), R(0, 0)));
}

namespace {

/// urdfdom reports through console_bridge; its messages are collected (not printed) while parsing.
struct CollectMessages : console_bridge::OutputHandler {
  std::string errors;
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR) errors += (errors.empty() ? "" : "; ") + text;
  }
};

/// A URDF as urdfdom read it, with the errors it reported on parts of links it skipped but still gave
/// a model for (an unreadable <inertial>, e.g. a mass "nan", is kept with mass 0).
struct ParsedUrdf {
  urdf::ModelInterfaceSharedPtr model;
  std::string errors;  ///< one line
};

ParsedUrdf parseUrdf(const std::string& xml, const std::string& source) {
  static std::mutex mutex;  // console_bridge's handler is process-wide
  const std::lock_guard<std::mutex> lock(mutex);
  CollectMessages messages;
  console_bridge::OutputHandler* previous = console_bridge::getOutputHandler();
  console_bridge::useOutputHandler(&messages);
  urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(xml);
  console_bridge::useOutputHandler(previous);
  for (char& c : messages.errors) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  if (!model) {
    const std::string why = messages.errors.empty() ? "urdfdom could not parse it" : messages.errors;
    throw InputError(source + ": not a valid URDF: " + why);
  }
  return {model, messages.errors};
}

Eigen::Isometry3d poseOf(const urdf::Pose& p) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(p.rotation.w, p.rotation.x, p.rotation.y, p.rotation.z).normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(p.position.x, p.position.y, p.position.z);
  return T;
}

/// Throws unless `p` (the origin of `what`, e.g. "joint 'j2'") lies within 10 km (kMaxLengthM) with a
/// finite rotation.
void checkOrigin(const urdf::Pose& p, const std::string& what) {
  const Eigen::Vector3d t(p.position.x, p.position.y, p.position.z);
  for (int i = 0; i < 3; ++i) {
    if (!(std::abs(t[i]) <= kMaxLengthM)) {
      throw InputError(what + ": <origin xyz>: " + formatNumber("%.9g", t[i]) + " m is outside -10000 m to 10000 m");
    }
  }
  const Eigen::Vector4d q(p.rotation.w, p.rotation.x, p.rotation.y, p.rotation.z);
  if (!q.allFinite() || !(q.norm() > 0.0)) throw InputError(what + ": <origin rpy>: not a finite rotation");
}

/// The limits of revolute or prismatic joint `what` (rad or m): finite, within ten turns or 10 km (as a
/// robot YAML's min_deg and max_deg, min_m and max_m), lower < upper.
std::pair<double, double> readLimits(const urdf::Joint& joint, const std::string& what) {
  const bool slide = joint.type == urdf::Joint::PRISMATIC;
  if (!joint.limits) throw InputError(what + ": a " + (slide ? "prismatic" : "revolute") + " joint needs <limit lower=.. upper=..>");
  for (const auto& [name, v] : {std::pair<const char*, double>{"lower", joint.limits->lower}, {"upper", joint.limits->upper}}) {
    if (slide && !(std::abs(v) <= kMaxLengthM)) {
      throw InputError(what + ": <limit " + name + ">: " + formatNumber("%.9g", v) + " m is outside -10000 m to 10000 m");
    }
    if (!slide && !(std::abs(v) <= kMaxJointAngleRad)) {
      throw InputError(what + ": <limit " + name + ">: " + formatNumber("%.9g", v) + " rad is outside " + kMaxJointAngleText);
    }
  }
  if (!(joint.limits->lower < joint.limits->upper)) {
    throw InputError(what + ": limit upper (" + exactNumber(joint.limits->upper) + ") must be greater than lower (" +
                     exactNumber(joint.limits->lower) + ")");
  }
  return {joint.limits->lower, joint.limits->upper};
}

/// Throws unless the <axis> of movable joint `what` is finite and a unit vector (to 1e-3; the URDF
/// specification asks for a normalized axis: "0 0 1e9" is no direction a file means).
void checkAxis(const urdf::Vector3& a, const std::string& what) {
  const Eigen::Vector3d axis(a.x, a.y, a.z);
  if (!axis.allFinite() || !(std::abs(axis.norm() - 1.0) <= 1e-3)) {
    throw InputError(what + ": <axis xyz>: '" + formatNumber("%.9g", a.x) + " " + formatNumber("%.9g", a.y) + " " +
                     formatNumber("%.9g", a.z) + "' is not a unit vector (length 1 within 1e-3)");
  }
}

/// Every element of the file with a physical value, on the arm's chain or not: each joint's origin
/// (within 10 km, a finite rotation) and axis (movable joints: a unit vector), each link's <inertial>
/// (mass and origin) and its <visual> and <collision> origins. A named element stays named.
void checkAllElements(const urdf::ModelInterface& model, const std::string& urdf_errors, const std::string& source);

const char* jointTypeName(int type) {
  switch (type) {
    case urdf::Joint::REVOLUTE: return "revolute";
    case urdf::Joint::CONTINUOUS: return "continuous";
    case urdf::Joint::PRISMATIC: return "prismatic";
    case urdf::Joint::FLOATING: return "floating";
    case urdf::Joint::PLANAR: return "planar";
    case urdf::Joint::FIXED: return "fixed";
    default: return "unknown";
  }
}

/// The only link without child joints below `base` (an error naming them when there are several).
std::string onlyLeaf(const urdf::LinkConstSharedPtr& base, const std::string& source) {
  std::vector<std::string> leaves;
  std::vector<urdf::LinkConstSharedPtr> stack{base};
  while (!stack.empty()) {
    const urdf::LinkConstSharedPtr link = stack.back();
    stack.pop_back();
    if (link->child_links.empty()) leaves.push_back(link->name);
    for (const auto& c : link->child_links) stack.push_back(c);
  }
  if (leaves.size() != 1) {
    std::string list;
    for (const auto& l : leaves) list += (list.empty() ? "" : ", ") + l;
    throw InputError(source + ": the URDF has " + std::to_string(leaves.size()) + " leaf links below '" + base->name + "' (" + list +
                     "): give the tip link (--tip-link)");
  }
  return leaves.front();
}

/// Bodies lumped into one: total mass and first moment sum(m c), in one frame.
struct Lumped {
  double mass_kg = 0.0;
  Eigen::Vector3d moment_kg_m = Eigen::Vector3d::Zero();
};

/// The mass (kg) of `link`'s <inertial>; an InputError naming the link when it is negative or not finite,
/// or when urdfdom could not read the <inertial> (its `urdf_errors`, ParsedUrdf::errors: how a mass
/// "nan" or "inf" shows, urdfdom keeping mass 0).
double inertialMass(const urdf::Link& link, const std::string& urdf_errors, const std::string& source) {
  const std::string what = source + ": link '" + link.name + "': <inertial>";
  if (urdf_errors.find("inertial element for Link [" + link.name + "]") != std::string::npos) {
    throw InputError(what + " not readable (urdfdom: " + urdf_errors + ")");
  }
  const double m = link.inertial->mass;
  if (!std::isfinite(m) || m < 0.0) throw InputError(what + " mass " + exactNumber(m) + " kg must be finite and not negative");
  if (m > 1e6) throw InputError(what + " mass " + exactNumber(m) + " kg is outside 0 kg to 1e6 kg");
  checkOrigin(link.inertial->origin, what);
  return m;
}

/// Adds a point mass `mass_kg` at `com_m` (in sum's frame) to `sum`.
void addPointMass(Lumped& sum, double mass_kg, const Eigen::Vector3d& com_m) {
  sum.mass_kg += mass_kg;
  sum.moment_kg_m += mass_kg * com_m;
}

/// The lumped bodies as one: COM = sum(m c) / sum(m) (the frame's origin when the mass is 0).
LinkMass asLinkMass(const Lumped& sum) {
  LinkMass l;
  l.mass_kg = sum.mass_kg;
  if (sum.mass_kg > 0.0) l.com_m = sum.moment_kg_m / sum.mass_kg;
  return l;
}

/// armFromUrdf's mass model: the <inertial> of every link below `base` that moves rigidly with movable
/// chain joint j lumped into LinkMass j, COM in joint j's child link frame (chainFrames(arm, q)[j + 1]).
/// That is the child link, links below it through fixed joints (on the chain, or after the tip) and
/// side branches through joints off the chain, fixed or not: a joint off the chain is taken at its
/// zero position (the static torques of one fixed posture). Links that no chain joint moves (the base
/// side) are left out. Empty when no moving link has an <inertial>; gravity the MassModel default,
/// -9.80665 m/s^2 along -z of the base link; no payload. `without`: the moving links with no <inertial>.
MassModel massesFromInertials(const urdf::LinkConstSharedPtr& base, const Arm& arm, const std::string& urdf_errors,
                              const std::string& source, std::vector<std::string>& without) {
  struct Visit {
    urdf::LinkConstSharedPtr link;
    int joint;                        ///< the movable chain joint the link moves with; -1: none (base side)
    Eigen::Isometry3d frame_T_link;  ///< the link's pose in that joint's child link frame
  };
  const std::vector<std::string>& names = arm.urdf.joint_names;
  std::vector<Lumped> sums(names.size());
  bool any = false;
  std::vector<Visit> stack{{base, -1, Eigen::Isometry3d::Identity()}};
  while (!stack.empty()) {
    const Visit v = stack.back();
    stack.pop_back();
    if (v.link->inertial) {  // checked on the base side too, where no joint moves it (the base link's)
      const double mass_kg = inertialMass(*v.link, urdf_errors, source);
      if (v.joint >= 0) {  // a point mass at the COM, the inertial origin's position
        addPointMass(sums[static_cast<std::size_t>(v.joint)], mass_kg,
                     v.frame_T_link * poseOf(v.link->inertial->origin).translation());
        any = true;
      }
    } else if (v.joint >= 0) {
      without.push_back(v.link->name);
    }
    for (const auto& child : v.link->child_links) {
      const urdf::JointConstSharedPtr joint = child->parent_joint;
      const auto it = std::find(names.begin(), names.end(), joint->name);
      if (it != names.end()) {
        stack.push_back({child, static_cast<int>(it - names.begin()), Eigen::Isometry3d::Identity()});
      } else {  // fixed, or movable off the chain at its zero position: the origin alone
        stack.push_back({child, v.joint, v.frame_T_link * poseOf(joint->parent_to_joint_origin_transform)});
      }
    }
  }
  MassModel masses;
  if (any) {
    for (const Lumped& s : sums) masses.links.push_back(asLinkMass(s));
  }
  return masses;
}

void checkAllElements(const urdf::ModelInterface& model, const std::string& urdf_errors, const std::string& source) {
  for (const auto& [name, joint] : model.joints_) {
    const std::string what = source + ": joint '" + name + "'";
    checkOrigin(joint->parent_to_joint_origin_transform, what);
    if (joint->type != urdf::Joint::FIXED && joint->type != urdf::Joint::FLOATING) checkAxis(joint->axis, what);
  }
  for (const auto& [name, link] : model.links_) {
    if (link->inertial) (void)inertialMass(*link, urdf_errors, source);
    for (const auto& v : link->visual_array) checkOrigin(v->origin, source + ": link '" + name + "': <visual>");
    for (const auto& c : link->collision_array) checkOrigin(c->origin, source + ": link '" + name + "': <collision>");
  }
}

}  // namespace

Arm armFromUrdf(const std::string& xml, const std::string& source, const std::string& base_link, const std::string& tip_link) {
  const ParsedUrdf parsed = parseUrdf(xml, source);
  const urdf::ModelInterfaceSharedPtr& model = parsed.model;
  checkAllElements(*model, parsed.errors, source);
  const urdf::LinkConstSharedPtr base = base_link.empty() ? model->getRoot() : model->getLink(base_link);
  if (!base) throw InputError(source + ": no link '" + base_link + "' (the base link) in the URDF");
  const std::string tip_name = tip_link.empty() ? onlyLeaf(base, source) : tip_link;
  urdf::LinkConstSharedPtr link = model->getLink(tip_name);
  if (!link) throw InputError(source + ": no link '" + tip_name + "' (the tip link) in the URDF");

  // Walk up from the tip to the base.
  std::vector<urdf::JointConstSharedPtr> chain;
  while (link->name != base->name) {
    const urdf::JointConstSharedPtr joint = link->parent_joint;
    if (!joint) {
      throw InputError(source + ": tip link '" + tip_name + "' is not below base link '" + base->name + "' (going up from '" +
                       tip_name + "' reaches the root link '" + link->name + "')");
    }
    chain.push_back(joint);
    link = model->getLink(joint->parent_link_name);
  }
  std::reverse(chain.begin(), chain.end());

  Arm arm;
  arm.source = source;
  arm.name = model->getName();
  arm.convention = DhConvention::kUrdf;
  arm.urdf.file = source;
  arm.urdf.base_link = base->name;
  arm.urdf.tip_link = tip_name;
  std::vector<double> lower, upper;
  Eigen::Isometry3d pending = Eigen::Isometry3d::Identity();  // fixed joints not yet folded
  for (const urdf::JointConstSharedPtr& joint : chain) {
    const std::string what = source + ": joint '" + joint->name + "'";  // origin and axis checked above
    const Eigen::Isometry3d origin = poseOf(joint->parent_to_joint_origin_transform);
    if (joint->type == urdf::Joint::FIXED) {
      pending = pending * origin;
      continue;
    }
    if (joint->type != urdf::Joint::REVOLUTE && joint->type != urdf::Joint::CONTINUOUS && joint->type != urdf::Joint::PRISMATIC) {
      throw InputError(what + " is " + jointTypeName(joint->type) + ": an orbcal arm has revolute (or continuous) and prismatic joints only");
    }
    const Eigen::Vector3d axis(joint->axis.x, joint->axis.y, joint->axis.z);
    const Eigen::Isometry3d combined = pending * origin;
    DhRow row;
    row.xyz_m = combined.translation();
    row.rpy_rad = rpyFromRotation(combined.linear());
    row.axis = axis.normalized();
    if (joint->type == urdf::Joint::PRISMATIC) row.type = JointType::kPrismatic;
    arm.joints.push_back(row);
    arm.urdf.joint_names.push_back(joint->name);
    arm.urdf.fixed_before.push_back(pending);
    pending = Eigen::Isometry3d::Identity();
    if (joint->type == urdf::Joint::CONTINUOUS) {
      lower.push_back(-kPi);
      upper.push_back(kPi);
    } else {
      const auto [lo, hi] = readLimits(*joint, what);
      lower.push_back(lo);
      upper.push_back(hi);
    }
  }
  if (arm.joints.empty()) {
    throw InputError(source + ": no movable joint between links '" + base->name + "' and '" + tip_name + "'");
  }
  arm.last_T_flange = pending;
  arm.lower_rad = Eigen::Map<const Eigen::VectorXd>(lower.data(), static_cast<Eigen::Index>(lower.size()));
  arm.upper_rad = Eigen::Map<const Eigen::VectorXd>(upper.data(), static_cast<Eigen::Index>(upper.size()));
  arm.masses = massesFromInertials(base, arm, parsed.errors, source, arm.urdf.links_without_inertial);
  return arm;
}

Eigen::Isometry3d urdfJointOrigin(const Arm& arm, int j) {
  const DhRow& r = arm.joints[static_cast<std::size_t>(j)];
  const Eigen::Isometry3d before = arm.urdf.fixed_before.empty() ? Eigen::Isometry3d::Identity()
                                                                  : arm.urdf.fixed_before[static_cast<std::size_t>(j)];
  return before.inverse() * linkTransform(DhConvention::kUrdf, r, 0.0);
}

namespace {

/// Position after the comment or tag starting at `i` ('<'), or npos.
std::size_t skipMarkup(const std::string& s, std::size_t i) {
  if (s.compare(i, 4, "<!--") == 0) {
    const std::size_t e = s.find("-->", i + 4);
    return e == std::string::npos ? e : e + 3;
  }
  const std::size_t e = s.find('>', i);
  return e == std::string::npos ? e : e + 1;
}

/// The value of attribute `name` in the start tag `tag` (quotes ' or "), or "" when absent.
std::string attribute(const std::string& tag, const std::string& name) {
  for (std::size_t i = tag.find(name); i != std::string::npos; i = tag.find(name, i + 1)) {
    if (i == 0 || !std::isspace(static_cast<unsigned char>(tag[i - 1]))) continue;
    std::size_t k = i + name.size();
    while (k < tag.size() && std::isspace(static_cast<unsigned char>(tag[k]))) ++k;
    if (k >= tag.size() || tag[k] != '=') continue;
    ++k;
    while (k < tag.size() && std::isspace(static_cast<unsigned char>(tag[k]))) ++k;
    if (k >= tag.size() || (tag[k] != '"' && tag[k] != '\'')) continue;
    const std::size_t e = tag.find(tag[k], k + 1);
    if (e == std::string::npos) return "";
    return tag.substr(k + 1, e - k - 1);
  }
  return "";
}

bool startsTag(const std::string& s, std::size_t i, const char* name) {
  const std::size_t n = std::char_traits<char>::length(name);
  return s.compare(i + 1, n, name) == 0 && i + 1 + n < s.size() &&
         (std::isspace(static_cast<unsigned char>(s[i + 1 + n])) || s[i + 1 + n] == '>' || s[i + 1 + n] == '/');
}

}  // namespace

std::string xmlEscaped(std::string_view text) {
  std::string out;
  for (const char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string xmlComment(const std::string& text) {
  std::string c = text;
  for (std::size_t p = c.find("--"); p != std::string::npos; p = c.find("--")) c.replace(p, 2, "- -");
  return "<!-- " + c + " -->\n";
}

std::string replaceUrdfOrigins(const std::string& xml, const Arm& arm, const std::string& comment) {
  if (arm.convention != DhConvention::kUrdf || arm.urdf.joint_names.size() != arm.joints.size()) {
    throw std::invalid_argument("replaceUrdfOrigins: the arm was not read from a URDF");
  }
  std::vector<std::string> origins(arm.joints.size());
  for (int j = 0; j < arm.numJoints(); ++j) {
    const Eigen::Isometry3d T = urdfJointOrigin(arm, j);
    const Eigen::Vector3d t = T.translation(), rpy = rpyFromRotation(T.linear());
    origins[static_cast<std::size_t>(j)] = "<origin xyz=\"" + exactNumber(t.x()) + " " + exactNumber(t.y()) + " " +
                                           exactNumber(t.z()) + "\" rpy=\"" + exactNumber(rpy.x()) + " " + exactNumber(rpy.y()) +
                                           " " + exactNumber(rpy.z()) + "\"/>";
  }
  std::vector<bool> done(arm.joints.size(), false);
  std::string out;
  std::size_t copied = 0;
  bool commented = comment.empty();
  for (std::size_t i = xml.find('<'); i != std::string::npos; i = xml.find('<', i)) {
    const std::size_t end = skipMarkup(xml, i);
    if (end == std::string::npos) break;
    if (!commented && startsTag(xml, i, "robot")) {
      out += xml.substr(copied, i - copied) + xmlComment(comment);
      copied = i;
      commented = true;
    }
    // A kinematic <joint> has a type attribute (a <transmission>'s <joint> has none).
    if (!startsTag(xml, i, "joint") || attribute(xml.substr(i, end - i), "type").empty()) {
      i = end;
      continue;
    }
    const std::string name = attribute(xml.substr(i, end - i), "name");
    const auto it = std::find(arm.urdf.joint_names.begin(), arm.urdf.joint_names.end(), name);
    const std::size_t close = xml.find("</joint>", end);
    if (it == arm.urdf.joint_names.end() || close == std::string::npos || xml[end - 2] == '/') {
      i = end;
      continue;
    }
    const std::size_t j = static_cast<std::size_t>(it - arm.urdf.joint_names.begin());
    // The joint's own <origin> (skipping comments), or none: then the new one goes first.
    std::size_t o = std::string::npos, o_end = std::string::npos;
    for (std::size_t k = xml.find('<', end); k != std::string::npos && k < close; k = xml.find('<', k)) {
      const std::size_t e = skipMarkup(xml, k);
      if (startsTag(xml, k, "origin")) {
        o = k;
        o_end = e;
        break;
      }
      k = e;
    }
    if (o == std::string::npos) {
      out += xml.substr(copied, end - copied) + origins[j];
      copied = end;
    } else {
      out += xml.substr(copied, o - copied) + origins[j];
      copied = o_end;
    }
    done[j] = true;
    i = close;
  }
  out += xml.substr(copied);
  for (std::size_t j = 0; j < done.size(); ++j) {
    if (!done[j]) throw InputError(arm.urdf.file + ": joint '" + arm.urdf.joint_names[j] + "' not found to write its origin");
  }
  return out;
}

}  // namespace orbcal::sim
