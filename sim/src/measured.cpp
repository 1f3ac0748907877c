#include "orbcal/sim/measured.hpp"

#include "orbcal/sim/joint_limits.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/sim/urdf.hpp"
#include "measured_columns.hpp"
#include "measured_points.hpp"

namespace orbcal::sim {

namespace {

using namespace measured_columns;  // NOLINT: the description's columns, shared with measured_points.cpp

constexpr const char* kFormat = "orbcal-measurements-1";
/// Largest accepted |entry of R^T R - I|, |bottom row - [0 0 0 1]| and ||q| - 1| of a measured pose.
constexpr double kPoseTolerance = 1e-6;


// ---------------------------------------------------------------------------------------------
// The description: which columns hold what.

struct Layout {
  ColumnGroup joints, matrix, position, quaternion, torque, temperature, time, direction;
  Unit length;  ///< of the matrix's translation (position carries its own)
  Unit prismatic;  ///< joints.prismatic_unit: of the prismatic joints' columns (joints.unit: the revolute ones')
  std::vector<ColumnGroup> points;  ///< pose.points: the marker points of a rigid body, one group each
  ColumnClaims claims;     ///< the key that named each column (for a message about a column the files lack)
  std::string description;  ///< the description's file, for messages that point at its keys
  /// Every group, in the order the writer puts them in a row (after the index).
  std::array<ColumnGroup*, 8> groups() {
    return {&joints, &torque, &temperature, &time, &matrix, &position, &quaternion, &direction};
  }
  std::array<const ColumnGroup*, 8> groups() const {
    return {&joints, &torque, &temperature, &time, &matrix, &position, &quaternion, &direction};
  }
};

/// {columns: [...], unit: U} (without `unit` when `units` is empty).
ColumnGroup readColumns(const ConfigNode& node, std::size_t count, const std::string& what,
                        const std::vector<Unit>& units, ColumnClaims& claims, const std::vector<std::string>& more_keys = {}) {
  ColumnGroup g;
  std::vector<std::string> keys{"columns"};
  keys.insert(keys.end(), more_keys.begin(), more_keys.end());
  if (units.empty()) {
    node.requireOnlyKeys(keys);
  } else {
    keys.push_back("unit");
    node.requireOnlyKeys(keys);
    g.unit = readUnit(valueOf(node, "unit"), units);
  }
  g.names = readNames(valueOf(node, "columns"), count, what, claims);
  return g;
}

/// {column: NAME, unit: U}.
ColumnGroup readColumn(const ConfigNode& node, const std::vector<Unit>& units, ColumnClaims& claims) {
  node.requireOnlyKeys({"column", "unit"});
  ColumnGroup g;
  g.names = {claimColumn(valueOf(node, "column"), claims)};
  g.unit = readUnit(valueOf(node, "unit"), units);
  return g;
}

/// A quaternion_xyzw key (a layout orbcal does not read) is refused with the key to write instead.
void refuseXyzwQuaternion(const ConfigNode& pose) {
  if (!pose.has("quaternion_xyzw")) return;
  const ConfigNode q = pose["quaternion_xyzw"];
  std::string instead = "[w, x, y, z]";
  if (q.size() == 4) instead = "[" + q[3].asString() + ", " + q[0].asString() + ", " + q[1].asString() + ", " + q[2].asString() + "]";
  q.fail("orbcal reads a quaternion's columns in w, x, y, z order: list the same columns in that order under "
         "quaternion_wxyz (here quaternion_wxyz: " + printable(instead, 80) + ")");
}

void readPoseLayout(const ConfigNode& pose, Layout& l, ColumnClaims& claims) {
  refuseXyzwQuaternion(pose);
  pose.requireOnlyKeys({"matrix", "position", "quaternion_wxyz", "points", "length_unit"});
  l.length = readUnit(valueOf(pose, "length_unit"), kLengthUnits);
  const auto matrix = optionalValueOf(pose, "matrix");
  const auto position = optionalValueOf(pose, "position");
  const auto quaternion = optionalValueOf(pose, "quaternion_wxyz");
  const auto points = optionalValueOf(pose, "points");
  if (matrix.has_value() + position.has_value() + points.has_value() != 1) {
    pose.fail("expected either 'matrix' (16 column names), 'position' (3, optionally with 'quaternion_wxyz') or 'points' "
              "(a rigid body's marker points, [x, y, z] names each)");
  }
  if (points && quaternion) quaternion->fail("not with 'points' (each marker point is a position)");
  if (points) l.points = readPointColumns(*points, l.length, claims);
  if (matrix && quaternion) quaternion->fail("not with 'matrix' (the matrix holds the rotation)");
  if (matrix) l.matrix.names = readNames(*matrix, 16, "a row-major 4x4 matrix", claims);
  if (position) {
    l.position.names = readNames(*position, 3, "x, y, z", claims);
    l.position.unit = l.length;
    l.position.range = kPositionRange;
  }
  if (quaternion) l.quaternion.names = readNames(*quaternion, 4, "w, x, y, z", claims);
}

/// {columns: [...], unit: U, sense: S}: the files' torques in orbcal's sense (sense: actuator, the
/// default: the torque the joint's actuator applies, sim/gravity.hpp) or negated (sense: load: the
/// torque the load exerts on the joint), read into the actuator's sense either way.
ColumnGroup readTorqueColumns(const ConfigNode& node, std::size_t joints, const std::string& per_joint, ColumnClaims& claims) {
  node.requireOnlyKeys({"columns", "unit", "sense"});
  ColumnGroup g;
  g.unit = readUnit(valueOf(node, "unit"), kTorqueUnits);
  g.names = readNames(valueOf(node, "columns"), joints, per_joint, claims);
  if (const auto sense = optionalValueOf(node, "sense")) {
    const std::string v = sense->asString();
    if (v != "actuator" && v != "load") {
      sense->fail("expected actuator (the torque the joint's actuator applies, orbcal's sense) or load (the load's "
                  "torque on the joint, the negative), got " + quoteInput(v));
    }
    if (v == "load") g.unit.multiply = -g.unit.multiply;
  }
  return g;
}

void readCovariateLayout(const ConfigNode& cov, std::size_t joints, const std::string& per_joint, Layout& l,
                         ColumnClaims& claims) {
  cov.requireOnlyKeys({"torque", "temperature", "time", "direction"});
  if (const auto n = optionalValueOf(cov, "torque")) l.torque = readTorqueColumns(*n, joints, per_joint, claims);
  if (const auto n = optionalValueOf(cov, "temperature")) l.temperature = readColumn(*n, kTemperatureUnits, claims);
  if (const auto n = optionalValueOf(cov, "time")) l.time = readColumn(*n, kTimeUnits, claims);
  if (const auto n = optionalValueOf(cov, "direction")) l.direction = readColumns(*n, joints, per_joint, {}, claims);
  l.torque.range = kTorqueRange;
  l.temperature.range = kTemperatureRange;
  l.time.range = kTimeRange;
}

Layout readLayout(const ConfigNode& root, const Arm& arm) {
  const auto joints = static_cast<std::size_t>(arm.numJoints());
  const std::string per_joint = "one per joint of " + arm.source;
  Layout l;
  l.description = root.source();
  ColumnClaims& claims = l.claims;
  const ConfigNode jn = valueOf(root, "joints");
  l.joints = readColumns(jn, joints, per_joint, kAngleUnits, claims, {"prismatic_unit"});
  if (arm.hasPrismatic() && !jn.has("prismatic_unit")) jn.fail("prismatic_unit (m or mm) is required: " + arm.source + " has a prismatic joint");
  if (jn.has("prismatic_unit")) l.prismatic = readUnit(valueOf(jn, "prismatic_unit"), kLengthUnits);
  readPoseLayout(valueOf(root, "pose"), l, claims);
  if (const auto cov = optionalValueOf(root, "covariates")) readCovariateLayout(*cov, joints, per_joint, l, claims);
  return l;
}

/// `path` relative to `folder` unless absolute or builtin:NAME; lexically normal ("a/../b" is "b").
std::string resolvePath(const std::string& folder, const std::string& path) {
  const std::filesystem::path p(path);  // a builtin: name has no separator to normalise
  return (path.rfind("builtin:", 0) == 0 || p.is_absolute() || folder.empty() ? p : std::filesystem::path(folder) / p).lexically_normal().string();
}

/// format, robot (loaded) and files.
void readSources(const ConfigNode& root, MeasuredData& d) {
  const ConfigNode format = valueOf(root, "format");
  if (format.asString() != kFormat) format.fail("expected '" + std::string(kFormat) + "', got '" + format.asString() + "'");
  const std::string folder = std::filesystem::path(d.description).parent_path().string();
  // robot: FILE, or {file: FILE, base_link: L, tip_link: T} for the chain between two links of a URDF.
  const ConfigNode robot = valueOf(root, "robot");
  RobotSource source;
  if (robot.isMap()) {
    robot.requireOnlyKeys({"file", "base_link", "tip_link"});
    source.path = resolvePath(folder, valueOf(robot, "file").asString());
    if (const auto base = optionalValueOf(robot, "base_link")) source.base_link = base->asString();
    if (const auto tip = optionalValueOf(robot, "tip_link")) source.tip_link = tip->asString();
    const bool links = !source.base_link.empty() || !source.tip_link.empty();
    if (links && !looksLikeXml(readTextNamedBy(source.path, robot.source() + ": robot.file"))) robot.fail("base_link and tip_link choose a chain in a URDF; " + source.path + " is not one");
  } else {
    source.path = resolvePath(folder, robot.asString());
  }
  d.robot_file = source.path;
  d.arm = loadArm(source, robot.source() + ": robot" + (robot.isMap() ? ".file" : ""));
  const ConfigNode files = valueOf(root, "files");
  if (files.size() == 0) files.fail("expected at least one CSV file");
  for (std::size_t i = 0; i < files.size(); ++i) d.files.push_back(resolvePath(folder, files[i].asString()));
}


/// The top-level `key` ({xyz_m, rpy_deg}): required when `sharing` is kKnown, an error otherwise.
Eigen::Isometry3d readKnownFrame(const ConfigNode& root, const std::string& key, FrameSharing sharing,
                                 const std::string& registration_key) {
  const auto node = optionalValueOf(root, key);
  if (sharing != FrameSharing::kKnown) {
    if (node) node->fail("given, but registration." + registration_key + " is not 'known'");
    return Eigen::Isometry3d::Identity();
  }
  if (!node) throw InputError(root.source() + ": " + key + ": missing (registration." + registration_key + " is 'known')");
  return node->asTransform();
}

void readRegistration(const ConfigNode& root, MeasuredData& d) {
  const ConfigNode reg = valueOf(root, "registration");
  reg.requireOnlyKeys({"base", "marker"});
  d.base = readFrameSharing(valueOf(reg, "base"));
  d.marker = readFrameSharing(valueOf(reg, "marker"));
  d.world_T_base = readKnownFrame(root, "world_T_base", d.base, "base");
  d.flange_T_marker = readKnownFrame(root, "flange_T_marker", d.marker, "marker");
}

/// The number at `key` within [lo, hi] (`range` says it in the key's unit), times `to_si`, when given.
std::optional<double> readSigma(const ConfigNode& noise, const std::string& key, double lo, double hi,
                                const std::string& range, double to_si) {
  const auto node = optionalValueOf(noise, key);
  if (!node) return std::nullopt;
  return node->asDoubleWithin(lo, hi, range) * to_si;
}

void readNoise(const ConfigNode& root, MeasuredData& d) {
  const auto noise = optionalValueOf(root, "noise");
  if (!noise) return;
  noise->requireOnlyKeys({"position_mm", "rotation_deg", "joint_deg"});
  const auto range = [](double lo, double hi, const char* unit) {
    return formatNumber("%.9g", lo) + " " + unit + " to " + formatNumber("%.9g", hi) + " " + unit + " (1 sigma per axis)";
  };
  d.noise_position_m = readSigma(*noise, "position_mm", kMinNoisePositionMm, kMaxNoisePositionMm,
                                 range(kMinNoisePositionMm, kMaxNoisePositionMm, "mm"), 1e-3);
  d.noise_rotation_rad = readSigma(*noise, "rotation_deg", kMinNoiseRotationDeg, kMaxNoiseRotationDeg,
                                   range(kMinNoiseRotationDeg, kMaxNoiseRotationDeg, "deg"), kDegToRad);
  d.noise_joint_rad = readSigma(*noise, "joint_deg", 0.0, kMaxNoiseJointDeg, "0 to 10 deg (0: readings exact)", kDegToRad);
}

// ---------------------------------------------------------------------------------------------
// The CSV files.

/// `l` with the column index of every name in `t` (InputError naming the file and the key for a missing one).
Layout bindColumns(Layout l, const CsvTable& t) {
  for (ColumnGroup* g : l.groups()) {
    g->index.clear();
    for (const std::string& name : g->names) g->index.push_back(requireNamedColumn(t, name, l.claims, l.description));
  }
  for (ColumnGroup& g : l.points) {
    g.index.clear();
    for (const std::string& name : g.names) g.index.push_back(requireNamedColumn(t, name, l.claims, l.description));
  }
  return l;
}

/// "<file>: line L: <first>..<last>: " for a message about a run of columns.
std::string columnsAt(const CsvTable& t, std::size_t r, const std::string& first, const std::string& last) {
  return t.where(r) + ": " + first + ".." + last + ": ";
}

Eigen::VectorXd readJoints(const CsvTable& t, std::size_t r, const Layout& l, const Arm& arm, JointLimitWarnings& limits) {
  const ColumnGroup& g = l.joints;
  Eigen::VectorXd q(static_cast<Eigen::Index>(g.index.size()));
  for (Eigen::Index j = 0; j < q.size(); ++j) {
    const Unit& u = arm.isPrismatic(static_cast<int>(j)) ? l.prismatic : g.unit;
    q[j] = u.toSi(t.number(r, g.index[static_cast<std::size_t>(j)]));
    if (limits.accept(arm, static_cast<int>(j), q[j])) continue;
    const bool edge_unit = u.name == jointEdgeUnit(arm, static_cast<int>(j));  // else also said in deg or mm, as the limits are
    throw InputError(t.where(r) + ": " + g.names[static_cast<std::size_t>(j)] + ": " + formatNumber("%.9g", u.fromSi(q[j])) + " " +
                     u.name + (edge_unit ? "" : " (" + formatJointValue(arm, static_cast<int>(j), q[j]) + ")") + " " +
                     outsideLimitsText(arm, static_cast<int>(j)) +
                     angleUnitHint(u.fromSi(q[j]), u, arm, static_cast<int>(j), l.description));
  }
  return q;
}

/// Throws unless R is a rotation: max |R^T R - I| <= kPoseTolerance and det R > 0.
void checkRotation(const Eigen::Matrix3d& R, const std::string& at) {
  const double off = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (off > kPoseTolerance) {
    throw InputError(at + "rotation is not orthonormal: max |R^T R - I| = " + formatNumber("%.3g", off) +
                     " (tolerance 1e-6)");
  }
  if (R.determinant() < 0.0) throw InputError(at + "rotation is a reflection (det R = -1)");
}

Eigen::Isometry3d readMatrixPose(const CsvTable& t, std::size_t r, const Layout& l) {
  const Eigen::VectorXd v = readGroup(t, r, l.matrix);
  const Eigen::Matrix4d m = Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(v.data());
  const std::vector<std::string>& n = l.matrix.names;
  if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > kPoseTolerance) {
    throw InputError(columnsAt(t, r, n[12], n[15]) + "bottom row of the pose matrix is [" + formatNumber("%.9g", m(3, 0)) +
                     " " + formatNumber("%.9g", m(3, 1)) + " " + formatNumber("%.9g", m(3, 2)) + " " +
                     formatNumber("%.9g", m(3, 3)) + "], expected [0 0 0 1]");
  }
  checkRotation(m.topLeftCorner<3, 3>(), columnsAt(t, r, n[0], n[10]));
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = m.topLeftCorner<3, 3>();
  for (int i = 0; i < 3; ++i) {
    T.translation()[i] = l.length.toSi(m(i, 3));
    checkWithin(t, r, l.matrix.index[static_cast<std::size_t>(4 * i + 3)], T.translation()[i], l.length, kPositionRange);
  }
  return T;
}

/// Unit quaternion from w, x, y, z; a norm within kPoseTolerance of 1 is normalised.
Eigen::Quaterniond readQuaternion(const CsvTable& t, std::size_t r, const ColumnGroup& g) {
  const Eigen::VectorXd v = readGroup(t, r, g);
  Eigen::Quaterniond q(v[0], v[1], v[2], v[3]);
  const double norm = q.norm();
  if (std::abs(norm - 1.0) > kPoseTolerance) {
    throw InputError(columnsAt(t, r, g.names.front(), g.names.back()) + "quaternion norm " + formatNumber("%.9g", norm) +
                     " differs from 1 by more than 1e-6");
  }
  return q.normalized();
}

Eigen::VectorXd readDirections(const CsvTable& t, std::size_t r, const ColumnGroup& g) {
  const Eigen::VectorXd d = readGroup(t, r, g);
  for (Eigen::Index j = 0; j < d.size(); ++j) {
    if (d[j] == -1.0 || d[j] == 0.0 || d[j] == 1.0) continue;
    throw InputError(t.where(r) + ": " + g.names[static_cast<std::size_t>(j)] +
                     ": expected an approach direction of -1, 0 or 1, got " + formatNumber("%.9g", d[j]));
  }
  return d;
}

MeasuredPose readPose(const CsvTable& t, std::size_t r, const Layout& l, const Arm& arm, int session, JointLimitWarnings& limits) {
  MeasuredPose p;
  p.where = t.where(r);
  JointSample& s = p.sample;
  s.session = session;
  s.q_rad = readJoints(t, r, l, arm, limits);
  if (l.matrix.given()) {
    p.world_T_marker = readMatrixPose(t, r, l);
  } else if (l.position.given()) {
    p.world_T_marker.translation() = readGroup(t, r, l.position);
    p.has_rotation = l.quaternion.given();
    if (p.has_rotation) p.world_T_marker.linear() = readQuaternion(t, r, l.quaternion).toRotationMatrix();
  }
  if (l.torque.given()) s.tau_Nm = readGroup(t, r, l.torque);
  if (l.temperature.given()) s.temperature_C = readGroup(t, r, l.temperature)[0];
  if (l.time.given()) s.time_s = readGroup(t, r, l.time)[0];
  if (l.direction.given()) s.direction = readDirections(t, r, l.direction);
  return p;
}

/// Throws when row r's time is earlier than row r - 1's: the rows of a file are its samples in the
/// order they were taken (approach directions and drift read that order).
void checkTimeOrder(const CsvTable& t, std::size_t r, const ColumnGroup& time, double previous_s, double now_s) {
  if (r == 0 || now_s >= previous_s) return;
  const auto in = [&time](double s) { return formatNumber("%.9g", time.unit.fromSi(s)) + " " + time.unit.name; };
  throw InputError(t.where(r) + ": " + time.names[0] + ": " + in(now_s) + " is earlier than " + in(previous_s) + " on line " +
                   std::to_string(t.line(r - 1)) + " (time runs backwards; the rows of a file are samples in the order taken)");
}

void readSession(const std::string& path, int session, const Layout& layout, MeasuredData& d, JointLimitWarnings& limits) {
  const std::string named_by = d.description + ": files[" + std::to_string(session) + "]";
  const CsvTable t = [&] {
    const std::string text = readTextNamedBy(path, named_by);
    try {
      return CsvTable::parse(text, path);
    } catch (const InputError& e) {  // a file that is no table at all (a wrong path?): named with the key, too
      throw InputError(named_by + ": " + e.what());
    }
  }();
  if (t.rows() == 0) throw InputError(path + ": no data rows (expected one sample per line after the header)");
  const Layout bound = bindColumns(layout, t);
  for (std::size_t r = 0; r < t.rows(); ++r) {
    MeasuredPose p = readPose(t, r, bound, d.arm, session, limits);
    if (bound.time.given()) checkTimeOrder(t, r, bound.time, r > 0 ? d.poses.back().sample.time_s : 0.0, p.sample.time_s);
    if (bound.points.empty()) d.poses.push_back(std::move(p));
    else readPointRow(t, r, bound.points, p, d.poses);
  }
}

// ---------------------------------------------------------------------------------------------
// Writing.

/// The columns writeMeasuredData writes, SI units.
Layout outputLayout(const MeasuredData& d, int joints) {
  const auto perJoint = [joints](const std::string& prefix, const std::string& suffix) {
    std::vector<std::string> names;
    for (int j = 1; j <= joints; ++j) names.push_back(prefix + std::to_string(j) + suffix);
    return names;
  };
  Layout l;
  l.joints = {perJoint("q", "_rad"), kAngleUnits[0], {}, {}};
  for (int j = 0; j < joints; ++j) l.joints.names[static_cast<std::size_t>(j)] = "q" + std::to_string(j + 1) + "_" + jointSiUnit(d.arm, j);
  if (d.points > 0) l.points = pointOutputColumns(d.points);
  else l.position = {{"x_m", "y_m", "z_m"}, kLengthUnits[0], {}, {}};
  bool rotation = false;
  for (const MeasuredPose& p : d.poses) rotation |= p.has_rotation;
  if (rotation) l.quaternion.names = {"qw", "qx", "qy", "qz"};
  if (d.has_torque) {
    l.torque = {perJoint("tau", "_Nm"), kTorqueUnits[0], {}, {}};
    for (int j = 0; j < joints; ++j) l.torque.names[static_cast<std::size_t>(j)] = jointEffortColumn(d.arm, j);  // a force: tau1_N
  }
  if (d.has_temperature) l.temperature = {{"temperature_C"}, kTemperatureUnits[0], {}, {}};
  if (d.has_time) l.time = {{"time_s"}, kTimeUnits[0], {}, {}};
  if (d.has_direction) l.direction.names = perJoint("dir", "");
  l.length = kLengthUnits[0];
  return l;
}

/// The cells of one written row (SI units), in the order of Layout::groups().
std::vector<double> rowCells(const MeasuredPose& p, const Layout& l) {
  std::vector<double> c;
  const auto add = [&c](const Eigen::VectorXd& v) { c.insert(c.end(), v.data(), v.data() + v.size()); };
  add(p.sample.q_rad);
  if (l.torque.given()) add(p.sample.tau_Nm);
  if (l.temperature.given()) c.push_back(p.sample.temperature_C);
  if (l.time.given()) c.push_back(p.sample.time_s);
  if (l.position.given()) add(p.world_T_marker.translation());
  if (l.quaternion.given()) {
    const Eigen::Quaterniond q(p.world_T_marker.linear());
    add(Eigen::Vector4d(q.w(), q.x(), q.y(), q.z()));
  }
  if (l.direction.given()) add(p.sample.direction);
  return c;
}

std::string formatSessionCsv(const std::vector<const MeasuredPose*>& poses, const Layout& l) {
  std::ostringstream out;
  out << "index";
  std::size_t columns = 0;
  for (const ColumnGroup* g : l.groups()) {
    for (const std::string& name : g->names) out << "," << name;
    columns += g->names.size();
  }
  out << "\n";
  for (std::size_t k = 0; k < poses.size(); ++k) {
    const std::vector<double> cells = rowCells(*poses[k], l);
    const bool finite = std::all_of(cells.begin(), cells.end(), [](double v) { return std::isfinite(v); });
    if (cells.size() != columns || !finite) {
      throw std::invalid_argument("writeMeasuredData: sample " + std::to_string(k) + " of its session (" +
                                  poses[k]->where + "): " + std::to_string(cells.size()) + " values for " +
                                  std::to_string(columns) + " columns, or one not finite");
    }
    out << k;
    for (double v : cells) out << "," << exactNumber(v);
    out << "\n";
  }
  return out.str();
}

/// A YAML double-quoted string (paths may hold ',', '#' or ': ').
std::string quoted(const std::string& text) {
  std::string q = "\"";
  for (char c : text) q += (c == '"' || c == '\\') ? std::string("\\") + c : std::string(1, c);
  return q + "\"";
}

std::string joined(const std::vector<std::string>& items) {
  std::string s;
  for (const std::string& item : items) s += (s.empty() ? "" : ", ") + item;
  return s;
}

std::string yamlList(const std::vector<std::string>& items) { return "[" + joined(items) + "]"; }



std::string formatCovariates(const Layout& l) {
  std::ostringstream s;
  if (l.torque.given()) s << "  torque: {columns: " << yamlList(l.torque.names) << ", unit: N*m}\n";
  if (l.temperature.given()) s << "  temperature: {column: " << l.temperature.names[0] << ", unit: degC}\n";
  if (l.time.given()) s << "  time: {column: " << l.time.names[0] << ", unit: s}\n";
  if (l.direction.given()) s << "  direction: {columns: " << yamlList(l.direction.names) << "}\n";
  const std::string body = s.str();
  return body.empty() ? "" : "covariates:\n" + body;
}

std::string formatDescription(const MeasuredData& d, const std::string& robot_file,
                              const std::vector<std::string>& files, const Layout& l) {
  std::ostringstream s;
  s << "# Measured data written by orbcal " << ORBCAL_VERSION << " (format: sim/include/orbcal/sim/measured.hpp)\n";
  s << "format: " << kFormat << "\n";
  std::vector<std::string> quoted_files;
  for (const std::string& f : files) quoted_files.push_back(quoted(f));
  s << "robot: " << quoted(robot_file) << "\n";
  s << "files: " << yamlList(quoted_files) << "\n";
  s << "joints: {columns: " << yamlList(l.joints.names) << ", unit: rad" << (d.arm.hasPrismatic() ? ", prismatic_unit: m}\n" : "}\n");
  std::vector<std::string> points;
  for (const ColumnGroup& g : l.points) points.push_back(yamlList(g.names));
  s << "pose: {" << (l.points.empty() ? "position: " + yamlList(l.position.names) : "points: " + yamlList(points));
  if (l.quaternion.given()) s << ", quaternion_wxyz: " << yamlList(l.quaternion.names);
  s << ", length_unit: m}\n";
  s << formatCovariates(l);
  s << "registration: {base: " << frameSharingName(d.base) << ", marker: " << frameSharingName(d.marker) << "}\n";
  if (d.base == FrameSharing::kKnown) s << "world_T_base: " << transformYaml(d.world_T_base) << "\n";
  if (d.marker == FrameSharing::kKnown) s << "flange_T_marker: " << transformYaml(d.flange_T_marker) << "\n";
  if (d.noise_position_m || d.noise_rotation_rad || d.noise_joint_rad) {
    std::vector<std::string> keys;
    if (d.noise_position_m) keys.push_back("position_mm: " + exactNumber(*d.noise_position_m * 1e3));
    if (d.noise_rotation_rad) keys.push_back("rotation_deg: " + exactNumber(*d.noise_rotation_rad * kRadToDeg));
    if (d.noise_joint_rad) keys.push_back("joint_deg: " + exactNumber(*d.noise_joint_rad * kRadToDeg));
    s << "noise: {" << joined(keys) << "}\n";
  }
  return s.str();
}

/// The poses of each session, in order; every session from 0 to the largest must have one.
std::vector<std::vector<const MeasuredPose*>> posesBySession(const MeasuredData& d) {
  std::vector<std::vector<const MeasuredPose*>> sessions(static_cast<std::size_t>(d.numSessions()));
  for (const MeasuredPose& p : d.poses) {
    if (p.sample.session < 0) throw std::invalid_argument("writeMeasuredData: " + p.where + ": negative session");
    const auto s = static_cast<std::size_t>(p.sample.session);
    if (s >= sessions.size()) sessions.resize(s + 1);
    sessions[s].push_back(&p);
  }
  for (std::size_t s = 0; s < sessions.size(); ++s) {
    if (sessions[s].empty()) throw std::invalid_argument("writeMeasuredData: session " + std::to_string(s) + " has no samples");
  }
  return sessions;
}

}  // namespace

MeasuredData loadMeasuredData(const std::string& description_path) {
  const ConfigNode root = ConfigNode::load(description_path);
  if (root.has("images")) root["images"].fail("a description of images (sim/image_views.hpp): `orbcal calibrate` reads it, for the hand-eye and board frames");
  root.requireOnlyKeys({"format", "robot", "files", "joints", "pose", "covariates", "registration", "noise",
                        "world_T_base", "flange_T_marker"});
  MeasuredData d;
  d.description = description_path;
  readSources(root, d);
  const Layout layout = readLayout(root, d.arm);
  readRegistration(root, d);
  readNoise(root, d);
  JointLimitWarnings limits;
  for (std::size_t s = 0; s < d.files.size(); ++s) readSession(d.files[s], static_cast<int>(s), layout, d, limits);
  d.has_torque = layout.torque.given();
  d.has_temperature = layout.temperature.given();
  d.has_time = layout.time.given();
  d.has_direction = layout.direction.given();
  d.length_unit = layout.length.name;
  d.angle_unit = layout.joints.unit.name;
  d.quaternion = layout.quaternion.given();
  d.points = static_cast<int>(layout.points.size());
  if (d.points > 0 && (d.marker != FrameSharing::kShared || d.base == FrameSharing::kPerSession)) {
    throw InputError(description_path + ": registration: with pose.points, marker must be shared (each point's offset on "
                     "the tool is estimated once) and base shared or known");
  }
  if (!d.has_direction) fillApproachDirections(d.poses);
  return d;
}

const char* frameSharingName(FrameSharing s) {
  switch (s) {
    case FrameSharing::kShared: return "shared";
    case FrameSharing::kPerSession: return "per_session";
    case FrameSharing::kKnown: return "known";
  }
  return "shared";
}

FrameSharing readFrameSharing(const ConfigNode& node) {
  const std::string s = node.asString();
  if (s == "shared") return FrameSharing::kShared;
  if (s == "per_session") return FrameSharing::kPerSession;
  if (s == "known") return FrameSharing::kKnown;
  node.fail("expected shared, per_session or known, got " + quoteInput(s));
}

std::string writeMeasuredData(const MeasuredData& data, const std::string& folder, const std::string& robot_file,
                              const std::string& description_name) {
  const auto sessions = posesBySession(data);
  const Layout layout = outputLayout(data, data.arm.numJoints());
  makeDirectories(folder);
  std::vector<std::string> files;
  for (std::size_t s = 0; s < sessions.size(); ++s) {
    files.push_back("session_" + std::to_string(s + 1) + ".csv");  // from 1, as frames.yaml numbers sessions
    std::vector<std::string> names;  // the columns before the points
    for (const ColumnGroup* g : layout.groups()) names.insert(names.end(), g->names.begin(), g->names.end());
    const auto cells = [&layout](const MeasuredPose& p) { return rowCells(p, layout); };
    writeFileAtomic(folder + "/" + files.back(), data.points > 0 ? formatPointsCsv(sessions[s], names, layout.points, cells)
                                                                 : formatSessionCsv(sessions[s], layout));
  }
  const std::string path = folder + "/" + description_name;
  writeFileAtomic(path, formatDescription(data, robot_file, files, layout));
  return path;
}

}  // namespace orbcal::sim
