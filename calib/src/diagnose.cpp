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

#include "diagnose_candidates.hpp"
#include "diagnose_folds.hpp"
#include "diagnose_noise.hpp"
#include "diagnose_text.hpp"
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

struct OrderChoice {
  Effect effect;
  CvResult cv;
};

class Diagnoser {
 public:
  Diagnoser(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs, const DiagnoseOptions& o)
      : data_(data), obs_(obs), o_(o), folds_(makeFolds(obs, std::max(2, o.folds), o.seed)) {}

  FitOptions fitOptions() const {
    FitOptions f;
    f.sigma_position_m = noise_.sigma_position_m;
    f.sigma_rotation_rad = noise_.sigma_rotation_rad;
    f.joint_noise_sigma_rad = noise_.joint_noise_sigma_rad;
    f.normal_equations = o_.lean_fits;
    return f;
  }

  Fit fitAll(const std::vector<Effect>& effects) const {
    return fitMarkerModel(startingModel(data_, obs_, effects), obs_, fitOptions());
  }

  /// Cross-validated held-out whitened SSE and residuals of a model with `effects`. With `warm` (a
  /// fit of all the data whose effects are the first of `effects`), every fold starts from its frames
  /// and parameters (the added effects at zero) instead of the closed-form start: the same optimum,
  /// fewer iterations.
  /// With `extremes` (driving variables' columns, prepared by prepareExtremes): also each one's extremes
  /// held out (CvResult::extremes).
  CvResult crossValidate(const std::vector<Effect>& effects, const Fit* warm = nullptr,
                         const std::vector<std::string>& extremes = {}) const {
    // A cold start depends on the effects alone: backward elimination and the shares of the excess
    // ask again for models already cross-validated (the base model, a prefix of the selection).
    std::string key;
    for (const Effect& e : effects) key += sim::formatEffect(e) + " ";
    for (const std::string& c : extremes) key += "|" + c;
    if (!warm) {
      const auto hit = cold_cvs_.find(key);
      if (hit != cold_cvs_.end()) return hit->second;
    }
    CvResult r = crossValidateFolds(effects, warm, extremes);
    if (!warm) cold_cvs_.emplace(key, r);
    return r;
  }

  /// The extremes folds of `vars` (extremesFold), before crossValidate asks for them (from several threads).
  void prepareExtremes(const std::vector<sim::DrivingVariable>& vars) const {
    for (const sim::DrivingVariable& v : vars) {
      if (!extreme_folds_.count(v.column)) extreme_folds_.emplace(v.column, extremesFold(obs_, v, kExtremesShare));
    }
  }

  CvResult crossValidateFolds(const std::vector<Effect>& effects, const Fit* warm, const std::vector<std::string>& extremes) const {
    if (o_.one_step_folds) return oneStepFolds(effects, warm, extremes);
    std::optional<sim::KinematicModel> warm_model;
    Eigen::VectorXd warm_p;
    if (warm) {
      const sim::KinematicModel& w = warm->model;
      warm_model = sim::makeKinematicModel(w.arm, w.sessions, w.base, w.marker, w.world_T_base, w.flange_T_marker, effects, true,
                                                w.marker_points);
      warm_p = Eigen::VectorXd::Zero(warm_model->layout.size());
      warm_p.head(warm->p.size()) = warm->p;
    }
    // A fold's fit is wanted for its parameters alone (its held-out residuals): no analyses.
    FitOptions fold_options = fitOptions();
    fold_options.analyze = !o_.lean_fits;
    const auto start = [&](const std::vector<MarkerObservation>& train) {
      return warm_model ? *warm_model : startingModel(data_, train, effects);
    };
    const CrossValidation cv = crossValidateFits(obs_, folds_.fold, folds_.k, start, fold_options, warm_p);
    CvResult r{cv.sse, cv.residual, true, {}};
    for (const std::string& c : extremes) {
      // One fold: the extremes (1 in extremesFold) held out, fitted on the rest.
      std::vector<int> fold = extreme_folds_.at(c);
      for (int& f : fold) f = 1 - f;
      r.extremes[c] = crossValidateFits(obs_, fold, 1, start, fold_options, warm_p).sse;
    }
    return r;
  }

  /// The fit of `effects` to all the data, from `warm` (its frames and parameters, the added effects
  /// at zero) where given, else from the closed-form start; for its parameters alone.
  Fit fitLean(const std::vector<Effect>& effects, const Fit* warm) const {
    FitOptions f = fitOptions();
    f.analyze = false;
    if (!warm) return fitMarkerModel(startingModel(data_, obs_, effects), obs_, f);
    const sim::KinematicModel& w = warm->model;
    const sim::KinematicModel start = sim::makeKinematicModel(w.arm, w.sessions, w.base, w.marker, w.world_T_base, w.flange_T_marker, effects, true,
                                                w.marker_points);
    Eigen::VectorXd p0 = Eigen::VectorXd::Zero(start.layout.size());
    p0.head(warm->p.size()) = warm->p;
    return fitMarkerModel(start, obs_, f, p0);
  }

  /// DiagnoseOptions::one_step_folds: the whitened system A, b of all the samples at the full fit p
  /// (with the geometry prior's rows S = diag(1/sigma^2)); fold f's step solves, on the free
  /// parameters, (A_t^T A_t + S) dp = A_t^T b_t - S p over its training rows t, and its held-out
  /// residuals are evaluated at p + dp.
  CvResult oneStepFolds(const std::vector<Effect>& effects, const Fit* warm, const std::vector<std::string>& extremes) const {
    const Fit full = fitLean(effects, warm);
    const sim::KinematicModel& model = full.model;
    const MarkerPoseModel m(model, obs_, noise_, full.p);
    const int n = m.numParams();
    const Eigen::VectorXd sigma = geometryPriorSigma(model.layout);
    Eigen::VectorXd prior = Eigen::VectorXd::Zero(n);  // S's diagonal
    for (int i = 0; i < n; ++i) prior[i] = sigma[i] > 0.0 ? 1.0 / (sigma[i] * sigma[i]) : 0.0;
    std::vector<int> free;
    for (int i = 0; i < n; ++i) {
      if (!std::binary_search(full.estimate.held.begin(), full.estimate.held.end(), i)) free.push_back(i);
    }
    const auto nf = static_cast<Eigen::Index>(free.size());
    Eigen::VectorXd scale(nf), prior_f(nf), p_f(nf);
    for (Eigen::Index c = 0; c < nf; ++c) {
      const int i = free[static_cast<std::size_t>(c)];
      scale[c] = model.layout.typical()[i];  // columns in typical magnitudes: a well-scaled normal matrix
      prior_f[c] = prior[i] * scale[c] * scale[c];
      p_f[c] = full.p[i] / scale[c];
    }
    Eigen::MatrixXd Af;  // the free columns alone, scaled
    Eigen::VectorXd b;
    whitenedSystem(m, Eigen::VectorXd::Zero(n), free, scale, Af, b);
    std::vector<Eigen::Index> first_row(obs_.size() + 1, 0);
    for (std::size_t k = 0; k < obs_.size(); ++k) first_row[k + 1] = first_row[k] + m.rows(static_cast<int>(k));
    const Eigen::MatrixXd N_all = Af.transpose() * Af;
    const Eigen::VectorXd g_all = Af.transpose() * b;
    CvResult r;
    r.residual.resize(obs_.size());
    // The held-out whitened SSE of the observations with fold[k] == f, their residuals into r.residual.
    const auto holdOut = [&](const std::vector<int>& fold, int f, bool keep) {
      Eigen::MatrixXd N = N_all;
      Eigen::VectorXd g = g_all;
      std::vector<MarkerObservation> test;
      std::vector<std::size_t> test_index;
      for (std::size_t k = 0; k < obs_.size(); ++k) {
        if (fold[k] != f) continue;
        const auto rows = Eigen::seqN(first_row[k], first_row[k + 1] - first_row[k]);
        N -= Af(rows, Eigen::all).transpose() * Af(rows, Eigen::all);
        g -= Af(rows, Eigen::all).transpose() * b(rows);
        test.push_back(obs_[k]);
        test_index.push_back(k);
      }
      N.diagonal() += prior_f;
      g -= prior_f.cwiseProduct(p_f);
      const Eigen::VectorXd step = N.ldlt().solve(g);
      Eigen::VectorXd p = full.p;
      for (Eigen::Index c = 0; c < nf; ++c) p[free[static_cast<std::size_t>(c)]] += step[c] * scale[c];
      const MarkerPoseModel held(model, test, noise_, p);
      std::vector<Eigen::VectorXd> nu;  // the held-out residuals, at p
      const double sse = 2.0 * weightedCost(held, Eigen::VectorXd::Zero(held.numParams()), &nu);
      for (std::size_t t = 0; keep && t < test.size(); ++t) r.residual[test_index[t]] = std::move(nu[t]);
      return sse;
    };
    for (int f = 0; f < folds_.k; ++f) r.sse += holdOut(folds_.fold, f, true);
    for (const std::string& c : extremes) r.extremes[c] = holdOut(extreme_folds_.at(c), 1, false);
    return r;
  }

  /// Score tests of the candidates at the full fit of `current`.
  struct Projection {
    Eigen::MatrixXd Bperp;  ///< candidate columns beyond the current model's column space
    double absorbed = 0.0;  ///< fraction of the columns' norm the current model absorbs
  };
  std::vector<CandidateResult> scoreTests(const std::vector<Effect>& current, const Fit& fit,
                                          const std::vector<Effect>& candidates, int step,
                                          std::vector<Projection>* projections) const {
    // Candidates that claim one cause (cyclic:2 and cyclic:2/6) cannot share a model: one extended model
    // per layer of mutually compatible candidates, each giving its candidates' whitened columns.
    std::vector<std::vector<std::size_t>> layers;
    for (std::size_t c = 0; c < candidates.size(); ++c) {
      auto fits = [&](const std::vector<std::size_t>& l) {
        return std::none_of(l.begin(), l.end(), [&](std::size_t k) { return sharesCause(candidates[k], candidates[c]); });
      };
      auto it = std::find_if(layers.begin(), layers.end(), fits);
      if (it == layers.end()) it = layers.insert(layers.end(), std::vector<std::size_t>{});
      it->push_back(c);
    }
    Eigen::MatrixXd A;
    Eigen::VectorXd b;
    std::vector<Eigen::MatrixXd> columns(candidates.size());  // each candidate's columns at typical magnitudes
    for (const std::vector<std::size_t>& layer : layers) {
      std::vector<Effect> all = current;
      for (std::size_t c : layer) all.push_back(candidates[c]);
      const sim::KinematicModel ext = sim::makeKinematicModel(fit.model.arm, fit.model.sessions, fit.model.base, fit.model.marker,
                                                              fit.model.world_T_base, fit.model.flange_T_marker, all, true,
                                                              fit.model.marker_points);
      Eigen::VectorXd p = Eigen::VectorXd::Zero(ext.layout.size());
      p.head(fit.p.size()) = fit.p;
      const MarkerPoseModel m(ext, obs_, noise_, p);
      whitenedSystem(m, Eigen::VectorXd::Zero(ext.layout.size()), A, b);
      // The candidate's columns at its parameters' typical magnitudes: each column is then the whitened
      // change a typical-size effect makes to the data.
      const Eigen::VectorXd typical = ext.layout.typical();
      for (std::size_t k = 0; k < layer.size(); ++k) {
        Eigen::MatrixXd& B = columns[layer[k]];
        B.resize(A.rows(), 0);
        for (const int blk : ext.effect_blocks[current.size() + k]) {
          const sim::ParamBlock& pb = ext.layout.block(blk);
          B.conservativeResize(Eigen::NoChange, B.cols() + pb.size());
          B.rightCols(pb.size()) = A.middleCols(pb.offset, pb.size()) * typical.segment(pb.offset, pb.size()).asDiagonal();
        }
      }
    }
    // The current model's free columns and an orthonormal basis of their span.
    std::vector<int> free;
    for (int i = 0; i < fit.model.layout.size(); ++i) {
      if (!std::binary_search(fit.estimate.held.begin(), fit.estimate.held.end(), i)) free.push_back(i);
    }
    Eigen::MatrixXd Af(A.rows(), static_cast<Eigen::Index>(free.size()));
    for (std::size_t c = 0; c < free.size(); ++c) Af.col(static_cast<Eigen::Index>(c)) = A.col(free[c]);
    const sim::ScaledSvd svd = sim::scaledSvd(Af, sim::kRankTolerance);
    const int rank = svd.rank;
    const Eigen::MatrixXd Q = rank > 0 ? Eigen::MatrixXd(svd.U.leftCols(rank)) : Eigen::MatrixXd::Zero(A.rows(), 0);
    const Eigen::VectorXd e = b - Q * (Q.transpose() * b);  // the residual (orthogonal to the model at its optimum)
    const double dof = std::max(1.0, static_cast<double>(A.rows() - rank));
    const double s2 = e.squaredNorm() / dof;  // residual variance in whitened units (1 when the noise is right)

    std::vector<CandidateResult> out;
    if (projections) projections->clear();
    for (std::size_t c = 0; c < candidates.size(); ++c) {
      CandidateResult r;
      r.effect = candidates[c];
      r.step = step;
      const Eigen::MatrixXd& B = columns[c];
      r.params = static_cast<int>(B.cols());
      const Eigen::MatrixXd Bp = B - Q * (Q.transpose() * B);
      Projection pr;
      pr.absorbed = B.norm() > 0 ? 1.0 - Bp.norm() / B.norm() : 1.0;
      // What this data can see of it: the directions beyond the current model along which an effect of
      // typical size moves the whitened data by at least one noise sigma in all (singular values of the
      // typical-scaled projected columns above 1). A joint that never moves, a torque that is only
      // sensor noise: rank 0, not testable here.
      const Eigen::JacobiSVD<Eigen::MatrixXd> bs(Bp, Eigen::ComputeThinU);
      int q = 0;
      for (Eigen::Index i = 0; i < bs.singularValues().size(); ++i) q += bs.singularValues()[i] > 1.0;
      r.rank = q;
      pr.Bperp = bs.matrixU().leftCols(q);
      if (q > 0) {
        const Eigen::VectorXd proj = pr.Bperp.transpose() * e;
        r.score = proj.squaredNorm() / s2;
        // F form: the residual variance is estimated from the same fit.
        r.p_value = fSurvival(r.score / q, q, dof - q);
      }
      out.push_back(r);
      if (projections) projections->push_back(std::move(pr));
    }
    std::vector<double> ps;
    for (const CandidateResult& r : out) ps.push_back(r.p_value);
    const std::vector<double> adj = holmAdjust(ps);
    for (std::size_t i = 0; i < out.size(); ++i) {
      out[i].p_adjusted = adj[i];
      out[i].significant = out[i].rank > 0 && adj[i] < o_.alpha;
    }
    return out;
  }

  std::vector<Effect> catalog() const { return catalogCandidates(data_, obs_, o_); }

  /// The order of a chosen cause with orders (cyclic: harmonics 1..max_order; compliance: degree 1 or 3):
  /// from the lowest, a higher order replaces the current choice only where it earns more after its
  /// penalty per parameter both on the random folds and with the extremes of its driving variables held
  /// out (a cubic fitted inside the training range must also predict its edges better). `cv` is the
  /// chosen order's, with `extremes` (the chosen's driving variables' columns).
  OrderChoice refineOrder(const std::vector<Effect>& selected, const Effect& chosen, const CvResult& cv,
                          const Fit& current_fit, const std::vector<std::string>& extremes) const {
    const sim::EffectKind& kind = chosen.kind();
    if (kind.maxOrder() == 0) return {chosen, cv};
    const auto params = [&](const Effect& e) { return paramCount(e); };
    std::vector<OrderChoice> orders;
    for (int k = 1; k <= std::min(kind.maxOrder(), std::max(o_.max_order, chosen.order())); ++k) {
      if (k == chosen.order()) {
        orders.push_back({chosen, cv});
        continue;
      }
      const Effect e = Effect(kind, chosen.joints(), k, chosen.reference()).withRange(chosen.lo(), chosen.hi());
      try {
        kind.check(e, data_.arm.numJoints(), "order");
      } catch (const sim::InputError&) {
        continue;
      }
      std::vector<Effect> trial = selected;
      trial.push_back(e);
      orders.push_back({e, crossValidate(trial, &current_fit, extremes)});
    }
    std::size_t best = 0;
    for (std::size_t k = 1; k < orders.size(); ++k) {
      const double extra = o_.penalty_per_param * (params(orders[k].effect) - params(orders[best].effect));
      const bool edges = extremes.empty() || orders[best].cv.extremesSse() - orders[k].cv.extremesSse() > extra;
      if (orders[best].cv.sse - orders[k].cv.sse > extra && edges) best = k;
    }
    return orders[best];
  }

  /// The chosen cause's kind on its joint and on the joints of the members of its confounded set of
  /// the same kind (a compliance of joints 4 and 2, whose torques both follow one angle): the kind
  /// acting on all of them, as every loaded joint of an arm gives, shares what one alone would take
  /// and extrapolates by each joint's own load. It replaces the choice only where it earns its extra
  /// parameters' penalty both on the random folds and with the extremes of the driving variables held
  /// out, as a higher order must (refineOrder); nothing otherwise.
  std::optional<OrderChoice> pooledJoints(const std::vector<Effect>& selected, const OrderChoice& chosen,
                                          const std::vector<Effect>& confounded, const Fit& current_fit,
                                          const std::vector<std::string>& extremes) const {
    const Effect& c = chosen.effect;
    if (c.joints().size() != 1) return std::nullopt;
    std::vector<int> joints = c.joints();
    for (const Effect& e : confounded) {
      if (&e.kind() == &c.kind() && e.joints().size() == 1 && e.joints() != c.joints()) joints.push_back(e.joints().front());
    }
    if (joints.size() < 2) return std::nullopt;
    std::sort(joints.begin(), joints.end());
    const Effect pooled = Effect(c.kind(), joints, c.order(), c.reference()).withRange(c.lo(), c.hi());
    try {
      c.kind().check(pooled, data_.arm.numJoints(), "joints");
    } catch (const sim::InputError&) {
      return std::nullopt;
    }
    std::vector<Effect> trial = selected;
    trial.push_back(pooled);
    OrderChoice p{pooled, crossValidate(trial, &current_fit, extremes)};
    const double extra = o_.penalty_per_param * (paramCount(pooled) - paramCount(c));
    const bool edges = extremes.empty() || chosen.cv.extremesSse() - p.cv.extremesSse() > extra;
    if (chosen.cv.sse - p.cv.sse > extra && edges) return p;
    return std::nullopt;
  }

  int paramCount(const Effect& e) const {
    int n = 0;
    for (const sim::ParamBlock& b : sim::effectBlocks(e, data_.arm, data_.numSessions())) n += b.size();
    return n;
  }

  void setNoise(const MarkerNoise& n) {
    noise_ = n;
    cold_cvs_.clear();  // the folds' fits whiten with the noise
  }

 private:
  const sim::MeasuredData& data_;
  const std::vector<MarkerObservation>& obs_;
  DiagnoseOptions o_;
  Folds folds_;
  MarkerNoise noise_;
  mutable std::map<std::string, CvResult> cold_cvs_;  ///< cross-validations from the closed-form start, by effects
  mutable std::map<std::string, std::vector<int>> extreme_folds_;  ///< extremesFold by driving variable's column
};

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
void backwardEliminate(const Diagnoser& d, const sim::MeasuredData& data, const DiagnoseOptions& o, const Fit& base_fit,
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
      int params = 0;
      for (const sim::ParamBlock& b : sim::effectBlocks(selected[i], data.arm, data.numSessions())) params += b.size();
      if (cv.sse - cv_current.sse < o.penalty_per_param * params) {
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

Diagnosis diagnoseRows(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs, const DiagnoseOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  Diagnoser d(data, obs, o);
  Diagnosis out;
  const FitOptions stated_options = statedFitOptions(data, obs, o, out.noise);
  // Data no real arm and instrument can give (a wrong unit or convention) are refused, not diagnosed.
  FitOptions registration = stated_options;
  registration.analyze = false;
  registration.estimate_joint_noise = false;  // the frames alone: no joint noise to tell from the rest
  requirePlausibleResidual(data, fitRegistration(startingModel(data, obs, {}), obs, registration).residuals,
                           "the nominal arm's registration residual");
  // Not the geometry's bounds (calibrate's): the base model is the one that lacks the causes diagnose
  // looks for, and its lengths absorb what they can of them (a thermal expansion, a bending link). Its
  // noise: as stated, else estimated with empirical corrections beside it (diagnose_noise.hpp).
  out.base_fit = fitMarkerModel(startingModel(data, obs, {}), obs, whiteningFitOptions(data, obs, o, stated_options, out.noise));
  d.setNoise(out.base_fit.noise);
  const int folds = std::max(2, o.folds);
  const int replicated = pureError(obs, std::vector<Eigen::VectorXd>(obs.size(), Eigen::VectorXd::Zero(3))).replicated;
  chooseJointFloor(out.noise, replicated);
  // The floor is stated (not estimated from these residuals) when the tracker's noise (or each sample's
  // covariance) is given and the joint readings' part is too, or not needed beside the repeats' scatter.
  const auto tested_stated = [&] { return out.noise.tracker_stated && out.noise.joint_source != "pure error"; };

  CvResult cv_base = d.crossValidate({});
  out.cv_base = cv_base.sse;
  out.residual_base = cv_base.residual;
  out.evidence = residualEvidence(data, obs, cv_base.residual, out.base_fit.noise, out.base_fit.model, out.base_fit.p);

  // Forward selection: the catalog's causes; then, where their model still leaves significant structure
  // (the lack-of-fit test), empirical corrections, selected the same way.
  ModelSelection sel{{}, cv_base, out.base_fit, 0};
  forwardSelect(d, data, obs, o, d.catalog(), sel, out);
  if (o.empirical && sel.steps < o.max_effects &&
      lackOfFit(data, obs, sel.fit, floorNoise(out.noise), sel.cv.residual, tested_stated(), folds, o.alpha).left()) {
    forwardSelect(d, data, obs, o, empiricalCandidates(data, obs, o.max_order), sel, out);
  }
  backwardEliminate(d, data, o, out.base_fit, sel);

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
  out.alternatives = alternativesOf(out, [&d](const std::vector<Effect>& effects) { return d.fitAll(effects); });

  judgeAgainstFloor(data, obs, o, stated_options, replicated, folds, out);
  out.heldout.noise_position_rms_m = out.lack_of_fit.noise_position_rms_m;
  out.unexplained = out.lack_of_fit.left();
  out.clean = out.selected.empty() && !out.unexplained;
  if (out.unexplained && !out.selected.empty()) out.share_of_excess = sharesOfExcess(d, out);
  out.verdict = verdictText(out);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace

Diagnosis diagnose(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs, const DiagnoseOptions& o) {
  std::vector<int> source;
  const std::vector<MarkerObservation> rows = dropExactDuplicates(obs, source);
  Diagnosis out = diagnoseRows(data, rows, o);
  expandRows(out, source, obs.size());
  return out;
}

}  // namespace orbcal::calib
