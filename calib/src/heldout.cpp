#include "orbcal/calib/heldout.hpp"

#include <algorithm>
#include <cmath>
#include <future>
#include <numeric>

#include "orbcal/calib/diagnose.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/errors.hpp"

namespace orbcal::calib {

namespace {

/// Union-find root with path halving.
std::size_t rootOf(std::vector<std::size_t>& parent, std::size_t i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

bool sameConfiguration(const sim::JointSample& a, const sim::JointSample& b) {
  return a.session == b.session && a.q_rad.size() == b.q_rad.size() &&
         (a.q_rad.size() == 0 || (a.q_rad - b.q_rad).cwiseAbs().maxCoeff() <= kSameConfigurationRad);
}

/// An item's position loss (m^2): its residual's position part, or a camera view's RMS corner distance.
double positionLoss(const Eigen::VectorXd& r) { return r.head(std::min<Eigen::Index>(3, r.size())).squaredNorm(); }

/// Position loss of each configuration (`groups`' order), averaged over its rows.
std::vector<double> configurationLoss(const std::vector<std::vector<int>>& groups, const std::vector<Eigen::VectorXd>& residual) {
  std::vector<double> loss;
  for (const std::vector<int>& members : groups) {
    double sum = 0.0;
    for (int i : members) sum += positionLoss(residual[static_cast<std::size_t>(i)]);
    loss.push_back(sum / static_cast<double>(members.size()));
  }
  return loss;
}

double positionRms(const std::vector<Eigen::VectorXd>& residual) {
  double sum = 0.0;
  for (const Eigen::VectorXd& r : residual) sum += positionLoss(r);
  return residual.empty() ? 0.0 : std::sqrt(sum / static_cast<double>(residual.size()));
}

/// The members of each configuration of `obs`, configurationGroups' order.
std::vector<std::vector<int>> groupMembers(const std::vector<MarkerObservation>& obs) {
  std::vector<std::vector<int>> out;
  for (auto& [key, members] : configurationGroups(obs)) out.push_back(members);
  return out;
}

}  // namespace

std::map<std::vector<long long>, std::vector<int>> configurationGroups(const std::vector<MarkerObservation>& obs) {
  const std::size_t n = obs.size();
  // Candidates pairs from a sweep along the first joint's reading (within a session).
  const auto first = [&](std::size_t i) { return obs[i].sample.q_rad.size() ? obs[i].sample.q_rad[0] : 0.0; };
  std::vector<std::size_t> order(n), parent(n);
  std::iota(order.begin(), order.end(), 0);
  std::iota(parent.begin(), parent.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return obs[a].sample.session != obs[b].sample.session ? obs[a].sample.session < obs[b].sample.session : first(a) < first(b);
  });
  for (std::size_t a = 0; a < n; ++a) {
    for (std::size_t b = a + 1; b < n; ++b) {
      const std::size_t i = order[a], j = order[b];
      if (obs[j].sample.session != obs[i].sample.session || first(j) - first(i) > kSameConfigurationRad) break;
      if (sameConfiguration(obs[i].sample, obs[j].sample)) parent[rootOf(parent, j)] = rootOf(parent, i);
    }
  }
  std::map<std::size_t, std::vector<int>> by_root;
  for (std::size_t i = 0; i < n; ++i) by_root[rootOf(parent, i)].push_back(static_cast<int>(i));
  std::map<std::vector<long long>, std::vector<int>> groups;
  for (auto& [root, members] : by_root) {
    const sim::JointSample& s = obs[static_cast<std::size_t>(members.front())].sample;
    std::vector<long long> key{s.session};
    for (Eigen::Index j = 0; j < s.q_rad.size(); ++j) key.push_back(std::llround(s.q_rad[j] * 1e9));
    groups[key] = std::move(members);
  }
  return groups;
}

int countConfigurations(const std::vector<MarkerObservation>& obs) { return static_cast<int>(configurationGroups(obs).size()); }

std::vector<int> splitByConfiguration(const std::vector<MarkerObservation>& obs, const std::vector<double>& shares,
                                      std::uint64_t seed) {
  if (shares.empty() || std::any_of(shares.begin(), shares.end(), [](double s) { return !(s > 0.0); })) {
    throw std::invalid_argument("splitByConfiguration: every share must be > 0");
  }
  const double total = std::accumulate(shares.begin(), shares.end(), 0.0);
  std::map<int, std::vector<const std::vector<int>*>> by_session;
  const std::map<std::vector<long long>, std::vector<int>> groups = configurationGroups(obs);
  for (const auto& [key, members] : groups) by_session[static_cast<int>(key[0])].push_back(&members);
  std::mt19937_64 rng = sim::makeRng(seed, 0x666f6c6473ULL);
  std::vector<int> part(obs.size(), 0);
  std::vector<double> count(shares.size(), 0.0);
  double dealt = 0.0;
  for (auto& [session, list] : by_session) {
    std::shuffle(list.begin(), list.end(), rng);
    for (const std::vector<int>* g : list) {
      dealt += 1.0;
      std::size_t best = 0;
      for (std::size_t k = 1; k < shares.size(); ++k) {
        if (shares[k] / total * dealt - count[k] > shares[best] / total * dealt - count[best]) best = k;
      }
      count[best] += 1.0;
      for (int i : *g) part[static_cast<std::size_t>(i)] = static_cast<int>(best);
    }
  }
  return part;
}

CrossValidation crossValidateFits(const std::vector<MarkerObservation>& obs, const std::vector<int>& fold, int folds,
                                  const std::function<sim::KinematicModel(const std::vector<MarkerObservation>&)>& start,
                                  const FitOptions& options, const Eigen::VectorXd& p0) {
  if (fold.size() != obs.size()) throw std::invalid_argument("crossValidateFits: one fold per observation expected");
  struct FoldResult {
    double sse = 0.0, effective = 0.0;
    std::vector<std::pair<std::size_t, Eigen::VectorXd>> residual;
  };
  std::vector<std::future<FoldResult>> jobs;
  for (int f = 0; f < folds; ++f) {
    if (std::find(fold.begin(), fold.end(), f) == fold.end()) continue;
    jobs.push_back(std::async(std::launch::async, [&, f] {
      std::vector<MarkerObservation> train, test;
      std::vector<std::size_t> test_index;
      for (std::size_t i = 0; i < obs.size(); ++i) {
        if (fold[i] == f) {
          test.push_back(obs[i]);
          test_index.push_back(i);
        } else {
          train.push_back(obs[i]);
        }
      }
      const sim::KinematicModel model = start(train);
      const Fit fit = fitMarkerModel(model, train, options, p0);
      const MarkerPoseModel held(model, test, fit.noise, fit.p);
      std::vector<Eigen::VectorXd> nu;  // the held-out residuals, at fit.p
      const double sse = 2.0 * weightedCost(held, Eigen::VectorXd::Zero(held.numParams()), &nu);
      FoldResult out{sse, fit.effective_parameters, {}};
      for (std::size_t t = 0; t < test.size(); ++t) out.residual.emplace_back(test_index[t], std::move(nu[t]));
      return out;
    }));
  }
  CrossValidation r;
  r.residual.resize(obs.size());
  for (auto& j : jobs) {
    FoldResult f = j.get();
    r.sse += f.sse;
    r.effective_parameters += f.effective / static_cast<double>(jobs.size());
    for (auto& [i, v] : f.residual) r.residual[i] = std::move(v);
  }
  return r;
}

std::vector<double> configurationLosses(const std::vector<MarkerObservation>& obs, const std::vector<Eigen::VectorXd>& residual) {
  if (residual.size() != obs.size()) throw std::invalid_argument("configurationLosses: one residual per observation expected");
  return configurationLoss(groupMembers(obs), residual);
}

HeldoutGain heldoutGain(const std::vector<MarkerObservation>& obs, const std::vector<Eigen::VectorXd>& before,
                        const std::vector<Eigen::VectorXd>& after) {
  if (before.size() != obs.size() || after.size() != obs.size()) {
    throw std::invalid_argument("heldoutGain: one residual per observation expected");
  }
  return heldoutGain(groupMembers(obs), before, after);
}

HeldoutGain heldoutGain(const std::vector<std::vector<int>>& groups, const std::vector<Eigen::VectorXd>& before,
                        const std::vector<Eigen::VectorXd>& after) {
  HeldoutGain g;
  const std::vector<double> lb = configurationLoss(groups, before), la = configurationLoss(groups, after);
  g.configurations = static_cast<int>(groups.size());
  g.before_rms_m = positionRms(before);
  g.after_rms_m = positionRms(after);
  g.enough = g.configurations >= kMinHeldoutConfigurations;
  if (g.configurations >= 2) {
    const double n = static_cast<double>(g.configurations);
    double mean = 0.0, ss = 0.0;
    for (std::size_t k = 0; k < lb.size(); ++k) mean += (lb[k] - la[k]) / n;
    for (std::size_t k = 0; k < lb.size(); ++k) ss += (lb[k] - la[k] - mean) * (lb[k] - la[k] - mean);
    const double se = std::sqrt(ss / (n - 1.0) / n);
    if (se > 0.0) {
      g.t = mean / se;
      // P(T > t) for t > 0 is half of P(|T| > t) = P(F(1, n - 1) > t^2).
      const double two_sided = fSurvival(g.t * g.t, 1.0, n - 1.0);
      g.p_value = g.t > 0.0 ? 0.5 * two_sided : 1.0 - 0.5 * two_sided;
    } else {
      g.p_value = mean > 0.0 ? 0.0 : 1.0;
    }
  }
  g.significant = g.enough && g.p_value < kHeldoutGainAlpha;
  return g;
}

void checkHoldout(std::optional<double> holdout) {
  if (holdout && !(*holdout >= 0.0 && *holdout < 1.0)) throw sim::InputError("--holdout: must be within [0, 1)");
}

std::vector<int> holdoutSplit(const std::vector<MarkerObservation>& obs, std::optional<double> holdout, std::uint64_t seed) {
  checkHoldout(holdout);
  const double h = holdout ? *holdout : defaultHoldout(countConfigurations(obs));
  return h > 0.0 ? splitByConfiguration(obs, {1.0 - h, h}, seed) : std::vector<int>(obs.size(), 0);
}

double defaultHoldout(int configurations) {
  const double n = static_cast<double>(configurations);
  if (configurations < 2 * kMinHeldoutConfigurations || kDefaultHoldoutShare * n >= kMinHeldoutConfigurations) {
    return kDefaultHoldoutShare;
  }
  // splitByConfiguration deals the held-out part round(share x configurations) of them: exactly kMinHeldoutConfigurations.
  return kMinHeldoutConfigurations / n;
}

std::string heldoutRefusal(const HeldoutGain& g, std::optional<double> holdout, int total) {
  using sim::formatNumber;
  if (g.significant) return "";
  if (!g.enough && g.cross_validated) {
    return "only " + std::to_string(g.configurations) + " configurations, and at least " + std::to_string(kMinHeldoutConfigurations) +
           " are needed to tell a gain from noise even when each is predicted by a fit without it (cross-validation): "
           "measure more configurations";
  }
  if (!g.enough) {
    const std::string advice =
        holdout ? "at least " + std::to_string(static_cast<int>(std::ceil(kMinHeldoutConfigurations / *holdout - 1e-9))) +
                      " in all with --holdout " + formatNumber("%g", *holdout) + ") or raise --holdout"
                : "at least " + std::to_string(2 * kMinHeldoutConfigurations) + " in all: the default hold-out then keeps " +
                      std::to_string(kMinHeldoutConfigurations) + " of them out) or give a larger --holdout";
    return "only " + std::to_string(g.configurations) + " of the " + std::to_string(total) +
           " configurations are held out, and at least " + std::to_string(kMinHeldoutConfigurations) +
           " are needed to tell a held-out gain from noise: measure more configurations (" + advice +
           (holdout && total >= kMinHeldoutConfigurations ? ", or leave --holdout out to judge the set by cross-validation" : "");
  }
  return std::string(g.cross_validated ? "the cross-validated gain is not significant" : "the held-out gain is not significant") +
         ": position RMS " + formatNumber("%.4f", g.before_rms_m * 1e3) + " -> " + formatNumber("%.4f", g.after_rms_m * 1e3) +
         " mm over " + std::to_string(g.configurations) +
         (g.cross_validated ? " configurations, each predicted by a fit without it" : " held-out configurations") +
         ", one-sided paired test of their squared errors t = " + formatNumber("%.2f", g.t) + ", p = " + formatNumber("%.2g", g.p_value) +
         " (needs p < " + formatNumber("%g", kHeldoutGainAlpha) + "): measure more configurations, or fit fewer effects";
}

std::string formatHeldoutGain(const HeldoutGain& g) {
  using sim::formatNumber;
  return std::to_string(g.configurations) +
         (g.cross_validated ? " configurations, each predicted once by a fit that never saw it (leave-one-configuration-out "
                              "cross-validation; the set is too small to hold " + std::to_string(kMinHeldoutConfigurations) + " out)"
                            : std::string(" held-out configurations")) +
         "; the gain over " + g.reference + ", one-sided paired test of their squared position errors: t = " +
         formatNumber("%.2f", g.t) + ", p = " + formatNumber("%.2g", g.p_value) + " (accepted at p < " +
         formatNumber("%g", kHeldoutGainAlpha) + " with at least " + std::to_string(kMinHeldoutConfigurations) + " configurations)";
}

namespace {

HeldoutVerdict verdictOf(const HeldoutGain& gain, bool worse, std::optional<double> holdout, int total) {
  using sim::formatNumber;
  HeldoutVerdict v;
  v.gain = gain;
  v.worse = worse;
  if (v.worse && v.gain.enough) {
    v.refusal = "the calibrated model predicts the " + std::to_string(v.gain.configurations) +
                (v.gain.cross_validated ? " configurations, each by a fit without it," : " held-out configurations") +
                " worse than " + v.gain.reference + " (position RMS " + formatNumber("%.4f", v.gain.before_rms_m * 1e3) + " -> " +
                formatNumber("%.4f", v.gain.after_rms_m * 1e3) + " mm)";
  } else {
    v.refusal = heldoutRefusal(v.gain, holdout, total);
  }
  return v;
}

}  // namespace

HeldoutVerdict heldoutVerdict(const std::vector<MarkerObservation>& held, const std::vector<Eigen::VectorXd>& before,
                              const std::vector<Eigen::VectorXd>& after, std::optional<double> holdout, int total) {
  const HeldoutGain gain = heldoutGain(held, before, after);
  return verdictOf(gain, !held.empty() && gain.after_rms_m > gain.before_rms_m, holdout, total);
}

bool judgeByCrossValidation(int configurations, std::optional<double> holdout) {
  return !holdout && configurations < 2 * kMinHeldoutConfigurations;
}

HeldoutVerdict crossValidatedVerdict(const std::vector<MarkerObservation>& obs, const FoldPredictor& predict,
                                     std::vector<Eigen::VectorXd>* before_out, std::vector<Eigen::VectorXd>* after_out) {
  std::vector<int> configuration(obs.size(), 0);
  int g = 0;
  for (const std::vector<int>& members : groupMembers(obs)) {
    for (int i : members) configuration[static_cast<std::size_t>(i)] = g;
    ++g;
  }
  return crossValidatedVerdict(configuration, predict, HeldoutGain{}.reference, before_out, after_out);
}

HeldoutVerdict crossValidatedVerdict(const std::vector<int>& configuration, const FoldPredictor& predict, const std::string& reference,
                                     std::vector<Eigen::VectorXd>* before_out, std::vector<Eigen::VectorXd>* after_out) {
  std::vector<std::vector<int>> groups;
  for (std::size_t i = 0; i < configuration.size(); ++i) {
    if (configuration[i] < 0) throw std::invalid_argument("crossValidatedVerdict: a negative configuration");
    const auto c = static_cast<std::size_t>(configuration[i]);
    if (groups.size() <= c) groups.resize(c + 1);
    groups[c].push_back(static_cast<int>(i));
  }
  const int total = static_cast<int>(groups.size());
  std::vector<Eigen::VectorXd> before(configuration.size()), after(configuration.size());
  if (total < kMinHeldoutConfigurations) {
    HeldoutGain g;
    g.reference = reference;
    g.configurations = total;
    g.cross_validated = true;
    return verdictOf(g, false, std::nullopt, total);
  }
  std::vector<std::pair<std::vector<int>, std::future<FoldPrediction>>> jobs;
  for (const std::vector<int>& test : groups) {
    if (test.empty()) throw std::invalid_argument("crossValidatedVerdict: configurations must be numbered 0..G-1");
    std::vector<int> train;
    for (int i = 0; i < static_cast<int>(configuration.size()); ++i) {
      if (!std::binary_search(test.begin(), test.end(), i)) train.push_back(i);
    }
    jobs.emplace_back(test, std::async(std::launch::async, [&predict, train, test] { return predict(train, test); }));
  }
  for (auto& [test, job] : jobs) {
    FoldPrediction f = job.get();
    if (f.before.size() != test.size() || f.after.size() != test.size()) {
      throw std::invalid_argument("crossValidatedVerdict: the predictor must give one residual per test observation");
    }
    for (std::size_t t = 0; t < test.size(); ++t) {
      before[static_cast<std::size_t>(test[t])] = std::move(f.before[t]);
      after[static_cast<std::size_t>(test[t])] = std::move(f.after[t]);
    }
  }
  HeldoutGain gain = heldoutGain(groups, before, after);
  gain.reference = reference;
  gain.cross_validated = true;
  const bool worse = gain.after_rms_m > gain.before_rms_m;
  if (before_out) *before_out = std::move(before);
  if (after_out) *after_out = std::move(after);
  return verdictOf(gain, worse, std::nullopt, total);
}

}  // namespace orbcal::calib
