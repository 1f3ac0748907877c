#include "orbcal/calib/diagnose.hpp"

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <future>
#include <map>
#include <numeric>
#include <optional>
#include <random>
#include <sstream>
#include <thread>
#include <tuple>

#include "diagnose_candidates.hpp"
#include "diagnose_folds.hpp"
#include "diagnose_noise.hpp"
#include "diagnose_text.hpp"
#include "diagnoser.hpp"
#include "stacked_system.hpp"
#include "orbcal/calib/plausibility.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::calib {

// ---- Diagnosis ----------------------------------------------------------------------------------

namespace {

using sim::Effect;


/// Evidence: held-out residuals against each variable (F test of a linear regression, pooled over the
/// residual components), Holm-adjusted. The base family (lack_of_fit.hpp's evidenceVariables, not
/// extended).
std::vector<VariableTest> residualEvidence(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs,
                                           const std::vector<Eigen::VectorXd>& residual, const MarkerNoise& noise,
                                           const sim::KinematicModel& model, const Eigen::VectorXd& p) {
  if (obs.size() < 10) return {};
  return variableTests(scaledResiduals(residual, noise), evidenceVariables(data, obs, model, p, false));
}

/// The model selected so far: its effects, their cross-validation and fit on all the data.
struct ModelSelection {
  std::vector<Effect> effects;
  CvResult cv;
  Fit fit;
  int steps = 0;
};

/// Forward selection from `pool`: at each step the significant candidates (score tests, Holm) are
/// cross-validated and the best penalized gain is added while one is positive; the confounded sets
/// and every step's tests go to `out`.
void forwardSelect(const Diagnoser& d, const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs, const DiagnoseOptions& o,
                   const std::vector<Effect>& pool, ModelSelection& sel, Diagnosis& out) {
  for (; sel.steps < o.max_effects; ++sel.steps) {
    const int step = sel.steps + 1;
    std::vector<Effect> remaining;
    for (const Effect& c : pool) {
      if (std::none_of(sel.effects.begin(), sel.effects.end(), [&](const Effect& s) { return sharesCause(s, c); })) remaining.push_back(c);
    }
    if (remaining.empty()) break;
    std::vector<Diagnoser::Projection> proj;
    std::vector<CandidateResult> tests = d.scoreTests(sel.effects, sel.fit, remaining, step, &proj);
    // Fit the significant ones, most significant first (at most 5 per step: the time budget).
    std::vector<std::size_t> order;
    for (std::size_t i = 0; i < tests.size(); ++i) {
      if (tests[i].significant) order.push_back(i);
    }
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return tests[a].score / std::max(1, tests[a].rank) > tests[b].score / std::max(1, tests[b].rank); });
    // One order of a cause (cyclic:2 or cyclic:2/6) competes; its order is chosen once it is selected.
    std::vector<std::size_t> distinct;
    for (std::size_t i : order) {
      if (std::none_of(distinct.begin(), distinct.end(), [&](std::size_t k) { return sharesCause(tests[k].effect, tests[i].effect); })) distinct.push_back(i);
    }
    order = distinct;
    if (order.size() > 5) order.resize(5);
    std::optional<std::size_t> best;
    double best_gain = 0.0;
    std::map<std::size_t, CvResult> cvs;
    // Every candidate is also scored with the extremes of each driving variable of the candidates held
    // out ("leave the extremes out"): the same held-out samples for all of them.
    std::vector<Effect> fitted;
    for (std::size_t i : order) fitted.push_back(tests[i].effect);
    const std::vector<sim::DrivingVariable> drivers = drivingVariablesOf(fitted, data.arm);
    d.prepareExtremes(drivers);
    std::vector<std::string> extremes;
    for (const sim::DrivingVariable& v : drivers) extremes.push_back(v.column);
    std::vector<std::future<CvResult>> jobs;  // the candidates side by side, on every core
    for (std::size_t i : order) {
      jobs.push_back(std::async(std::launch::async, [&d, &sel, &tests, &extremes, i] {
        std::vector<Effect> trial = sel.effects;
        trial.push_back(tests[i].effect);
        return d.crossValidate(trial, &sel.fit, extremes);
      }));
    }
    for (std::size_t j = 0; j < order.size(); ++j) {
      cvs[order[j]] = jobs[j].get();
      tests[order[j]].cv_gain = sel.cv.sse - cvs[order[j]].sse;
    }
    // The largest penalized gain; then, among the candidates whose gain comes within the confounding
    // margin of it (the random folds cannot tell them apart), the one that predicts the held-out
    // extremes best after its penalty per parameter: parsimony, and no advantage that lives only inside
    // the training range.
    const auto penalized = [&](std::size_t i) { return *tests[i].cv_gain - o.penalty_per_param * tests[i].params; };
    for (std::size_t i : order) {
      if (penalized(i) > 0.0 && (!best || penalized(i) > penalized(*best))) best = i;
    }
    if (best) {
      const double top = *tests[*best].cv_gain;
      const auto edges = [&](std::size_t i) { return cvs[i].extremesSse() + o.penalty_per_param * tests[i].params; };
      const std::size_t first = *best;
      for (std::size_t i : order) {
        if (i == first || penalized(i) <= 0.0 || *tests[i].cv_gain < (1.0 - o.confounding_gain_margin) * top) continue;
        if (edges(i) < edges(*best) || (edges(i) == edges(*best) && *tests[i].cv_gain > *tests[*best].cv_gain)) best = i;
      }
      best_gain = *tests[*best].cv_gain;
    }
    // Causes the data cannot tell from the chosen one: significant candidates that, fitted instead of
    // it, predict the held-out data about as well (their cross-validated gain within
    // confounding_gain_margin of the chosen one's); and the geometry, when it absorbs most of the
    // chosen cause's columns.
    std::vector<Effect> members;  // the chosen one's confounded set
    if (best) {
      ConfoundedSet set;
      set.effects.push_back(tests[*best].effect);
      set.with_geometry = proj[*best].absorbed > 0.9;
      for (std::size_t i = 0; i < tests.size(); ++i) {
        if (i == *best || !tests[i].significant || !tests[i].cv_gain || sharesCause(tests[i].effect, tests[*best].effect)) continue;
        if (*tests[i].cv_gain >= (1.0 - o.confounding_gain_margin) * best_gain) set.effects.push_back(tests[i].effect);
      }
      members = set.effects;
      if (set.effects.size() > 1 || set.with_geometry) {
        set.separate_by = separationAdvice(set.effects);
        const std::string beyond = beyondRangeAdvice(set.effects, data.arm, obs);
        if (set.effects.size() > 1 && !beyond.empty()) set.separate_by += "; or " + beyond;
        out.confounded.push_back(set);
      }
    }
    out.candidates.insert(out.candidates.end(), tests.begin(), tests.end());
    if (!best) break;
    // The joints of the chosen cause (pooled with its confounded set's of its kind), then its order
    // (cyclic harmonics, a compliance's degree), each by its cross-validated gain.
    OrderChoice chosen{tests[*best].effect, cvs[*best]};
    if (std::optional<OrderChoice> p = d.pooledJoints(sel.effects, chosen, members, sel.fit, extremes)) chosen = *p;
    chosen = d.refineOrder(sel.effects, chosen.effect, chosen.cv, sel.fit, extremes);
    tests[*best].effect = chosen.effect;
    cvs[*best] = chosen.cv;
    sel.effects.push_back(tests[*best].effect);
    sel.cv = std::move(cvs[*best]);
    sel.fit = d.fitAll(sel.effects);
  }

}

/// Backward elimination: every selected effect must keep earning its place.
void backwardEliminate(const Diagnoser& d, const DiagnoseOptions& o, const Fit& base_fit,
                       ModelSelection& sel) {
  std::vector<Effect>& selected = sel.effects;
  CvResult& cv_current = sel.cv;
  Fit& current_fit = sel.fit;
  for (bool removed = true; removed && !selected.empty();) {
    removed = false;
    for (std::size_t i = 0; i < selected.size(); ++i) {
      std::vector<Effect> without = selected;
      without.erase(without.begin() + static_cast<std::ptrdiff_t>(i));
      CvResult cv = d.crossValidate(without);
      if (cv.sse - cv_current.sse < o.penalty_per_param * d.paramCount(selected[i])) {
        selected = without;
        cv_current = std::move(cv);
        current_fit = selected.empty() ? base_fit : d.fitAll(selected);
        removed = true;
        break;
      }
    }
  }
}

/// Each selected cause's held-out position mean-square gain over the model with the causes before it
/// (the selection order), as a share of the base model's excess over the noise.
std::vector<double> sharesOfExcess(const Diagnoser& d, const Diagnosis& out) {
  const auto ms = [](const std::vector<Eigen::VectorXd>& r) {
    double s = 0.0;
    for (const Eigen::VectorXd& x : r) s += x.head<3>().squaredNorm();
    return r.empty() ? 0.0 : s / static_cast<double>(r.size());
  };
  std::vector<double> shares;
  double previous = ms(out.residual_base);
  const double excess = previous - std::pow(out.lack_of_fit.noise_position_rms_m, 2);
  for (std::size_t i = 0; i < out.selected.size(); ++i) {
    const std::vector<Effect> prefix(out.selected.begin(), out.selected.begin() + static_cast<std::ptrdiff_t>(i + 1));
    const double current = i + 1 == out.selected.size() ? ms(out.residual_selected) : ms(d.crossValidate(prefix).residual);
    shares.push_back(excess > 0.0 ? (previous - current) / excess : 0.0);
    previous = current;
  }
  return shares;
}

}  // namespace

namespace {

/// The diagnosis of `obs` (the input without exact repeats); `input`: every input row, which the noise
/// a calibration would estimate is computed on (`orbcal calibrate` keeps them all).
Diagnosis diagnoseRows(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs, const DiagnoseOptions& o,
                       const std::vector<MarkerObservation>& input) {
  const auto t0 = std::chrono::steady_clock::now();
  const auto phase = [&o](std::size_t k) {
    if (o.progress) o.progress(static_cast<int>(k), static_cast<int>(kDiagnosePhases.size()));
  };
  phase(0);
  Diagnoser d(data, obs, o);
  Diagnosis out;
  const FitOptions stated_options = statedFitOptions(data, obs, o, out.noise);
  // A long log's selection on a seeded random subset (DiagnoseOptions::selection_observations).
  const std::vector<MarkerObservation> subset =
      o.selection_observations > 0 ? seededSubset(obs, static_cast<std::size_t>(o.selection_observations), o.seed) : std::vector<MarkerObservation>{};
  const std::vector<MarkerObservation>& chosen = subset.empty() ? obs : subset;
  // Data no real arm and instrument can give (a wrong unit or convention) are refused, not diagnosed. The
  // bound is on an RMS, which the selection's random subset gives as well as every observation does.
  FitOptions registration = stated_options;
  registration.analyze = false;
  registration.estimate_joint_noise = false;  // the frames alone: no joint noise to tell from the rest
  requirePlausibleResidual(data, fitRegistration(startingModel(data, chosen, {}), chosen, registration).residuals,
                           "the nominal arm's registration residual");
  phase(1);
  // Not the geometry's bounds (calibrate's): the base model is the one that lacks the causes diagnose
  // looks for, and its lengths absorb what they can of them (a thermal expansion, a bending link). Its
  // noise: as stated, else estimated with empirical corrections beside it (diagnose_noise.hpp).
  out.base_fit = fitMarkerModel(startingModel(data, obs, {}), obs, whiteningFitOptions(data, obs, o, stated_options, out.noise));
  d.setNoise(out.base_fit.noise);
  const int folds = std::max(2, o.folds);
  const int replicated = pureError(obs, std::vector<Eigen::VectorXd>(obs.size(), Eigen::VectorXd::Zero(3))).replicated;

  phase(2);
  CvResult cv_base = d.crossValidate({});
  out.cv_base = cv_base.sse;
  out.residual_base = cv_base.residual;
  testEstimate(out.noise, out.base_fit, obs, cv_base.residual, folds, o.alpha);
  chooseJointFloor(out.noise, replicated);
  out.evidence = residualEvidence(data, obs, cv_base.residual, out.base_fit.noise, out.base_fit.model, out.base_fit.p);

  // Forward selection: the catalog's causes; then, where their model still leaves significant structure
  // (the lack-of-fit test), empirical corrections, selected the same way.
  phase(3);
  std::optional<Diagnoser> on_subset;
  std::optional<Fit> subset_base;
  if (!subset.empty()) {
    on_subset.emplace(data, subset, o);
    on_subset->setNoise(out.base_fit.noise);
    subset_base = on_subset->fitAll({});
    out.selection_observations = static_cast<int>(subset.size());
  }
  const Diagnoser& ds = on_subset ? *on_subset : d;
  const Fit& base_chosen = subset_base ? *subset_base : out.base_fit;
  ModelSelection sel{{}, on_subset ? ds.crossValidate({}) : cv_base, base_chosen, 0};
  forwardSelect(ds, data, chosen, o, ds.catalog(), sel, out);
  if (o.empirical && sel.steps < o.max_effects &&
      lackOfFit(data, chosen, sel.fit, floorNoise(out.noise), sel.cv.residual, out.noise.floorStated(), folds, o.alpha).left()) {
    forwardSelect(ds, data, chosen, o, empiricalCandidates(data, chosen, o.max_order), sel, out);
  }
  phase(4);
  backwardEliminate(ds, o, base_chosen, sel);
  if (on_subset && !sel.effects.empty()) {  // the selected model on every observation
    sel.fit = d.fitAll(sel.effects);
    sel.cv = d.crossValidate(sel.effects, &sel.fit);
  } else if (on_subset) {
    sel.fit = out.base_fit;
    sel.cv = cv_base;
  }

  out.selected = sel.effects;
  // The fit of `selected` on all the data (kept current by both passes). Its geometry is not held to
  // the plausibility bounds: a selected cause may share columns with a length (thermal expansion
  // scales them all), and what the data say of the causes is the report's to give, not a refusal's.
  out.fit = sel.fit;
  out.cv_selected = sel.cv.sse;
  out.residual_selected = sel.cv.residual;
  out.heldout.base = residualStats(out.residual_base);
  out.heldout.selected = residualStats(out.residual_selected);
  // Keep only the confounded sets of effects that stayed.
  std::vector<ConfoundedSet> kept;
  for (const ConfoundedSet& c : out.confounded) {
    if (std::any_of(out.selected.begin(), out.selected.end(), [&](const Effect& e) { return sharesCause(e, c.effects.front()); })) {
      kept.push_back(c);
    }
  }
  out.confounded = kept;
  phase(5);
  // The alternatives' fits run beside the judgement: they read the selection and its confounded sets
  // (copied), the judgement neither; each alone leaves part of the cores idle.
  std::future<std::vector<Alternative>> alternatives =
      std::async(std::launch::async, [&d, selected = out.selected, confounded = out.confounded] {
        return alternativesOf(selected, confounded, [&d](const std::vector<Effect>& effects) { return d.fitAll(effects); });
      });
  // The noise `orbcal calibrate --effects <selected>` would estimate (the report's), beside them too.
  std::future<std::pair<std::optional<MarkerNoise>, int>> with_selected =
      std::async(std::launch::async, [&data, &input, &o, &stated_options, selected = out.selected, noise = out.noise] {
        return noiseWithSelected(data, input, selected, o, stated_options, noise);
      });
  judgeAgainstFloor(data, obs, o, stated_options, replicated, folds, out);
  out.alternatives = alternatives.get();
  std::tie(out.noise.with_selected, out.noise.with_selected_observations) = with_selected.get();
  out.heldout.noise_position_rms_m = out.lack_of_fit.noise_position_rms_m;
  out.unexplained = out.lack_of_fit.left();
  out.clean = out.selected.empty() && !out.unexplained;
  if (out.unexplained && !out.selected.empty()) out.share_of_excess = sharesOfExcess(d, out);
  out.verdict = verdictText(out);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  phase(kDiagnosePhases.size());
  return out;
}

}  // namespace

Diagnosis diagnose(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs, const DiagnoseOptions& o) {
  std::vector<int> source;
  const std::vector<MarkerObservation> rows = dropExactDuplicates(obs, source);
  Diagnosis out = diagnoseRows(data, rows, o, obs);
  expandRows(out, source, obs.size());
  return out;
}

}  // namespace orbcal::calib
