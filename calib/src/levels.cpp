#include "orbcal/calib/levels.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/calib/diagnose.hpp"

namespace orbcal::calib {

Level parseLevel(const std::string& text, const std::string& what) {
  if (text == "auto") return {LevelKind::kAuto, {}};
  if (text == "frames") return {LevelKind::kFrames, {}};
  if (text == "offsets") return {LevelKind::kOffsets, {}};
  if (text == "map") return {LevelKind::kMap, {}};
  if (text == "full") return {LevelKind::kFull, {}};
  Level level{LevelKind::kList, {}};
  std::istringstream in(text);
  for (std::string name; std::getline(in, name, ',');) {
    if (name.empty()) break;
    level.names.push_back(name);
  }
  if (text.empty() || text.back() == ',' || level.names.size() != static_cast<std::size_t>(std::count(text.begin(), text.end(), ',') + 1)) {
    throw sim::InputError(what + ": '" + text + "': expected auto, frames, offsets, map, full or a comma-separated list of "
                          "parameter names (e.g. theta1,theta3,d2)");
  }
  return level;
}

std::string levelName(const Level& level) {
  switch (level.kind) {
    case LevelKind::kAuto: return "auto";
    case LevelKind::kFrames: return "frames";
    case LevelKind::kOffsets: return "offsets";
    case LevelKind::kMap: return "map";
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
  const int g = L.find(sim::BlockKind::kGeometry);
  if (g < 0 || level.kind == LevelKind::kFull || level.kind == LevelKind::kMap) return hold;
  const sim::ParamBlock& b = L.block(g);
  for (int i = 0; i < b.size(); ++i) {
    const bool free = level.kind == LevelKind::kOffsets
                          ? sim::paramKind(model.arm, i) == sim::kTheta
                          : std::find(level.names.begin(), level.names.end(), b.params[static_cast<std::size_t>(i)].name) != level.names.end();
    if (!free) hold.push_back(b.offset + i);
  }
  return hold;
}

FitOptions levelOptions(FitOptions options, const sim::KinematicModel& model, const Level& level, const std::string& what) {
  options.hold = levelHold(model, level, what);
  options.map = level.kind == LevelKind::kMap;
  return options;
}

namespace {

/// The seed of repeat r of the level choice: distinct splits from one user seed.
std::uint64_t repeatSeed(std::uint64_t seed, int r) { return seed + 0x9e3779b97f4a7c15ULL * static_cast<std::uint64_t>(r); }

/// The paired comparison of levels a and b over the configurations: per configuration, b's held-out
/// squared position error minus a's (averaged over the repeats); its mean, standard error, t and the
/// one-sided p of "a predicts no better than b" (Student's t, G - 1 degrees of freedom).
struct Paired {
  double mean = 0.0, se = 0.0, t = 0.0, p = 1.0;
};
Paired pairedComparison(const std::vector<double>& a, const std::vector<double>& b) {
  Paired out;
  const double n = static_cast<double>(a.size());
  if (a.size() < 2) return out;
  double ss = 0.0;
  for (std::size_t g = 0; g < a.size(); ++g) out.mean += (b[g] - a[g]) / n;
  for (std::size_t g = 0; g < a.size(); ++g) ss += (b[g] - a[g] - out.mean) * (b[g] - a[g] - out.mean);
  out.se = std::sqrt(ss / (n - 1.0) / n);
  if (out.se <= 0.0) return out;
  out.t = out.mean / out.se;
  const double two_sided = fSurvival(out.t * out.t, 1.0, n - 1.0);
  out.p = out.t > 0.0 ? 0.5 * two_sided : 1.0 - 0.5 * two_sided;
  return out;
}

}  // namespace

LevelChoice chooseLevel(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs,
                        const std::vector<sim::Effect>& effects, FitOptions options, std::uint64_t seed) {
  LevelChoice c;
  c.chosen = {LevelKind::kFull, {}};
  c.configurations = countConfigurations(obs);
  if (c.configurations < kMinLevelConfigurations) return c;
  c.folds = kLevelFolds;
  c.repeats = kLevelRepeats;
  // Every fold's fit for its parameters alone, with one noise for all levels: the stated one, else the
  // full model's on all the training data (so that no level's folds are whitened by its own misfit).
  options.analyze = false;
  options.hold.clear();
  options.map = false;
  if (!options.sigma_position_m || !options.sigma_rotation_rad) {
    const Fit full = fitMarkerModel(startingModel(data, obs, effects), obs, options);
    options.sigma_position_m = full.noise.sigma_position_m;
    options.sigma_rotation_rad = full.noise.sigma_rotation_rad;
  }
  const auto start = [&](const std::vector<MarkerObservation>& train) { return startingModel(data, train, effects); };
  const sim::KinematicModel shape = startingModel(data, obs, effects);
  const std::vector<LevelKind> kinds = {LevelKind::kFrames, LevelKind::kOffsets, LevelKind::kMap, LevelKind::kFull};
  // Per level: the per-configuration losses summed over the repeats, and each repeat's mean loss.
  std::vector<std::vector<double>> loss(kinds.size());
  std::vector<std::vector<double>> repeat_mse(kinds.size(), std::vector<double>(static_cast<std::size_t>(c.repeats), 0.0));
  for (std::size_t l = 0; l < kinds.size(); ++l) {
    c.scores.push_back({{kinds[l], {}}, 0.0, 0, 0.0, 0});
    c.scores[l].free = shape.layout.size() - static_cast<int>(levelHold(shape, c.scores[l].level, "--level").size());
  }
  for (int r = 0; r < c.repeats; ++r) {
    const std::vector<int> fold = splitByConfiguration(obs, std::vector<double>(static_cast<std::size_t>(c.folds), 1.0), repeatSeed(seed, r));
    for (std::size_t l = 0; l < kinds.size(); ++l) {
      const CrossValidation cv = crossValidateFits(obs, fold, c.folds, start, levelOptions(options, shape, c.scores[l].level, "--level"));
      const std::vector<double> g = configurationLosses(obs, cv.residual);
      if (loss[l].empty()) loss[l].assign(g.size(), 0.0);
      for (std::size_t k = 0; k < g.size(); ++k) loss[l][k] += g[k] / c.repeats;
      const double rms = residualStats(cv.residual).position_rms_m;
      repeat_mse[l][static_cast<std::size_t>(r)] = rms * rms;
      c.scores[l].heldout_rms_m += rms * rms / c.repeats;  // the mean square, rooted below
      c.scores[l].effective += (kinds[l] == LevelKind::kMap ? cv.effective_parameters : c.scores[l].free) / static_cast<double>(c.repeats);
    }
  }
  for (int r = 0; r < c.repeats; ++r) {
    std::size_t w = 0;
    for (std::size_t l = 1; l < kinds.size(); ++l) {
      if (repeat_mse[l][static_cast<std::size_t>(r)] < repeat_mse[w][static_cast<std::size_t>(r)]) w = l;
    }
    ++c.scores[w].wins;
  }
  for (LevelScore& x : c.scores) x.heldout_rms_m = std::sqrt(x.heldout_rms_m);
  // map, whose shrinkage the data already set (tau), unless the level of the smallest pooled held-out
  // RMS predicts significantly better than it: the paired one-sided test of the held-out rule
  // (kHeldoutGainAlpha) on the per-configuration losses.
  const std::size_t map = 2;
  std::size_t best = 0;
  for (std::size_t l = 1; l < c.scores.size(); ++l) {
    if (c.scores[l].heldout_rms_m < c.scores[best].heldout_rms_m) best = l;
  }
  std::size_t other = best;  // the level map is compared with: the best of the others
  if (best == map) {
    other = map == 0 ? 1 : 0;
    for (std::size_t l = 0; l < c.scores.size(); ++l) {
      if (l != map && c.scores[l].heldout_rms_m < c.scores[other].heldout_rms_m) other = l;
    }
  }
  const Paired vs_map = pairedComparison(loss[other], loss[map]);  // > 0: `other` predicts better than map
  const std::size_t chosen = best != map && vs_map.p < kHeldoutGainAlpha ? best : map;
  const std::size_t compared = chosen == map ? other : map;
  const Paired d = pairedComparison(loss[chosen], loss[compared]);
  c.chosen = c.scores[chosen].level;
  c.runner_up = levelName(c.scores[compared].level);
  c.margin_m2 = d.mean;
  c.margin_se_m2 = d.se;
  c.margin_t = d.t;
  c.margin_p = d.p;
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
  using sim::formatNumber;
  if (c.asked) return "level " + levelName(c.chosen) + " (as asked)";
  if (c.scores.empty()) {
    return "level full (" + std::to_string(c.configurations) + " configurations are too few to cross-validate the levels; " +
           std::to_string(kMinLevelConfigurations) + " are needed)";
  }
  std::string s = "level " + levelName(c.chosen) + " (chosen by " + std::to_string(c.folds) + "-fold cross-validation repeated " +
                  std::to_string(c.repeats) + " times with other splits on " + std::to_string(c.configurations) +
                  " configurations: held-out position RMS";
  for (std::size_t i = 0; i < c.scores.size(); ++i) {
    const LevelScore& x = c.scores[i];
    s += std::string(i ? "," : "") + " " + levelName(x.level) + " " + formatNumber("%.3f", x.heldout_rms_m * 1e3) + " mm (" +
         std::to_string(x.free) + " free" +
         (x.level.kind == LevelKind::kMap ? ", " + formatNumber("%.1f", x.effective) + " effective" : std::string()) + ")";
  }
  std::vector<const LevelScore*> winners;
  for (const LevelScore& x : c.scores) {
    if (x.wins > 0) winners.push_back(&x);
  }
  std::sort(winners.begin(), winners.end(), [](const LevelScore* a, const LevelScore* b) { return a->wins > b->wins; });
  s += "; predicted best by";
  for (std::size_t i = 0; i < winners.size(); ++i) {
    s += std::string(i ? "," : "") + " " + levelName(winners[i]->level) + " in " + std::to_string(winners[i]->wins) + " of " +
         std::to_string(c.repeats) + " repeats";
  }
  if (!c.runner_up.empty()) {
    s += "; against " + c.runner_up + ", its held-out squared position error per configuration is lower by " +
         formatNumber("%.3g", c.margin_m2 * 1e6) + " +- " + formatNumber("%.2g", c.margin_se_m2 * 1e6) + " mm^2 (t = " +
         formatNumber("%.1f", c.margin_t) + ", one-sided p = " + formatNumber("%.2g", c.margin_p) + ")";
    if (c.chosen.kind == LevelKind::kMap && c.margin_p >= kHeldoutGainAlpha) {
      s += "; map is kept unless another level predicts significantly better (p < " + formatNumber("%g", kHeldoutGainAlpha) + ")";
    }
  }
  return s + ")";
}

}  // namespace orbcal::calib
