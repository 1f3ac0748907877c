#include "orbcal/calib/levels.hpp"

#include <algorithm>
#include <sstream>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"

namespace orbcal::calib {

Level parseLevel(const std::string& text, const std::string& what) {
  if (text == "auto") return {LevelKind::kAuto, {}};
  if (text == "frames") return {LevelKind::kFrames, {}};
  if (text == "offsets") return {LevelKind::kOffsets, {}};
  if (text == "full") return {LevelKind::kFull, {}};
  Level level{LevelKind::kList, {}};
  std::istringstream in(text);
  for (std::string name; std::getline(in, name, ',');) {
    if (name.empty()) break;
    level.names.push_back(name);
  }
  if (text.empty() || text.back() == ',' || level.names.size() != static_cast<std::size_t>(std::count(text.begin(), text.end(), ',') + 1)) {
    throw sim::InputError(what + ": '" + text + "': expected auto, frames, offsets, full or a comma-separated list of "
                          "parameter names (e.g. theta1,theta3,d2)");
  }
  return level;
}

std::string levelName(const Level& level) {
  switch (level.kind) {
    case LevelKind::kAuto: return "auto";
    case LevelKind::kFrames: return "frames";
    case LevelKind::kOffsets: return "offsets";
    case LevelKind::kFull: return "full";
    case LevelKind::kList: break;
  }
  std::string s;
  for (const std::string& n : level.names) s += (s.empty() ? "" : ",") + n;
  return s;
}

std::vector<int> levelHold(const sim::KinematicModel& model, const Level& level, const std::string& what) {
  if (level.kind == LevelKind::kAuto) throw std::invalid_argument("levelHold: choose the level first (chooseLevel)");
  const sim::ParamLayout& L = model.layout;
  for (const std::string& name : level.names) {
    bool found = false;
    for (int i = 0; i < L.size() && !found; ++i) found = L.param(i).name == name;
    if (!found) {
      throw sim::InputError(what + ": '" + name + "' is not a parameter of this model (the geometric ones are " +
                            sim::paramName(model.arm, 0) + ", " + sim::paramName(model.arm, 1) + ", ... " +
                            sim::paramName(model.arm, model.arm.numParams() - 1) + ")");
    }
  }
  std::vector<int> hold;
  const int g = L.find("geometry");
  if (g < 0 || level.kind == LevelKind::kFull) return hold;
  const sim::ParamBlock& b = L.block(g);
  for (int i = 0; i < b.size(); ++i) {
    const bool free = level.kind == LevelKind::kOffsets
                          ? sim::paramKind(model.arm, i) == sim::kTheta
                          : std::find(level.names.begin(), level.names.end(), b.params[static_cast<std::size_t>(i)].name) != level.names.end();
    if (!free) hold.push_back(b.offset + i);
  }
  return hold;
}

LevelChoice chooseLevel(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs,
                        const std::vector<sim::Effect>& effects, FitOptions options, std::uint64_t seed) {
  LevelChoice c;
  c.chosen = {LevelKind::kFull, {}};
  c.configurations = countConfigurations(obs);
  if (c.configurations < kMinLevelConfigurations) return c;
  c.folds = kLevelFolds;
  // Every fold's fit for its parameters alone, with one noise for all levels: the stated one, else the
  // full model's on all the training data (so that no level's folds are whitened by its own misfit).
  options.analyze = false;
  options.hold.clear();
  if (!options.sigma_position_m || !options.sigma_rotation_rad) {
    const Fit full = fitMarkerModel(startingModel(data, obs, effects), obs, options);
    options.sigma_position_m = full.noise.sigma_position_m;
    options.sigma_rotation_rad = full.noise.sigma_rotation_rad;
  }
  const std::vector<int> fold = splitByConfiguration(obs, std::vector<double>(static_cast<std::size_t>(c.folds), 1.0), seed);
  const auto start = [&](const std::vector<MarkerObservation>& train) { return startingModel(data, train, effects); };
  const sim::KinematicModel shape = startingModel(data, obs, effects);
  for (const LevelKind kind : {LevelKind::kFrames, LevelKind::kOffsets, LevelKind::kFull}) {
    LevelScore s{{kind, {}}, 0.0, 0};
    FitOptions o = options;
    o.hold = levelHold(shape, s.level, "--level");
    s.free = shape.layout.size() - static_cast<int>(o.hold.size());
    s.heldout_rms_m = residualStats(crossValidateFits(obs, fold, c.folds, start, o).residual).position_rms_m;
    c.scores.push_back(s);
  }
  const auto best = std::min_element(c.scores.begin(), c.scores.end(),
                                     [](const LevelScore& a, const LevelScore& b) { return a.heldout_rms_m < b.heldout_rms_m; });
  c.chosen = best->level;
  return c;
}

LevelChoice resolveLevel(const Level& level, const sim::MeasuredData& data, const std::vector<MarkerObservation>& observations,
                         const std::vector<sim::Effect>& effects, const FitOptions& options, std::uint64_t seed) {
  if (level.kind == LevelKind::kAuto) return chooseLevel(data, observations, effects, options, seed);
  LevelChoice c;
  c.chosen = level;
  c.asked = true;
  return c;
}

std::string levelSentence(const LevelChoice& c) {
  if (c.asked) return "level " + levelName(c.chosen) + " (as asked)";
  if (c.scores.empty()) {
    return "level full (" + std::to_string(c.configurations) + " configurations are too few to cross-validate the levels; " +
           std::to_string(kMinLevelConfigurations) + " are needed)";
  }
  std::string s = "level " + levelName(c.chosen) + " (chosen by " + std::to_string(c.folds) + "-fold cross-validation on " +
                  std::to_string(c.configurations) + " configurations: held-out position RMS";
  for (std::size_t i = 0; i < c.scores.size(); ++i) {
    const LevelScore& x = c.scores[i];
    s += std::string(i ? "," : "") + " " + levelName(x.level) + " " + sim::formatNumber("%.3f", x.heldout_rms_m * 1e3) + " mm (" +
         std::to_string(x.free) + " free)";
  }
  return s + ")";
}

}  // namespace orbcal::calib
