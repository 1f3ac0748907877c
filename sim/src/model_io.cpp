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

std::string number(double v) { return std::isfinite(v) ? exactNumber(v) : std::string(".nan"); }

}  // namespace

std::string writeModelFile(const KinematicModel& m, const Eigen::VectorXd& p, const std::vector<ParameterRow>& rows,
                           const std::string& folder, const std::string& header, const std::string& model_name,
                           const std::string& robot_name) {
  if (p.size() != m.layout.size()) throw std::invalid_argument("writeModelFile: wrong parameter count");
  makeDirectories(folder);
  writeFileAtomic(folder + "/" + robot_name, formatArm(m.arm, header));
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
    << "  flange_T_marker: " << transformList(m.flange_T_marker) << "\n"
    << "effects:" << (m.effects.empty() ? " []" : "") << "\n";
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
    s << "}}\n";
  }
  s << "parameters:" << (rows.empty() ? " []" : "") << "\n";
  for (const ParameterRow& r : rows) {
    s << "  - {name: " << r.name << ", effect: " << r.effect << ", value: " << number(r.value) << ", sigma: " << number(r.sigma)
      << ", unit: \"" << r.unit << "\", held: " << (r.held ? "true" : "false") << "}\n";
  }
  const std::string path = folder + "/" + model_name;
  writeFileAtomic(path, s.str());
  return path;
}

LoadedModel loadModelFile(const std::string& path) {
  const ConfigNode root = ConfigNode::load(path);
  root.requireOnlyKeys({"format", "robot", "sessions", "registration", "effects", "parameters"});
  // Format 1 wrote a compliance with the other sign (dq = +c tau); files without one read the same.
  const std::string format = root["format"].asString();
  if (format != "orbcal-model-2" && format != "orbcal-model-1") root["format"].fail("expected orbcal-model-2");
  const std::string robot = root["robot"].asString();
  const std::filesystem::path dir = std::filesystem::path(path).parent_path();
  const Arm arm = loadArm(robot.rfind("builtin:", 0) == 0 || std::filesystem::path(robot).is_absolute()
                              ? robot
                              : (dir / robot).string());
  const int sessions = root["sessions"].asInt();
  if (sessions < 1) root["sessions"].fail("must be at least 1");
  const ConfigNode reg = root["registration"];
  reg.requireOnlyKeys({"base", "marker", "world_T_base", "flange_T_marker"});
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
  std::map<std::string, std::pair<double, ConfigNode>> values;
  const ConfigNode list = root["effects"];
  for (std::size_t k = 0; k < list.size(); ++k) {
    const ConfigNode e = list[k];
    e.requireOnlyKeys({"spec", "parameters"});
    effects.push_back(parseEffect(e["spec"].asString(), arm.numJoints(), path + ": effects[" + std::to_string(k) + "].spec"));
    if (format == "orbcal-model-1" && !effects.back().kind().signConvention().empty()) {
      e["spec"].fail("a format orbcal-model-1 file gave " + effects.back().name() +
                     " the other sign; calibrate again (orbcal-model-2: positive compliance sags)");
    }
    (void)e["parameters"];  // required (read below, once the layout is known)
  }
  LoadedModel out;
  try {
    out.model = makeKinematicModel(arm, sessions, base, marker, frames("world_T_base", base),
                                   frames("flange_T_marker", marker), effects, false);
  } catch (const std::invalid_argument& e) {
    throw InputError(path + ": effects: " + e.what());
  }
  out.p = Eigen::VectorXd::Zero(out.model.layout.size());
  for (std::size_t k = 0; k < list.size(); ++k) {
    const ConfigNode params = list[k]["parameters"];
    std::vector<std::string> allowed;
    for (const int blk : out.model.effect_blocks[k]) {
      const ParamBlock& b = out.model.layout.block(blk);
      for (int i = 0; i < b.size(); ++i) {
        const std::string& pname = b.params[static_cast<std::size_t>(i)].name;
        allowed.push_back(pname);
        out.p[b.offset + i] = params[pname].asDouble();
      }
    }
    params.requireOnlyKeys(allowed);
  }
  const ConfigNode rows = root["parameters"];
  (void)rows.size();  // a sequence (informative; not read back)
  return out;
}

}  // namespace orbcal::sim
