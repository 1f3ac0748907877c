#pragma once
// diagnose's engine (calib/src/diagnose.cpp alone includes it): the fits, cross-validations, score
// tests, and the choice of a chosen cause's joints and order, on one dataset with one noise.
#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <future>
#include <map>
#include <mutex>
#include <numeric>
#include <optional>
#include <string>
#include <vector>

#include "diagnose_candidates.hpp"
#include "diagnose_folds.hpp"
#include "diagnose_scores.hpp"
#include "stacked_system.hpp"
#include "orbcal/calib/diagnose.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/errors.hpp"

namespace orbcal::calib {

struct OrderChoice {
  sim::Effect effect;
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

  Fit fitAll(const std::vector<sim::Effect>& effects) const { return fitMarkerModel(startOnAll(effects), obs_, fitOptions()); }

  /// startingModel(data_, obs_, effects), the frames guessed once: a hand-eye solve at every fit of all
  /// the data was 3 % of a diagnosis' CPU (the real iiwa7).
  sim::KinematicModel startOnAll(const std::vector<sim::Effect>& effects) const {
    std::call_once(start_once_, [this] { start_.emplace(startingModel(data_, obs_, {})); });
    return startingModelFrom(*start_, obs_, effects);
  }

  /// Cross-validated held-out whitened SSE and residuals of a model with `effects`. With `warm` (a
  /// fit of all the data whose effects are the first of `effects`), every fold starts from its frames
  /// and parameters (the added effects at zero) instead of the closed-form start: the same optimum,
  /// fewer iterations.
  /// With `extremes` (driving variables' columns, prepared by prepareExtremes): also each one's extremes
  /// held out (CvResult::extremes).
  CvResult crossValidate(const std::vector<sim::Effect>& effects, const Fit* warm = nullptr,
                         const std::vector<std::string>& extremes = {}) const {
    // A cold start depends on the effects alone: backward elimination and the shares of the excess
    // ask again for models already cross-validated (the base model, a prefix of the selection).
    std::string key;
    for (const sim::Effect& e : effects) key += sim::formatEffect(e) + " ";
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

  CvResult crossValidateFolds(const std::vector<sim::Effect>& effects, const Fit* warm, const std::vector<std::string>& extremes) const {
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
  Fit fitLean(const std::vector<sim::Effect>& effects, const Fit* warm) const {
    FitOptions f = fitOptions();
    f.analyze = false;
    if (!warm) return fitMarkerModel(startOnAll(effects), obs_, f);
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
  CvResult oneStepFolds(const std::vector<sim::Effect>& effects, const Fit* warm, const std::vector<std::string>& extremes) const {
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
    // The normal equations (free columns alone, scaled) of each group of held-out samples and of all.
    std::vector<HeldOutGroup> groups;
    for (int f = 0; f < folds_.k; ++f) groups.push_back({&folds_.fold, f});
    for (const std::string& c : extremes) groups.push_back({&extreme_folds_.at(c), 1});
    std::vector<Eigen::MatrixXd> Ng;
    std::vector<Eigen::VectorXd> gg;
    groupNormals(m, free, scale, groups, Ng, gg);
    CvResult r;
    r.residual.resize(obs_.size());
    // The held-out whitened SSE of group i's observations (fold[k] == f), their residuals into r.residual.
    const auto holdOut = [&](std::size_t i, const std::vector<int>& fold, int f, bool keep) {
      Eigen::MatrixXd N = Ng.back() - Ng[i];
      Eigen::VectorXd g = gg.back() - gg[i];
      std::vector<MarkerObservation> test;
      std::vector<std::size_t> test_index;
      for (std::size_t k = 0; k < obs_.size(); ++k) {
        if (fold[k] != f) continue;
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
    for (int f = 0; f < folds_.k; ++f) r.sse += holdOut(static_cast<std::size_t>(f), folds_.fold, f, true);
    for (std::size_t e = 0; e < extremes.size(); ++e) {
      r.extremes[extremes[e]] = holdOut(static_cast<std::size_t>(folds_.k) + e, extreme_folds_.at(extremes[e]), 1, false);
    }
    return r;
  }

  /// Score tests of the candidates at the full fit of `current`.
  struct Projection {
    double absorbed = 0.0;  ///< fraction of the columns' norm the current model absorbs
  };
  std::vector<CandidateResult> scoreTests(const std::vector<sim::Effect>& current, const Fit& fit,
                                          const std::vector<sim::Effect>& candidates, int step,
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
    // Each layer's extended model at the fit (its candidates at zero), each candidate's columns at its
    // parameters' typical magnitudes: each column is then the whitened change a typical-size effect
    // makes to the data.
    std::vector<MarkerPoseModel> models;
    std::vector<CandidateColumns> columns(candidates.size());
    for (std::size_t l = 0; l < layers.size(); ++l) {
      std::vector<sim::Effect> all = current;
      for (std::size_t c : layers[l]) all.push_back(candidates[c]);
      const sim::KinematicModel ext = sim::makeKinematicModel(fit.model.arm, fit.model.sessions, fit.model.base, fit.model.marker,
                                                              fit.model.world_T_base, fit.model.flange_T_marker, all, true,
                                                              fit.model.marker_points);
      Eigen::VectorXd p = Eigen::VectorXd::Zero(ext.layout.size());
      p.head(fit.p.size()) = fit.p;
      const Eigen::VectorXd typical = ext.layout.typical();
      for (std::size_t k = 0; k < layers[l].size(); ++k) {
        CandidateColumns& cc = columns[layers[l][k]];
        cc.layer = l;
        for (const int blk : ext.effect_blocks[current.size() + k]) {
          const sim::ParamBlock& pb = ext.layout.block(blk);
          for (int i = pb.offset; i < pb.offset + pb.size(); ++i) cc.cols.push_back(i);
        }
        cc.scale.resize(static_cast<Eigen::Index>(cc.cols.size()));
        for (std::size_t i = 0; i < cc.cols.size(); ++i) cc.scale[static_cast<Eigen::Index>(i)] = typical[cc.cols[i]];
      }
      models.emplace_back(ext, obs_, noise_, p);
    }
    // The current model's free columns span what the fit absorbs.
    std::vector<int> free;
    for (int i = 0; i < fit.model.layout.size(); ++i) {
      if (!std::binary_search(fit.estimate.held.begin(), fit.estimate.held.end(), i)) free.push_back(i);
    }
    const ScoreStatistics stats = scoreStatistics(models, free, columns);
    const double dof = stats.dof;

    std::vector<CandidateResult> out;
    if (projections) projections->clear();
    for (std::size_t c = 0; c < candidates.size(); ++c) {
      CandidateResult r;
      r.effect = candidates[c];
      r.step = step;
      r.params = static_cast<int>(columns[c].cols.size());
      const ScoreStatistic& st = stats.candidates[c];
      // A joint that never moves, a torque that is only sensor noise: rank 0, not testable here.
      r.rank = st.rank;
      if (st.rank > 0) {
        r.score = st.score;
        // F form: the residual variance is estimated from the same fit.
        r.p_value = fSurvival(r.score / st.rank, st.rank, dof - st.rank);
      }
      out.push_back(r);
      if (projections) projections->push_back(Projection{st.absorbed});
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

  std::vector<sim::Effect> catalog() const { return catalogCandidates(data_, obs_, o_); }

  /// The order of a chosen cause with orders (cyclic: harmonics 1..max_order; compliance: degree 1 or 3):
  /// from the lowest, a higher order replaces the current choice only where it earns more after its
  /// penalty per parameter both on the random folds and with the extremes of its driving variables held
  /// out (a cubic fitted inside the training range must also predict its edges better). `cv` is the
  /// chosen order's, with `extremes` (the chosen's driving variables' columns).
  OrderChoice refineOrder(const std::vector<sim::Effect>& selected, const sim::Effect& chosen, const CvResult& cv,
                          const Fit& current_fit, const std::vector<std::string>& extremes) const {
    const sim::EffectKind& kind = chosen.kind();
    if (kind.maxOrder() == 0) return {chosen, cv};
    std::vector<OrderChoice> orders;
    for (int k = 1; k <= std::min(kind.maxOrder(), std::max(o_.max_order, chosen.order())); ++k) {
      if (k == chosen.order()) {
        orders.push_back({chosen, cv});
        continue;
      }
      const sim::Effect e = sim::Effect(kind, chosen.joints(), k, chosen.reference()).withRange(chosen.lo(), chosen.hi());
      try {
        kind.check(e, data_.arm.numJoints(), "order");
      } catch (const sim::InputError&) {
        continue;
      }
      std::vector<sim::Effect> trial = selected;
      trial.push_back(e);
      orders.push_back({e, crossValidate(trial, &current_fit, extremes)});
    }
    std::size_t best = 0;
    for (std::size_t k = 1; k < orders.size(); ++k) {
      if (earns(orders[best], orders[k], !extremes.empty())) best = k;
    }
    return orders[best];
  }

  /// The chosen cause's kind on its joint and on the joints of the members of its confounded set of
  /// the same kind (a compliance of joints 4 and 2, whose torques both follow one angle): the kind
  /// acting on all of them, as every loaded joint of an arm gives, shares what one alone would take
  /// and extrapolates by each joint's own load. It replaces the choice only where it earns its extra
  /// parameters' penalty both on the random folds and with the extremes of the driving variables held
  /// out, as a higher order must (refineOrder); nothing otherwise.
  std::optional<OrderChoice> pooledJoints(const std::vector<sim::Effect>& selected, const OrderChoice& chosen,
                                          const std::vector<sim::Effect>& confounded, const Fit& current_fit,
                                          const std::vector<std::string>& extremes) const {
    const sim::Effect& c = chosen.effect;
    if (c.joints().size() != 1) return std::nullopt;
    std::vector<int> joints = c.joints();
    for (const sim::Effect& e : confounded) {
      if (&e.kind() == &c.kind() && e.joints().size() == 1 && e.joints() != c.joints()) joints.push_back(e.joints().front());
    }
    if (joints.size() < 2) return std::nullopt;
    std::sort(joints.begin(), joints.end());
    const sim::Effect pooled = sim::Effect(c.kind(), joints, c.order(), c.reference()).withRange(c.lo(), c.hi());
    try {
      c.kind().check(pooled, data_.arm.numJoints(), "joints");
    } catch (const sim::InputError&) {
      return std::nullopt;
    }
    std::vector<sim::Effect> trial = selected;
    trial.push_back(pooled);
    OrderChoice p{pooled, crossValidate(trial, &current_fit, extremes)};
    if (earns(chosen, p, !extremes.empty())) return p;
    return std::nullopt;
  }

  /// `to` replaces `from` (a higher order, pooled joints): it lowers the held-out whitened SSE by more
  /// than the penalty for its extra parameters on the random folds and, with `extremes`, also with the
  /// extremes of the driving variables held out.
  bool earns(const OrderChoice& from, const OrderChoice& to, bool extremes) const {
    const double extra = o_.penalty_per_param * (paramCount(to.effect) - paramCount(from.effect));
    const bool edges = !extremes || from.cv.extremesSse() - to.cv.extremesSse() > extra;
    return from.cv.sse - to.cv.sse > extra && edges;
  }

  int paramCount(const sim::Effect& e) const {
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
  mutable std::once_flag start_once_;
  mutable std::optional<sim::KinematicModel> start_;  ///< startingModel(data_, obs_, {}) (startOnAll)
};

}  // namespace orbcal::calib
