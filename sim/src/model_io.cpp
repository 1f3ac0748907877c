#include "orbcal/sim/model_io.hpp"

#include <cmath>
#include <filesystem>
#include <map>
#include <sstream>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/io.hpp"

namespace orbcal::sim {

namespace {

std::string transformList(const std::vector<Eigen::Isometry3d>& frames) {
  std::string s = "[";
  for (std::size_t k = 0; k < frames.size(); ++k) s += (k ? ", " : "") + transformYaml(frames[k]);
  return s + "]";
}

/// A value or 1-sigma of the parameter list, written only when finite (loadModelFile reads no other):
/// std::runtime_error naming the file and the row otherwise, before anything is written.
std::string number(double v, const std::string& where) {
  if (!std::isfinite(v)) throw std::runtime_error(where + ": " + exactNumber(v) + " is not a finite number; nothing written");
  return exactNumber(v);
}

/// `arm` as a robot YAML in `folder` records it: a URDF file named relative to the working directory,
/// or one inside `folder` (a calibrated URDF written beside it), named relative to `folder` instead (a
/// robot YAML's paths are read from its own folder), lexically normal; other absolute paths and
/// builtin: names as they are.
Arm besideFolder(Arm arm, const std::string& folder) {
  const std::filesystem::path file = arm.urdf.file;
  if (arm.urdf.file.empty() || arm.urdf.file.rfind("builtin:", 0) == 0) return arm;
  const std::filesystem::path from = std::filesystem::absolute(folder).lexically_normal();
  const std::filesystem::path relative = std::filesystem::absolute(file).lexically_normal().lexically_relative(from);
  const bool inside = !relative.empty() && *relative.begin() != "..";
  if (file.is_absolute() && !inside) return arm;
  arm.urdf.file = relative.string();
  return arm;
}

}  // namespace

std::string writeModelFile(const KinematicModel& m, const Eigen::VectorXd& p, const std::vector<ParameterRow>& rows,
                           const std::string& folder, const std::string& header, const std::string& model_name,
                           const std::string& robot_name, const std::vector<std::string>& alternatives) {
  if (p.size() != m.layout.size()) throw std::invalid_argument("writeModelFile: wrong parameter count");
  makeDirectories(folder);
  writeFileAtomic(folder + "/" + robot_name, formatArm(besideFolder(m.arm, folder), header));
  std::ostringstream s;
  std::istringstream lines(header);
  for (std::string line; std::getline(lines, line);) s << "# " << line << "\n";
  s << "format: orbcal-model-2\n"
    << "robot: " << robot_name << "\n"
    << "sessions: " << m.sessions << "\n"
    << "registration:\n"
    << "  base: " << frameSharingName(m.base) << "\n"
    << "  marker: " << frameSharingName(m.marker) << "\n"
    << "  world_T_base: " << transformList(m.world_T_base) << "\n"
    << "  flange_T_marker: " << transformList(m.flange_T_marker) << "\n";
  if (!m.marker_points.empty()) {
    s << "  marker_points_m: [";  // rigid-body data: each point's offset in the marker frame
    for (std::size_t k = 0; k < m.marker_points.size(); ++k) {
      const Eigen::Vector3d& x = m.marker_points[k];
      s << (k ? ", " : "") << "[" << exactNumber(x[0]) << ", " << exactNumber(x[1]) << ", " << exactNumber(x[2]) << "]";
    }
    s << "]\n";
  }
  s << "effects:" << (m.effects.empty() ? " []" : "") << "\n";
  for (std::size_t k = 0; k < m.effects.size(); ++k) {
    s << "  - {spec: \"" << formatEffect(m.effects[k]) << "\", parameters: {";
    bool first = true;
    for (const int blk : m.effect_blocks[k]) {
      const ParamBlock& b = m.layout.block(blk);
      for (int i = 0; i < b.size(); ++i) {
        s << (first ? "" : ", ") << b.params[static_cast<std::size_t>(i)].name << ": " << exactNumber(p[b.offset + i]);
        first = false;
      }
    }
    s << "}";
    // The ranges of the variables that drive it over the data it was fitted on (display units).
    const std::vector<FittedRange>& ranges = m.effects[k].fittedRanges();
    if (!ranges.empty()) {
      s << ", range: {";
      for (std::size_t i = 0; i < ranges.size(); ++i) {
        const std::string where = folder + "/" + model_name + ": effects[" + std::to_string(k) + "].range." + ranges[i].column;
        s << (i ? ", " : "") << ranges[i].column << ": [" << number(ranges[i].lo, where) << ", " << number(ranges[i].hi, where) << "]";
      }
      s << "}";
    }
    s << "}\n";
  }
  if (!alternatives.empty()) {
    s << "alternatives: [";
    for (std::size_t k = 0; k < alternatives.size(); ++k) s << (k ? ", " : "") << "\"" << alternatives[k] << "\"";
    s << "]\n";
  }
  s << "parameters:" << (rows.empty() ? " []" : "") << "\n";
  for (const ParameterRow& r : rows) {
    const std::string where = folder + "/" + model_name + ": parameters: " + r.name;
    s << "  - {name: " << r.name << ", effect: " << r.effect << ", value: " << number(r.value, where + ".value")
      << ", sigma: " << number(r.sigma, where + ".sigma")
      << ", unit: \"" << r.unit << "\", held: " << (r.held ? "true" : "false") << "}\n";
  }
  const std::string path = folder + "/" + model_name;
  writeFileAtomic(path, s.str());
  return path;
}

namespace {

/// The effects' parameter values: effects[k].parameters of `list`, every one of the model's and no
/// other, each within its physical bound.
Eigen::VectorXd readEffectValues(const ConfigNode& list, const KinematicModel& model) {
  Eigen::VectorXd p = Eigen::VectorXd::Zero(model.layout.size());
  for (std::size_t k = 0; k < list.size(); ++k) {
    const ConfigNode params = list[k]["parameters"];
    std::vector<std::string> allowed;
    for (const int blk : model.effect_blocks[k]) {
      const ParamBlock& b = model.layout.block(blk);
      for (int i = 0; i < b.size(); ++i) {
        const ParamInfo& info = b.params[static_cast<std::size_t>(i)];
        allowed.push_back(info.name);
        p[b.offset + i] = readParameterValue(params[info.name], info);
      }
    }
    params.requireOnlyKeys(allowed);
  }
  return p;
}

/// An effect's `range:` (optional): one [lo, hi] per driving variable of its kind, lo <= hi, no other key.
Effect readFittedRanges(const ConfigNode& e, const Effect& effect, const Arm& arm) {
  if (!e.has("range")) return effect;
  const ConfigNode range = e["range"];
  std::vector<std::string> allowed;
  std::vector<FittedRange> out;
  for (const DrivingVariable& v : effect.kind().drivingVariables(effect, arm)) {
    allowed.push_back(v.column);
    if (!range.has(v.column)) continue;
    const Eigen::VectorXd lh = range[v.column].asVector(2);
    if (!(lh[0] <= lh[1])) range[v.column].fail("expected [lo, hi] with lo <= hi");
    out.push_back({v.column, lh[0], lh[1]});
  }
  range.requireOnlyKeys(allowed);
  return effect.withFittedRanges(std::move(out));
}

/// A 1-sigma of the parameter list: a finite number from 0 (asDouble refuses '.nan' and infinities).
void checkSigma(const ConfigNode& sigma) {
  if (!(sigma.asDouble() >= 0.0)) sigma.fail("a 1-sigma must not be negative");
}

/// `parameters:` against the model it lists: one row per parameter of `full` (the model with its
/// geometry, as fitted), in its order, with its name, block and unit; values within their physical
/// bounds, and an effect's value the one `effects:` gives (`effect_values`: name -> value).
void checkParameterList(const ConfigNode& rows, const KinematicModel& full, const std::map<std::string, double>& effect_values) {
  if (rows.size() != static_cast<std::size_t>(full.layout.size())) {
    rows.fail("expected " + std::to_string(full.layout.size()) + " rows, one per parameter of the model above (geometry, "
              "registration, effects), got " + std::to_string(rows.size()));
  }
  for (int i = 0; i < full.layout.size(); ++i) {
    const ConfigNode row = rows[static_cast<std::size_t>(i)];
    row.requireOnlyKeys({"name", "effect", "value", "sigma", "unit", "held"});
    const ParamInfo& info = full.layout.param(i);
    const std::string block = full.layout.block(full.layout.blockOf(i)).effect;
    for (const auto& [key, expected] : {std::pair<const char*, std::string>{"name", info.name}, {"effect", block}, {"unit", info.unit}}) {
      if (row[key].asString() != expected) {
        row[key].fail("expected " + quoteInput(expected) + " (parameter " + std::to_string(i + 1) + " of the model above), got " +
                      quoteInput(row[key].asString()));
      }
    }
    const double value = readParameterValue(row["value"], info);
    const auto given = effect_values.find(info.name);
    if (given != effect_values.end() && given->second != value) {
      row["value"].fail(exactNumber(value) + " differs from the value in effects, " + exactNumber(given->second));
    }
    checkSigma(row["sigma"]);
    (void)row["held"].asBool();
  }
}

}  // namespace

Arm loadRobotNamedBy(const ConfigNode& root, const std::string& path) {
  const std::string robot = root["robot"].asString();
  const std::filesystem::path dir = std::filesystem::path(path).parent_path();
  const std::string robot_path =
      robot.rfind("builtin:", 0) == 0 || std::filesystem::path(robot).is_absolute() ? robot : (dir / robot).string();
  return loadArm(RobotSource{robot_path, "", ""}, path + ": robot");
}

LoadedModel loadModelFile(const std::string& path) {
  const ConfigNode root = ConfigNode::load(path);
  root.requireOnlyKeys({"format", "robot", "sessions", "registration", "effects", "parameters", "alternatives"});
  // Format 1 wrote a compliance with the other sign (dq = +c tau); files without one read the same.
  const std::string format = root["format"].asString();
  if (format != "orbcal-model-2" && format != "orbcal-model-1") root["format"].fail("expected orbcal-model-2");
  const Arm arm = loadRobotNamedBy(root, path);
  const int sessions = root["sessions"].asInt();
  if (sessions < 1 || sessions > 10000) root["sessions"].fail("must be within 1 to 10000");
  const ConfigNode reg = root["registration"];
  reg.requireOnlyKeys({"base", "marker", "world_T_base", "flange_T_marker", "marker_points_m"});
  std::vector<Eigen::Vector3d> points;
  if (reg.has("marker_points_m")) {
    const ConfigNode list = reg["marker_points_m"];
    for (std::size_t k = 0; k < list.size(); ++k) points.push_back(list[k].asVectorWithin(3, -kMaxLengthM, kMaxLengthM, "within 10 km"));
  }
  const FrameSharing base = readFrameSharing(reg["base"]), marker = readFrameSharing(reg["marker"]);
  const auto frames = [&](const char* key, FrameSharing sharing) {
    const ConfigNode list = reg[key];
    const std::size_t expected = sharing == FrameSharing::kPerSession ? static_cast<std::size_t>(sessions) : 1;
    if (list.size() != expected) list.fail("expected " + std::to_string(expected) + " frames");
    std::vector<Eigen::Isometry3d> out;
    for (std::size_t k = 0; k < expected; ++k) out.push_back(list[k].asTransform());
    return out;
  };
  std::vector<Effect> effects;
  const ConfigNode list = root["effects"];
  for (std::size_t k = 0; k < list.size(); ++k) {
    const ConfigNode e = list[k];
    e.requireOnlyKeys({"spec", "parameters", "range"});
    effects.push_back(readFittedRanges(e, parseEffect(e["spec"].asString(), arm.numJoints(), path + ": effects[" + std::to_string(k) + "].spec"), arm));
    if (format == "orbcal-model-1" && !effects.back().kind().signConvention().empty()) {
      e["spec"].fail("a format orbcal-model-1 file gave " + effects.back().name() +
                     " the other sign; calibrate again (orbcal-model-2: positive compliance sags)");
    }
    (void)e["parameters"];  // required (read below, once the layout is known)
  }
  LoadedModel out;
  KinematicModel full;
  try {
    const auto world_T_base = frames("world_T_base", base), flange_T_marker = frames("flange_T_marker", marker);
    out.model = makeKinematicModel(arm, sessions, base, marker, world_T_base, flange_T_marker, effects, false, points);
    full = makeKinematicModel(arm, sessions, base, marker, world_T_base, flange_T_marker, effects, true, points);
  } catch (const std::invalid_argument& e) {
    throw InputError(path + ": effects: " + e.what());
  }
  out.p = readEffectValues(list, out.model);
  std::map<std::string, double> effect_values;
  for (const std::vector<int>& blocks : out.model.effect_blocks) {
    for (const int blk : blocks) {
      const ParamBlock& b = out.model.layout.block(blk);
      for (int i = 0; i < b.size(); ++i) effect_values[b.params[static_cast<std::size_t>(i)].name] = out.p[b.offset + i];
    }
  }
  checkParameterList(root["parameters"], full, effect_values);
  if (root.has("alternatives")) {
    const ConfigNode alts = root["alternatives"];
    for (std::size_t k = 0; k < alts.size(); ++k) {
      const std::string name = alts[k].asString();
      if (name.empty() || std::filesystem::path(name).is_absolute() || name.find("..") != std::string::npos) {
        alts[k].fail("expected a file name beside the model file");
      }
      out.alternatives.push_back((std::filesystem::path(path).parent_path() / name).string());
    }
  }
  return out;
}

}  // namespace orbcal::sim
