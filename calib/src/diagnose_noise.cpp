#include "diagnose_noise.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <random>
#include <set>

#include "diagnose_candidates.hpp"
#include "orbcal/calib/heldout.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::calib {

namespace {

/// The flexible model's terms at one level of flexibility: per moving joint its harmonics 1..h
/// (cyclic), smooth functions of degree d of its own angle and torque (empirical) and its link's bending
/// (where the arm has masses), and with `couplings` each joint's reading off by a multiple of every
/// other's (coupling).
std::vector<sim::Effect> flexibleTerms(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs,
                                       const std::vector<sim::Effect>& effects, int h, int d, bool couplings) {
  std::vector<sim::Effect> out = effects;
  const auto add = [&](const sim::Effect& e) {
    const auto same = [&](const sim::Effect& s) { return &s.kind() == &e.kind() && s.joints() == e.joints(); };
    if (sim::fitsJointTypes(e, data.arm) && std::none_of(out.begin(), out.end(), same)) out.push_back(e);
  };
  std::vector<int> moving;
  for (int j = 0; j < data.arm.numJoints(); ++j) {
    double lo = obs.front().sample.q_rad[j], hi = lo;
    for (const MarkerObservation& o : obs) {
      lo = std::min(lo, o.sample.q_rad[j]);
      hi = std::max(hi, o.sample.q_rad[j]);
    }
    if (hi - lo > 1e-9) moving.push_back(j);
  }
  for (int j : moving) add(sim::Effect(*sim::findEffectKind("cyclic"), {j}, h));
  for (const sim::Effect& e : empiricalCandidates(data, obs, d)) add(e);
  // Every link's bending under the load it carries (where the arm has masses): smooth structure that no
  // joint's own angle or torque follows, which a joint-noise estimate would otherwise take.
  if (!data.arm.masses.empty()) {
    for (int j : moving) add(sim::Effect(*sim::findEffectKind("link_bending"), {j}));
  }
  if (couplings) {
    for (int i : moving) {
      for (int j : moving) {
        if (i != j) add(sim::Effect(*sim::findEffectKind("coupling"), {i, j}));
      }
    }
  }
  return out;
}

std::set<int> sessionsOf(const std::vector<MarkerObservation>& obs) {
  std::set<int> s;
  for (const MarkerObservation& o : obs) s.insert(o.sample.session);
  return s;
}

}  // namespace

std::vector<MarkerObservation> seededSubset(const std::vector<MarkerObservation>& obs, std::size_t keep, std::uint64_t seed) {
  std::vector<MarkerObservation> subset;
  if (keep >= obs.size()) return subset;
  std::mt19937_64 rng(seed);
  subset.reserve(keep);
  std::sample(obs.begin(), obs.end(), std::back_inserter(subset), keep, rng);  // in their order
  if (sessionsOf(subset) != sessionsOf(obs)) subset.clear();  // a session's frames need its samples
  return subset;
}

FlexibleFit flexibleFit(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs, const std::vector<sim::Effect>& effects,
                        const FitOptions& options, int max_degree, int max_obs, std::uint64_t seed) {
  FitOptions f = options;
  f.analyze = false;  // the noise components alone are wanted
  // Its many smooth terms leave nearly flat directions: a wide prior (ten typical sizes) gives the fit one
  // minimum, so the noise estimated from its residuals does not depend on where LM stops (FitOptions::effect_prior).
  f.effect_prior = true;
  int rows = 0;
  for (const MarkerObservation& o : obs) rows += o.has_rotation ? 6 : 3;
  struct Level {
    int harmonics, degree;
    bool couplings;
  };
  const int top = std::max(1, max_degree);
  FlexibleFit out;
  const sim::KinematicModel start = startingModel(data, obs, {});  // its frames for every level's model on `obs`
  for (const Level& l : {Level{top, std::min(3, top), true}, Level{std::min(4, top), std::min(3, top), true},
                         Level{std::min(2, top), std::min(2, top), true}, Level{std::min(2, top), std::min(2, top), false},
                         Level{1, 1, false}}) {
    const std::vector<sim::Effect> terms = flexibleTerms(data, obs, effects, l.harmonics, l.degree, l.couplings);
    const sim::KinematicModel model = startingModelFrom(start, obs, terms);
    const int params = model.layout.size();
    if (4 * params > rows) continue;
    // The observations this level needs (a quarter of their rows for its parameters), rounded up.
    const std::size_t needed = static_cast<std::size_t>((4.0 * params * obs.size() + rows - 1) / rows) + 1;
    const std::size_t keep = std::max(needed, static_cast<std::size_t>(std::max(0, max_obs)));
    if (max_obs > 0) out.subset = seededSubset(obs, keep, seed);
    out.degree = l.harmonics;
    const std::vector<MarkerObservation>& fitted = out.fitted(obs);
    out.fit = fitMarkerModel(out.subset.empty() ? model : startingModel(data, fitted, terms), fitted, f);
    return out;
  }
  out.fit = fitMarkerModel(startingModelFrom(start, obs, effects), obs, f);
  return out;
}

bool leavesStructure(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs, const Fit& fit, double alpha) {
  const std::vector<Eigen::VectorXd> residual = markerResiduals(fit.model, fit.p, obs);
  return !lackOfFit(data, obs, fit, fit.noise, residual, false, 2, alpha).unexplained.empty();
}

MarkerNoise floorNoise(const NoiseFloors& n) {
  MarkerNoise m = n.whitening;
  m.joint_noise_sigma_rad = n.joint_floor_rad;
  return m;
}

void chooseJointFloor(NoiseFloors& n, int replicated) {
  if (n.joint_stated || !n.joint_estimated) {
    n.joint_floor_rad = n.whitening.joint_noise_sigma_rad;
    n.joint_source = "stated";
  } else if (replicated > 0) {
    n.joint_floor_rad = 0.0;  // the repeats' scatter holds the whole noise: the floor is the pure error's
    n.joint_source = "pure error";
  } else if (n.survived.resolved(2) && !n.flexible_structured && !n.estimate_contradicted) {
    n.joint_floor_rad = n.joint_estimate_rad;
    n.joint_source = "survives";
  } else {
    n.joint_floor_rad = 0.0;
    n.joint_source = "unstated";
  }
}

void testEstimate(NoiseFloors& n, const Fit& fit, const std::vector<MarkerObservation>& obs,
                  const std::vector<Eigen::VectorXd>& residual, int folds, double alpha) {
  n.estimate_contradicted = false;
  if (!n.joint_estimated || obs.empty()) return;
  MarkerNoise with = n.whitening;
  with.joint_noise_sigma_rad = n.joint_estimate_rad;
  const HeldoutNoise h = heldoutNoise(fit, obs, with, residual, folds);
  // Two lower tails, each at alpha / 2 (Bonferroni): the whitened sum, chi-square(3N) under the noise, and
  // the plain mean square, a scaled chi-square of Satterthwaite's degrees of freedom nu = 2 E^2 / Var.
  // Unmodelled structure raises both; either too small says the estimate holds more than noise.
  n.estimate_chi2 = h.chi2 - h.whitened_estimation;
  n.estimate_chi2_expected = 3.0 * static_cast<double>(obs.size());
  const bool whitened_low = 1.0 - chiSquareSurvival(std::max(0.0, n.estimate_chi2), n.estimate_chi2_expected) < alpha / 2;
  n.estimate_ms_m2 = h.residual_ms_m2;
  n.estimate_ms_expected_m2 = h.position_ms_m2 + h.estimation_ms_m2;
  const double nu = h.residual_ms_var_m4 > 0.0 ? 2.0 * n.estimate_ms_expected_m2 * n.estimate_ms_expected_m2 / h.residual_ms_var_m4 : 0.0;
  const bool plain_low = nu > 0.0 && 1.0 - chiSquareSurvival(nu * h.residual_ms_m2 / n.estimate_ms_expected_m2, nu) < alpha / 2;
  n.estimate_contradicted = whitened_low || plain_low;
}

void measureFloors(NoiseFloors& n, const Fit& fit, const std::vector<MarkerObservation>& obs,
                   const std::vector<Eigen::VectorXd>& residual, int folds) {
  MarkerNoise independent = n.whitening;
  if (!n.joint_stated && n.joint_estimated) independent.joint_noise_sigma_rad = 0.0;
  // The position mean square one unit of joint variance adds (sigma_q^2 |J_pos|_F^2 averaged): from a
  // probe of 1e-4 rad on top of the independent joint noise.
  constexpr double kProbe = 1e-4;
  MarkerNoise probe = independent;
  probe.joint_noise_sigma_rad = std::sqrt(std::pow(independent.joint_noise_sigma_rad, 2) + kProbe * kProbe);
  const std::vector<HeldoutNoise> h = heldoutNoises(fit, obs, {independent, n.whitening, probe}, residual, folds);
  const HeldoutNoise& h0 = h[0];
  n.floor_independent_rms_m = std::sqrt(h0.position_ms_m2);
  n.floor_with_estimate_rms_m = std::sqrt(h[1].position_ms_m2);
  const double per_variance = (h[2].position_ms_m2 - h0.position_ms_m2) / (kProbe * kProbe);
  double ms = 0.0;
  for (const Eigen::VectorXd& r : residual) ms += r.head<3>().squaredNorm();
  ms /= std::max<std::size_t>(1, residual.size());
  const double excess = ms - h0.position_ms_m2 - h0.estimation_ms_m2;
  n.joint_needed_rad = excess > 0.0 && per_variance > 0.0
                           ? std::sqrt(std::pow(independent.joint_noise_sigma_rad, 2) + excess / per_variance)
                           : 0.0;
}

std::vector<MarkerObservation> dropExactDuplicates(const std::vector<MarkerObservation>& obs, std::vector<int>& source) {
  const auto same = [](const MarkerObservation& a, const MarkerObservation& b) {
    return a.point == b.point && a.has_rotation == b.has_rotation &&
           (a.world_T_marker.matrix() - b.world_T_marker.matrix()).cwiseAbs().maxCoeff() <= 1e-12 &&
           (a.sample.q_rad - b.sample.q_rad).cwiseAbs().maxCoeff() <= 1e-12;
  };
  std::vector<int> original(obs.size());  // the first row each row repeats (itself when none)
  for (std::size_t i = 0; i < obs.size(); ++i) original[i] = static_cast<int>(i);
  for (const auto& [key, members] : configurationGroups(obs)) {
    for (std::size_t a = 0; a < members.size(); ++a) {
      for (std::size_t b = 0; b < a; ++b) {
        const int i = members[a], j = members[b];
        if (original[static_cast<std::size_t>(j)] == j && same(obs[static_cast<std::size_t>(i)], obs[static_cast<std::size_t>(j)])) {
          original[static_cast<std::size_t>(i)] = std::min(original[static_cast<std::size_t>(i)], j);
        }
      }
    }
  }
  std::vector<MarkerObservation> kept;
  std::vector<int> position(obs.size(), -1);
  source.assign(obs.size(), -1);
  for (std::size_t i = 0; i < obs.size(); ++i) {
    if (original[i] != static_cast<int>(i)) continue;
    position[i] = static_cast<int>(kept.size());
    kept.push_back(obs[i]);
  }
  for (std::size_t i = 0; i < obs.size(); ++i) source[i] = position[static_cast<std::size_t>(original[i])];
  return kept;
}

void expandRows(Diagnosis& out, const std::vector<int>& source, std::size_t rows) {
  const auto kept = static_cast<Eigen::Index>(out.residual_base.size());
  const int dropped = static_cast<int>(rows) - static_cast<int>(kept);
  if (dropped <= 0) return;
  const auto expand = [&](std::vector<Eigen::VectorXd>& r) {
    std::vector<Eigen::VectorXd> all;
    for (int s : source) all.push_back(r[static_cast<std::size_t>(s)]);
    r = std::move(all);
  };
  expand(out.residual_base);
  expand(out.residual_selected);
  if (out.lack_of_fit.axis_values.size() == kept) {
    Eigen::VectorXd axis(static_cast<Eigen::Index>(rows));
    for (std::size_t i = 0; i < source.size(); ++i) axis[static_cast<Eigen::Index>(i)] = out.lack_of_fit.axis_values[source[i]];
    out.lack_of_fit.axis_values = axis;
  }
  out.noise.duplicates_dropped = dropped;
  out.verdict += " " + std::to_string(dropped) + " of the " + std::to_string(rows) +
                 " rows repeat another row exactly (the same readings and measurement): each such set is counted once.";
}

FitOptions statedFitOptions(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs, const DiagnoseOptions& o,
                            NoiseFloors& n) {
  FitOptions f;
  f.sigma_position_m = o.sigma_position_m ? o.sigma_position_m : data.noise_position_m;
  f.sigma_rotation_rad = o.sigma_rotation_rad ? o.sigma_rotation_rad : data.noise_rotation_rad;
  const std::optional<double> joint = o.joint_noise_sigma_rad ? o.joint_noise_sigma_rad : data.noise_joint_rad;
  f.joint_noise_sigma_rad = joint.value_or(0.0);
  f.estimate_joint_noise = !joint && !anyOwnCovariance(obs);
  f.normal_equations = o.lean_fits;
  n.tracker_stated = f.sigma_position_m.has_value() || anyOwnCovariance(obs);
  n.joint_stated = joint.has_value();
  n.joint_estimated = f.estimate_joint_noise;
  return f;
}

std::pair<std::optional<MarkerNoise>, int> noiseWithSelected(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs,
                                                             const std::vector<sim::Effect>& selected, const DiagnoseOptions& o,
                                                             const FitOptions& stated, const NoiseFloors& n) {
  if ((n.tracker_stated && !n.joint_estimated) || selected.empty() || anyOwnCovariance(obs)) return {std::nullopt, 0};
  FitOptions f = stated;
  f.estimate_joint_noise = false;  // as calibrate: the joint readings' noise as stated, else not modelled
  const std::vector<MarkerObservation> subset =
      o.noise_observations > 0 ? seededSubset(obs, static_cast<std::size_t>(o.noise_observations), o.seed) : std::vector<MarkerObservation>{};
  const std::vector<MarkerObservation>& fitted = subset.empty() ? obs : subset;
  return {fitMarkerModel(startingModel(data, fitted, selected), fitted, f).noise, static_cast<int>(subset.size())};
}

FitOptions whiteningFitOptions(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs, const DiagnoseOptions& o,
                               const FitOptions& stated, NoiseFloors& n) {
  FitOptions f = stated;
  const bool rotations = std::any_of(obs.begin(), obs.end(), [](const MarkerObservation& x) { return x.has_rotation; });
  const bool estimated = stated.estimate_joint_noise || !stated.sigma_position_m || (rotations && !stated.sigma_rotation_rad);
  if (anyOwnCovariance(obs) || !estimated) {
    n.whitening.sigma_position_m = stated.sigma_position_m.value_or(n.whitening.sigma_position_m);
    n.whitening.sigma_rotation_rad = stated.sigma_rotation_rad.value_or(n.whitening.sigma_rotation_rad);
    n.whitening.joint_noise_sigma_rad = stated.joint_noise_sigma_rad;
    return f;
  }
  const FlexibleFit ff = flexibleFit(data, obs, {}, stated, o.max_order, o.noise_observations, o.seed);
  const Fit& flexible = ff.fit;
  n.flexible_degree = ff.degree;
  n.noise_observations = static_cast<int>(ff.subset.size());
  n.flexible_structured = n.joint_estimated && leavesStructure(data, ff.fitted(obs), flexible, o.alpha);
  n.whitening = flexible.noise;
  n.components = n.survived = flexible.noise_components;
  n.joint_estimate_rad = flexible.noise.joint_noise_sigma_rad;
  // Every later fit whitens with this noise, as given.
  f.sigma_position_m = flexible.noise.sigma_position_m;
  f.sigma_rotation_rad = flexible.noise.sigma_rotation_rad;
  f.joint_noise_sigma_rad = flexible.noise.joint_noise_sigma_rad;
  f.estimate_joint_noise = false;
  return f;
}

std::string noiseDependenceText(const Diagnosis& d) {
  const NoiseFloors& n = d.noise;
  if (!n.verdict_depends_on_noise) return "";
  const auto mm = [](double m) { return sim::formatNumber("%.3g", m * 1e3) + " mm"; };
  const auto deg = [](double r) { return sim::formatNumber("%.2g", r * sim::kRadToDeg) + " deg"; };
  const std::string plan =
      "measure each configuration several times (`orbcal configs --repeat 3` writes every configuration three times), "
      "whose scatter diagnose takes as the noise (pure error), or state the noise (noise: {position_mm, rotation_deg, "
      "joint_deg} in the description, or --joint-noise-deg)";
  if (!n.tracker_stated) {
    return "The verdict depends on the noise, and nothing here measures it independently of these residuals (no noise "
           "stated, no repeated configurations): the fits estimate it at position " + mm(n.whitening.sigma_position_m) +
           " per axis" + (n.joint_estimated ? ", joint readings " + deg(n.joint_estimate_rad) + " +- " + deg(n.survived.sigmaSd(2)) : "") +
           ". To decide, " + plan + ".";
  }
  std::string s = "The verdict is judged against the stated tracker noise alone (held-out floor " + mm(n.floor_independent_rms_m) +
                  "): the joint readings' noise is not stated, and the " + deg(n.joint_estimate_rad) +
                  " the fits estimate is not shown to be noise (with the floor it gives, " + mm(n.floor_with_estimate_rms_m) +
                  ", the verdict would differ).";
  if (n.joint_needed_rad > 0.0) {
    s += " The residuals would be noise if the joint readings were " + deg(n.joint_needed_rad) +
         " noisy; industrial encoders read to about 0.001 deg.";
  }
  return s + " To decide, " + plan + ".";
}

void judgeAgainstFloor(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs, const DiagnoseOptions& o,
                       const FitOptions& stated_options, int replicated, int folds, Diagnosis& out) {
  // The joint noise that survives the selected model with empirical corrections beside it.
  if (out.noise.joint_estimated && !out.selected.empty()) {
    const FlexibleFit ff = flexibleFit(data, obs, out.selected, stated_options, o.max_order, o.noise_observations, o.seed);
    const Fit& f = ff.fit;
    out.noise.flexible_structured = leavesStructure(data, ff.fitted(obs), f, o.alpha);
    out.noise.survived = f.noise_components;
    out.noise.joint_estimate_rad = f.noise.joint_noise_sigma_rad;
    testEstimate(out.noise, out.fit, obs, out.residual_selected, folds, o.alpha);
    chooseJointFloor(out.noise, replicated);
  }
  // Lack of fit of the selected model (the base model when nothing is selected), against the floor.
  out.lack_of_fit = lackOfFit(data, obs, out.fit, floorNoise(out.noise), out.residual_selected, out.noise.floorStated(), folds, o.alpha);
  measureFloors(out.noise, out.fit, obs, out.residual_selected, folds);
  if (out.lack_of_fit.source == NoiseSource::kResiduals) {
    out.noise.verdict_depends_on_noise = !out.lack_of_fit.left();
  } else if (out.noise.joint_source == "unstated" && out.lack_of_fit.left() && !out.noise.estimate_contradicted) {
    const LackOfFit with = lackOfFit(data, obs, out.fit, out.noise.whitening, out.residual_selected, true, folds, o.alpha);
    out.noise.verdict_depends_on_noise = !with.left();
  }
}

}  // namespace orbcal::calib
