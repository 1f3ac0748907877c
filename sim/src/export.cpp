#include "orbcal/sim/export.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/model_io.hpp"
#include "orbcal/sim/urdf_export.hpp"

namespace orbcal::sim {

namespace {

std::string commentLines(const std::string& header) {
  std::ostringstream s;
  std::istringstream lines(header);
  for (std::string line; std::getline(lines, line);) s << "# " << line << "\n";
  return s.str();
}

std::string numberList(std::initializer_list<double> values) {
  std::string s = "[";
  for (const double v : values) s += (s.size() > 1 ? ", " : "") + exactNumber(v);
  return s + "]";
}

/// {session: .., matrix: [[..] x4], xyz_m: [..], quaternion_xyzw: [..]} of T.
std::string frameEntry(const std::string& session, const Eigen::Isometry3d& T) {
  const Eigen::Matrix4d M = T.matrix();
  std::string rows;
  for (int r = 0; r < 4; ++r) rows += (r ? ", " : "") + numberList({M(r, 0), M(r, 1), M(r, 2), M(r, 3)});
  const Eigen::Quaterniond q(T.linear());
  const Eigen::Vector3d t = T.translation();
  return "{session: " + session + ", matrix: [" + rows + "], xyz_m: " + numberList({t.x(), t.y(), t.z()}) +
         ", quaternion_xyzw: " + numberList({q.x(), q.y(), q.z(), q.w()}) + "}";
}

std::string frameSection(const char* key, FrameSharing sharing, const std::vector<Eigen::Isometry3d>& frames) {
  std::string s = std::string(key) + ":\n  sharing: " + frameSharingName(sharing) + "\n  frames:\n";
  const bool per_session = sharing == FrameSharing::kPerSession;
  for (std::size_t k = 0; k < frames.size(); ++k) s += "    - " + frameEntry(per_session ? std::to_string(k + 1) : "all", frames[k]) + "\n";
  return s;
}

/// One entry of effects.yaml: an effect on one joint (or pair, for the kinds that take pairs), or a
/// global effect as a whole.
struct Entry {
  Effect effect;
  std::vector<ParamBlock> blocks;  ///< its parameters, named as in the model's layout
};

/// The model's effects split into entries: an effect on several joints gives one entry per key
/// (EffectKind::keys: "compliance:2", "compliance:4"; "coupling:3,2"), the joints divided evenly.
std::vector<Entry> entriesOf(const KinematicModel& m) {
  std::vector<Entry> out;
  for (const Effect& e : m.effects) {
    const std::size_t keys = e.kind().keys(e).size(), joints = e.joints().size();
    if (keys <= 1 || joints % keys != 0) {
      out.push_back({e, effectBlocks(e, m.arm, m.sessions)});
      continue;
    }
    const std::size_t per = joints / keys;
    for (std::size_t k = 0; k < keys; ++k) {
      const std::vector<int> part(e.joints().begin() + static_cast<std::ptrdiff_t>(k * per),
                                  e.joints().begin() + static_cast<std::ptrdiff_t>((k + 1) * per));
      const Effect sub = Effect(e.kind(), part, e.order(), e.reference()).withRange(e.lo(), e.hi());
      out.push_back({sub, effectBlocks(sub, m.arm, m.sessions)});
    }
  }
  return out;
}

/// The formula of an entry of an arm's effects ("" when it is no joint-angle correction).
std::string formulaOf(const Entry& x, const Arm& arm) {
  return x.blocks.size() == 1 ? x.effect.kind().correctionFormula(x.effect, x.blocks.front(), arm) : std::string();
}

}  // namespace

std::string formatFramesFile(const KinematicModel& m, const std::string& header) {
  std::ostringstream s;
  s << commentLines(header)
    << "# a_T_b maps coordinates in frame b to frame a: p_a = R p_b + t. matrix: the 4x4 homogeneous transform, row by row,\n"
    << "# translation in metres; xyz_m: t; quaternion_xyzw: R as a unit quaternion [x, y, z, w] (Hamilton).\n"
    << "# world_T_base: the robot's base in the measuring system's frame; flange_T_marker: the marker (or tool) on the flange.\n"
    << "# sharing: shared (one frame for every session), per_session (one per session), known (given, not estimated).\n"
    << "format: orbcal-frames-1\n"
    << "sessions: " << m.sessions << "\n"
    << frameSection("world_T_base", m.base, m.world_T_base) << frameSection("flange_T_marker", m.marker, m.flange_T_marker);
  return s.str();
}

std::string formatEffectsFile(const KinematicModel& m, const Eigen::VectorXd& p, const std::string& robot, const std::string& header) {
  if (p.size() != m.layout.size()) throw std::invalid_argument("formatEffectsFile: wrong parameter count");
  std::map<std::string, double> values;
  for (const std::vector<int>& blocks : m.effect_blocks) {
    for (const int blk : blocks) {
      const ParamBlock& b = m.layout.block(blk);
      for (int i = 0; i < b.size(); ++i) values[b.params[static_cast<std::size_t>(i)].name] = p[b.offset + i];
    }
  }
  std::ostringstream s;
  s << commentLines(header)
    << "# Joint N stands at qN + dqN: qN its reading (rad; m for a prismatic joint), dqN the sum of the formulas of its joint_angle\n"
    << "# entries, evaluated at the readings q, the actuators' torques tau (N m, about the joint axis; a prismatic joint's force\n"
    << "# along it, N) and the approach directions dir (+1/-1, 0: did not move). To reach qN, command c with c + dqN(c) = qN\n"
    << "# (c = qN - dqN(c), iterated). Parameters in SI. See docs/export.md.\n"
    << "format: orbcal-effects-1\n"
    << "robot: " << robot << "\n"
    << "sessions: " << m.sessions << "\n"
    << "joints: [";
  for (int j = 0; j < m.arm.numJoints(); ++j) {
    s << (j ? ", " : "") << "{joint: " << j + 1 << ", name: " << jsonString(urdfJointName(m.arm, j))
      << ", type: " << jointTypeName(m.arm.joints[static_cast<std::size_t>(j)].type) << "}";
  }
  s << "]\neffects:" << (m.effects.empty() ? " []" : "") << "\n";
  for (const Entry& x : entriesOf(m)) {
    const std::string formula = formulaOf(x, m.arm);
    s << "  - effect: " << x.effect.name() << "\n    spec: " << jsonString(x.effect.spec()) << "\n";
    if (!formula.empty()) {
      const int j = x.effect.joints().front();
      s << "    joint: " << j + 1 << "\n    joint_name: " << jsonString(urdfJointName(m.arm, j)) << "\n";
    }
    s << "    applies_to: " << (formula.empty() ? "chain" : "joint_angle") << "\n"
      << (formula.empty() ? "    description: " + jsonString(x.effect.kind().words(x.effect)) : "    formula: " + jsonString(formula))
      << "\n    parameters:\n";
    for (const ParamBlock& b : x.blocks) {
      for (const ParamInfo& info : b.params) {
        const double v = values.at(info.name);
        if (!std::isfinite(v)) throw std::runtime_error("effects: " + info.name + ": " + exactNumber(v) + " is not a finite number");
        s << "      - {name: " << info.name << ", value: " << exactNumber(v) << ", unit: " << jsonString(info.unit) << "}\n";
      }
    }
  }
  return s.str();
}

LoadedEffects loadEffectsFile(const std::string& path) {
  const ConfigNode root = ConfigNode::load(path);
  root.requireOnlyKeys({"format", "robot", "sessions", "joints", "effects"});
  if (root["format"].asString() != "orbcal-effects-1") root["format"].fail("expected orbcal-effects-1");
  const Arm arm = loadRobotNamedBy(root, path);
  const int sessions = root["sessions"].asInt();
  if (sessions < 1 || sessions > 10000) root["sessions"].fail("must be within 1 to 10000");
  const ConfigNode joints = root["joints"];
  if (joints.size() != static_cast<std::size_t>(arm.numJoints())) {
    joints.fail("expected " + std::to_string(arm.numJoints()) + " joints, those of " + root["robot"].asString());
  }
  for (int j = 0; j < arm.numJoints(); ++j) {
    const ConfigNode n = joints[static_cast<std::size_t>(j)];
    n.requireOnlyKeys({"joint", "name", "type"});
    if (n["joint"].asInt() != j + 1) n["joint"].fail("expected " + std::to_string(j + 1));
    const std::string type = jointTypeName(arm.joints[static_cast<std::size_t>(j)].type);
    if (n["type"].asString() != type) n["type"].fail("expected " + type + " (the robot's)");
    if (n["name"].asString() != urdfJointName(arm, j)) n["name"].fail("expected " + quoteInput(urdfJointName(arm, j)) + " (the robot's)");
  }
  const ConfigNode list = root["effects"];
  std::vector<Effect> effects;
  for (std::size_t k = 0; k < list.size(); ++k) {
    const ConfigNode e = list[k];
    e.requireOnlyKeys({"effect", "spec", "joint", "joint_name", "applies_to", "formula", "description", "parameters"});
    effects.push_back(parseEffect(e["spec"].asString(), arm.numJoints(), path + ": effects[" + std::to_string(k) + "].spec"));
    if (e["effect"].asString() != effects.back().name()) e["effect"].fail("expected " + quoteInput(effects.back().name()) + " (the spec's)");
  }
  LoadedEffects out;
  try {
    out.model = makeKinematicModel(arm, sessions, FrameSharing::kKnown, FrameSharing::kKnown, {Eigen::Isometry3d::Identity()},
                                   {Eigen::Isometry3d::Identity()}, effects, false);
  } catch (const std::invalid_argument& e) {
    throw InputError(path + ": effects: " + e.what());
  }
  out.p = Eigen::VectorXd::Zero(out.model.layout.size());
  for (std::size_t k = 0; k < list.size(); ++k) {
    const ConfigNode e = list[k];
    Entry x{effects[k], {}};
    for (const int blk : out.model.effect_blocks[k]) x.blocks.push_back(out.model.layout.block(blk));
    const std::string formula = formulaOf(x, arm);
    if (e["applies_to"].asString() != (formula.empty() ? "chain" : "joint_angle")) {
      e["applies_to"].fail(std::string("expected ") + (formula.empty() ? "chain" : "joint_angle") + " for " + effects[k].spec());
    }
    if (!formula.empty()) {
      const int j = effects[k].joints().front();
      if (e["joint"].asInt() != j + 1) e["joint"].fail("expected " + std::to_string(j + 1) + " (the spec's)");
      if (e["joint_name"].asString() != urdfJointName(arm, j)) e["joint_name"].fail("expected " + quoteInput(urdfJointName(arm, j)));
      if (e["formula"].asString() != formula) e["formula"].fail("differs from the formula of " + effects[k].spec() + ": " + formula);
    }
    const ConfigNode params = e["parameters"];
    std::size_t row = 0;
    for (const ParamBlock& b : x.blocks) {
      for (int i = 0; i < b.size(); ++i, ++row) {
        const ParamInfo& info = b.params[static_cast<std::size_t>(i)];
        if (row >= params.size()) params.fail("expected " + info.name + " and the rest of " + effects[k].spec() + "'s parameters");
        const ConfigNode r = params[row];
        r.requireOnlyKeys({"name", "value", "unit"});
        if (r["name"].asString() != info.name) r["name"].fail("expected " + quoteInput(info.name));
        if (r["unit"].asString() != info.unit) r["unit"].fail("expected " + quoteInput(info.unit) + " (SI)");
        out.p[b.offset + i] = readParameterValue(r["value"], info);
      }
    }
    if (row != params.size()) params.fail("expected " + std::to_string(row) + " parameters, those of " + effects[k].spec());
  }
  return out;
}

}  // namespace orbcal::sim
