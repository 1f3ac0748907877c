#include "orbcal/calib/lack_of_fit.hpp"

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <memory>

#include "halves.hpp"
#include "orbcal/calib/diagnose.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::calib {

namespace {

/// sin(h q), cos(h q) for h = from..to (n x 2 (to - from + 1)).
Eigen::MatrixXd harmonics(const Eigen::VectorXd& q, int from, int to) {
  Eigen::MatrixXd X(q.size(), 2 * (to - from + 1));
  for (int h = from; h <= to; ++h) {
    X.col(2 * (h - from)) = (h * q.array()).sin().matrix();
    X.col(2 * (h - from) + 1) = (h * q.array()).cos().matrix();
  }
  return X;
}

bool varies(const Eigen::VectorXd& v) { return v.size() > 0 && (v.array() - v.mean()).abs().maxCoeff() > 1e-12; }

std::vector<VariableTest> holmAdjusted(std::vector<VariableTest> tests) {
  std::vector<double> ps;
  for (const VariableTest& t : tests) ps.push_back(t.p_value);
  const std::vector<double> adj = holmAdjust(ps);
  for (std::size_t i = 0; i < tests.size(); ++i) tests[i].p_adjusted = adj[i];
  return tests;
}

}  // namespace

std::vector<EvidenceVariable> evidenceVariables(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs,
                                                const sim::KinematicModel& model, const Eigen::VectorXd& p, bool extended,
                                                const std::vector<Eigen::MatrixXd>* whitened_jq) {
  const int n = static_cast<int>(obs.size());
  std::vector<EvidenceVariable> vars;
  const auto add = [&](std::string name, Eigen::MatrixXd X, std::string label, Eigen::VectorXd axis) {
    vars.push_back({std::move(name), std::move(X), Eigen::MatrixXd(), std::move(label), std::move(axis)});
  };
  const bool stack = whitened_jq && static_cast<int>(whitened_jq->size()) == n && n > 0;
  const int m = stack ? static_cast<int>(whitened_jq->front().rows()) : 0;
  const auto column = [&](auto get) {
    Eigen::VectorXd v(n);
    for (int i = 0; i < n; ++i) v[i] = get(obs[static_cast<std::size_t>(i)], i);
    return v;
  };
  const int J = data.arm.numJoints();
  std::vector<int> moving;
  for (int j = 0; j < J; ++j) {
    const std::string joint = "joint " + std::to_string(j + 1);
    const std::string value = sim::jointValueName(data.arm, j);
    const Eigen::VectorXd q = column([&](const MarkerObservation& o, int) { return o.sample.q_rad[j]; });
    if (!varies(q)) continue;
    moving.push_back(j);
    const Eigen::VectorXd q_edge = q * sim::jointEdgeScale(data.arm, j);
    const std::string label = sim::jointEdgeLabel(data.arm, j);
    add(value + " (harmonics 1, 2)", harmonics(q, 1, 2), label, q_edge);
    if (extended) {
      const Eigen::MatrixXd H = harmonics(q, 3, 6);
      add(value + " (harmonics 3-6)", H, label, q_edge);
      if (stack) {
        Eigen::MatrixXd& S = vars.back().stacked;
        S.resize(static_cast<Eigen::Index>(n) * m, H.cols());
        onHalves(n, [&](int k0, int k1) {
          for (int i = k0; i < k1; ++i) S.middleRows(static_cast<Eigen::Index>(i) * m, m) = (*whitened_jq)[static_cast<std::size_t>(i)].col(j) * H.row(i);
          return 0;
        });
      }
    }
    if (obs.front().sample.hasTorque()) {
      const Eigen::VectorXd t = column([&](const MarkerObservation& o, int) { return o.sample.tau_Nm[j]; });
      if (varies(t)) {
        const std::string effort = sim::jointEffortName(data.arm, j);
        add(effort, t, sim::jointEffortLabel(data.arm, j), t);
        if (extended) {
          Eigen::MatrixXd T(n, 3);
          T << t, t.array().square().matrix(), t.array().cube().matrix();
          add(effort + " (cubic)", T, sim::jointEffortLabel(data.arm, j), t);
        }
      }
    }
    if (obs.front().sample.direction.size() == J) {
      const Eigen::VectorXd d = column([&](const MarkerObservation& o, int) { return o.sample.direction[j]; });
      if (varies(d)) add(joint + " approach direction", d, joint + " approach direction", d);
    }
  }
  if (data.has_temperature) {
    const Eigen::VectorXd t = column([](const MarkerObservation& o, int) { return o.sample.temperature_C; });
    add("temperature", t, "temperature (degC)", t);
  }
  if (data.has_time) {
    const Eigen::VectorXd t = column([](const MarkerObservation& o, int) { return o.sample.time_s; });
    add("time", t, "time (s)", t);
  }
  const Eigen::VectorXd order = column([](const MarkerObservation&, int i) { return static_cast<double>(i); });
  add("sample order", order, "sample", order);
  Eigen::MatrixXd W(n, 3);
  onHalves(n, [&](int k0, int k1) {
    for (int i = k0; i < k1; ++i) W.row(i) = sim::predictMarkerPose(model, p, obs[static_cast<std::size_t>(i)].sample).translation().transpose();
    return 0;
  });
  add("workspace position", W, "marker x (m)", W.col(0));
  if (extended) {
    // Quadratic: the linear terms, the squares and the cross products (a bowl or a saddle in space).
    Eigen::MatrixXd Q(n, 9);
    Q << W, W.array().square().matrix(), (W.col(0).array() * W.col(1).array()).matrix(),
        (W.col(0).array() * W.col(2).array()).matrix(), (W.col(1).array() * W.col(2).array()).matrix();
    add("workspace position (quadratic)", Q, "marker x (m)", W.col(0));
  }
  if (data.numSessions() > 1) {
    Eigen::MatrixXd S = Eigen::MatrixXd::Zero(n, data.numSessions() - 1);
    Eigen::VectorXd s(n);
    for (int i = 0; i < n; ++i) {
      const int session = obs[static_cast<std::size_t>(i)].sample.session;
      s[i] = session;
      if (session > 0) S(i, session - 1) = 1.0;
    }
    add("session", S, "session", s);
  }
  if (extended) {
    // Products of joint-angle pairs, one column each: a family of J(J-1)/2, not the sin/cos cross terms.
    for (std::size_t a = 0; a < moving.size(); ++a) {
      for (std::size_t b = a + 1; b < moving.size(); ++b) {
        const int i = moving[a], j = moving[b];
        const Eigen::VectorXd x = column([&](const MarkerObservation& o, int) { return o.sample.q_rad[i] * o.sample.q_rad[j]; });
        const bool angles = !data.arm.isPrismatic(i) && !data.arm.isPrismatic(j);
        const std::string pair = "joints " + std::to_string(i + 1) + " x " + std::to_string(j + 1) + (angles ? " angles" : " values");
        const std::string unit_i = sim::jointEdgeUnit(data.arm, i), unit_j = sim::jointEdgeUnit(data.arm, j);
        add(pair + " (product)", x, pair + " (" + (unit_i == unit_j ? unit_i + "^2" : unit_i + " " + unit_j) + ")",
            x * sim::jointEdgeScale(data.arm, i) * sim::jointEdgeScale(data.arm, j));
      }
    }
  }
  return vars;
}

std::vector<VariableTest> variableTests(const Eigen::MatrixXd& Y, const std::vector<EvidenceVariable>& vars,
                                        const ModelColumns* model) {
  const int n = static_cast<int>(Y.rows()), m = static_cast<int>(Y.cols());
  if (n < 10) return {};
  if (model) return holmAdjusted(addedVariableTests(Y, vars, *model));
  std::vector<VariableTest> out;
  const Eigen::MatrixXd Yc = Y.rowwise() - Y.colwise().mean();
  const double total = Yc.squaredNorm();
  // Stacked: y = the components one after another per sample, centred per component (as Yc).
  Eigen::VectorXd y(n * m);
  for (int i = 0; i < n; ++i) y.segment(i * m, m) = Yc.row(i).transpose();
  for (const EvidenceVariable& v : vars) {
    if (v.stacked.size() > 0) {
      if (v.stacked.rows() != n * m) continue;
      Eigen::MatrixXd Xs = v.stacked;
      for (int c = 0; c < m; ++c) {  // centred per component, as y
        Eigen::RowVectorXd mean = Eigen::RowVectorXd::Zero(Xs.cols());
        for (int i = 0; i < n; ++i) mean += Xs.row(i * m + c);
        mean /= n;
        for (int i = 0; i < n; ++i) Xs.row(i * m + c) -= mean;
      }
      const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(Xs);
      const int d = static_cast<int>(qr.rank());
      const int dof2 = n * m - d - m;
      if (d == 0 || dof2 <= 0) continue;
      const double explained = (Xs * qr.solve(y)).squaredNorm();
      VariableTest t;
      t.variable = v.name;
      t.dof = d;
      t.statistic = (explained / d) / (std::max(1e-300, total - explained) / dof2);
      t.p_value = fSurvival(t.statistic, d, dof2);
      out.push_back(t);
      continue;
    }
    const Eigen::MatrixXd Xc = v.X.rowwise() - v.X.colwise().mean();
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(Xc);
    const int d = static_cast<int>(qr.rank());
    if (d == 0 || n - d - 1 <= 0) continue;
    const Eigen::MatrixXd fitted = Xc * qr.solve(Yc);
    const double explained = fitted.squaredNorm();
    const double resid = std::max(1e-300, total - explained);
    VariableTest t;
    t.variable = v.name;
    t.dof = d;
    t.statistic = (explained / (m * d)) / (resid / (m * (n - d - 1)));
    t.p_value = fSurvival(t.statistic, m * d, m * (n - d - 1));
    out.push_back(t);
  }
  return holmAdjusted(std::move(out));
}

Eigen::MatrixXd scaledResiduals(const std::vector<Eigen::VectorXd>& residual, const MarkerNoise& noise) {
  const Eigen::Index n = static_cast<Eigen::Index>(residual.size());
  const Eigen::Index m = n ? residual.front().size() : 0;
  Eigen::MatrixXd Y(n, m);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index c = 0; c < m; ++c) Y(i, c) = residual[static_cast<std::size_t>(i)][c] / (c < 3 ? noise.sigma_position_m : noise.sigma_rotation_rad);
  }
  return Y;
}

Eigen::MatrixXd groupMeans(const Eigen::MatrixXd& A, const std::vector<MarkerObservation>& obs, int rows_per) {
  const auto groups = configurationGroups(obs);
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(groups.size()) * rows_per, A.cols());
  Eigen::Index g = 0;
  for (const auto& [key, members] : groups) {
    for (int i : members) out.middleRows(g * rows_per, rows_per) += A.middleRows(static_cast<Eigen::Index>(i) * rows_per, rows_per);
    out.middleRows(g * rows_per, rows_per) /= static_cast<double>(members.size());
    ++g;
  }
  return out;
}

Eigen::MatrixXd whitenedResiduals(const Fit& fit, const std::vector<MarkerObservation>& obs, const MarkerNoise& noise,
                                  const std::vector<Eigen::VectorXd>& residual, std::vector<Eigen::MatrixXd>* whitened_jq) {
  const MarkerPoseModel model(fit.model, obs, noise, fit.p);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model.numParams());
  const int n = static_cast<int>(obs.size());
  const Eigen::Index m = n ? residual.front().size() : 0;
  Eigen::MatrixXd Y(n, m);
  if (whitened_jq) whitened_jq->assign(obs.size(), Eigen::MatrixXd());
  // Each sample's row (and W_k J_q) written in place: the two halves side by side.
  onHalves(n, [&](int k0, int k1) {
    for (int k = k0; k < k1; ++k) {
      const Eigen::LLT<Eigen::MatrixXd> llt(model.innovationAndCovariance(k, zero).R);
      const Eigen::MatrixXd& r = residual[static_cast<std::size_t>(k)];
      Y.row(k) = llt.matrixL().solve(r).transpose();
      if (whitened_jq) (*whitened_jq)[static_cast<std::size_t>(k)] = llt.matrixL().solve(model.jointJacobian(k, zero));
    }
    return 0;
  });
  return Y;
}

ModelColumns whitenedModelColumns(const Fit& fit, const std::vector<MarkerObservation>& obs, const MarkerNoise& noise,
                                  bool group_means) {
  auto model = std::make_shared<const MarkerPoseModel>(fit.model, obs, noise, fit.p);
  auto free = std::make_shared<std::vector<int>>();
  for (int j = 0; j < model->numParams(); ++j) {
    if (!std::binary_search(fit.estimate.held.begin(), fit.estimate.held.end(), j)) free->push_back(j);
  }
  // The rows: each sample in its order, or each replicate group (configurationGroups' order, as groupMeans).
  auto rows = std::make_shared<std::vector<std::vector<int>>>();
  if (group_means) {
    for (const auto& [key, members] : configurationGroups(obs)) rows->push_back(members);
  } else {
    for (int k = 0; k < static_cast<int>(obs.size()); ++k) rows->push_back({k});
  }
  ModelColumns c;
  c.rows = static_cast<int>(rows->size());
  c.components = obs.empty() ? 0 : model->rows(0);
  c.params = static_cast<int>(free->size());
  c.fill = [model, free, rows, m = c.components](int first, int count, Eigen::MatrixXd& J) {
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model->numParams());
    J.setZero(static_cast<Eigen::Index>(count) * m, static_cast<Eigen::Index>(free->size()));
    for (int r = 0; r < count; ++r) {
      const std::vector<int>& members = (*rows)[static_cast<std::size_t>(first + r)];
      for (int k : members) {
        const Linearization lin = model->linearize(k, zero);
        J.middleRows(static_cast<Eigen::Index>(r) * m, m) += Eigen::LLT<Eigen::MatrixXd>(lin.R).matrixL().solve(lin.H(Eigen::all, *free));
      }
      J.middleRows(static_cast<Eigen::Index>(r) * m, m) /= static_cast<double>(members.size());
    }
  };
  return c;
}

PureError pureError(const std::vector<MarkerObservation>& obs, const std::vector<Eigen::VectorXd>& residual) {
  PureError pe;
  for (const auto& [key, members] : configurationGroups(obs)) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (int i : members) mean += residual[static_cast<std::size_t>(i)].head<3>();
    mean /= static_cast<double>(members.size());
    for (int i : members) pe.ss += (residual[static_cast<std::size_t>(i)].head<3>() - mean).squaredNorm();
    pe.ss_group_means += static_cast<double>(members.size()) * mean.squaredNorm();
    ++pe.groups;
    pe.replicated += members.size() > 1 ? 1 : 0;
    pe.dof += 3 * (static_cast<int>(members.size()) - 1);
  }
  return pe;
}

namespace {

/// One sample's terms of a HeldoutNoise: Rp its noise's position covariance, V its prediction's
/// covariance (zero without the parameters' covariance), r its held-out position residual.
void addHeldoutTerms(HeldoutNoise& h, const Eigen::Matrix3d& Rp, const Eigen::Matrix3d* V, const Eigen::Vector3d& r) {
  const Eigen::LDLT<Eigen::Matrix3d> Rinv(Rp);
  h.position_ms_m2 += Rp.trace();
  Eigen::Matrix3d S = Rp;
  if (V) {
    h.estimation_ms_m2 += V->trace();
    h.whitened_estimation += Rinv.solve(*V).trace();
    S += *V;
  }
  h.chi2 += r.dot(Rinv.solve(r));
  h.residual_ms_m2 += r.squaredNorm();
  h.residual_ms_var_m4 += 2.0 * S.squaredNorm();  // Var(r^T r) = 2 tr(S^2) for r ~ N(0, S)
}

void addHeldout(HeldoutNoise& to, const HeldoutNoise& h) {
  to.position_ms_m2 += h.position_ms_m2;
  to.estimation_ms_m2 += h.estimation_ms_m2;
  to.whitened_estimation += h.whitened_estimation;
  to.chi2 += h.chi2;
  to.residual_ms_m2 += h.residual_ms_m2;
  to.residual_ms_var_m4 += h.residual_ms_var_m4;
}

}  // namespace

std::vector<HeldoutNoise> heldoutNoises(const Fit& fit, const std::vector<MarkerObservation>& obs, const std::vector<MarkerNoise>& noises,
                                        const std::vector<Eigen::VectorXd>& residual, int folds) {
  std::vector<HeldoutNoise> out(noises.size());
  if (obs.empty() || noises.empty()) return out;
  // At the fit (y = 0 about p): R_k as every fit whitens with it (tracker or the sample's own
  // covariance, plus the joint noise through J_e_q), H_k for the parameters' covariance: one H per
  // sample, whatever the noise.
  std::vector<MarkerPoseModel> models;
  models.reserve(noises.size());
  for (const MarkerNoise& noise : noises) models.emplace_back(fit.model, obs, noise, fit.p);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(models.front().numParams());
  const Eigen::MatrixXd& cov = fit.estimate.covariance;
  const bool have_cov = cov.rows() == zero.size() && cov.cols() == zero.size();
  // A prediction from the other K-1 folds: their information is about (K-1)/K of all the data's, so
  // the variance of its parameters, and of the prediction, is K/(K-1) times the all-data one.
  const double k = folds > 1 ? static_cast<double>(folds) / (folds - 1) : 1.0;
  const auto part = [&](int s0, int s1) {
    std::vector<HeldoutNoise> h(noises.size());
    for (int s = s0; s < s1; ++s) {
      const Linearization first = have_cov ? models.front().linearize(s, zero) : models.front().innovationAndCovariance(s, zero);
      Eigen::Matrix3d V = Eigen::Matrix3d::Zero();
      if (have_cov) {
        const Eigen::MatrixXd Hp = first.H.topRows(3);
        V = k * Hp * cov * Hp.transpose();
      }
      const Eigen::Vector3d r = residual[static_cast<std::size_t>(s)].head<3>();
      for (std::size_t i = 0; i < models.size(); ++i) {
        const Eigen::MatrixXd R = i == 0 ? first.R : models[i].innovationAndCovariance(s, zero).R;
        addHeldoutTerms(h[i], R.topLeftCorner<3, 3>(), have_cov ? &V : nullptr, r);
      }
    }
    return h;
  };
  const int n = models.front().numSamples();
  const auto [lower, upper] = onHalves(n, part);
  const double samples = n;
  for (std::size_t i = 0; i < out.size(); ++i) {
    addHeldout(out[i], lower[i]);
    addHeldout(out[i], upper[i]);
    out[i].position_ms_m2 /= samples;
    out[i].estimation_ms_m2 /= samples;
    out[i].residual_ms_m2 /= samples;
    out[i].residual_ms_var_m4 /= samples * samples;
  }
  return out;
}

HeldoutNoise heldoutNoise(const Fit& fit, const std::vector<MarkerObservation>& obs, const MarkerNoise& noise,
                          const std::vector<Eigen::VectorXd>& residual, int folds) {
  return heldoutNoises(fit, obs, {noise}, residual, folds).front();
}

const char* noiseSourceName(NoiseSource s) {
  switch (s) {
    case NoiseSource::kStated: return "stated";
    case NoiseSource::kPureError: return "pure_error";
    case NoiseSource::kResiduals: break;
  }
  return "residuals";
}

namespace {

/// The global test of `lof` (source already set): chi-square against the stated noise or F against pure
/// error, each against its expectation with the estimation variance.
void globalTest(LackOfFit& lof, const HeldoutNoise& h, int samples) {
  const double rows = 3.0 * samples;
  if (lof.source == NoiseSource::kStated) {
    // Held-out whitened position SSE: rows chi-square terms plus the estimation variance. Scaled to
    // its expectation and read as chi-square(rows) (the estimation share is a few per cent).
    lof.dof1 = rows;
    lof.statistic = h.chi2 * rows / (rows + h.whitened_estimation);
    lof.p_value = chiSquareSurvival(lof.statistic, rows);
    lof.tested = true;
  } else if (lof.source == NoiseSource::kPureError) {
    // The lack-of-fit sum of squares (group means of the held-out residuals, n_g-weighted) expects
    // 3 G sigma^2 + the estimation variance (m^2, summed over samples); sigma^2 from pure error.
    const PureError& pe = lof.pure;
    const double s2 = pe.ss / pe.dof;
    lof.dof1 = 3.0 * pe.groups;
    lof.dof2 = pe.dof;
    lof.statistic = pe.ss_group_means / (lof.dof1 * s2 + samples * h.estimation_ms_m2);
    lof.p_value = fSurvival(lof.statistic, lof.dof1, lof.dof2);
    lof.tested = true;
  }
}

}  // namespace

LackOfFit lackOfFit(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs, const Fit& fit,
                    const MarkerNoise& noise, const std::vector<Eigen::VectorXd>& residual, bool stated, int folds,
                    double alpha) {
  LackOfFit lof;
  const int n = static_cast<int>(obs.size());
  if (n == 0 || residual.size() != obs.size()) return lof;
  const HeldoutNoise h = heldoutNoise(fit, obs, noise, residual, folds);
  lof.pure = pureError(obs, residual);
  lof.source = stated ? NoiseSource::kStated : lof.pure.dof > 0 ? NoiseSource::kPureError : NoiseSource::kResiduals;
  // (c): from the tested model's own fit on all the data (its position mean square, corrected for the
  // parameters fitted: rows / dof), not from the base model's, whose residuals hold the very structure
  // the effects explain.
  const double rows = static_cast<double>(fit.dof) + static_cast<double>(fit.estimate.y.size() - static_cast<Eigen::Index>(fit.estimate.held.size()));
  const double own_ms = std::pow(fit.residuals.position_rms_m, 2) * rows / std::max(1, fit.dof);
  const double noise_ms = lof.source == NoiseSource::kPureError ? 3.0 * lof.pure.ss / lof.pure.dof
                          : lof.source == NoiseSource::kStated  ? h.position_ms_m2
                                                                : own_ms;
  lof.noise_position_rms_m = std::sqrt(noise_ms);
  lof.estimation_factor = 1.0 + h.estimation_ms_m2 / std::max(1e-300, noise_ms);
  double ms = 0.0;
  for (const Eigen::VectorXd& r : residual) ms += r.head<3>().squaredNorm();
  ms /= n;
  lof.position_rms_m = std::sqrt(ms);
  lof.excess_rms_m = std::sqrt(std::max(0.0, ms - noise_ms));
  lof.excess_share = ms > 0.0 ? std::max(0.0, ms - noise_ms) / ms : 0.0;
  globalTest(lof, h, n);
  // Two routes to the verdict (the global test, the variable family): alpha/2 each (Bonferroni), so
  // that a clean model is called unexplained with probability at most alpha.
  lof.level = lof.tested ? 0.5 * alpha : alpha;
  lof.significant = lof.tested && lof.p_value < lof.level;

  // The variable family: score tests on the fit's own residuals beside its columns (variableTests).
  const std::vector<Eigen::VectorXd> own = markerResiduals(fit.model, fit.p, obs);
  std::vector<Eigen::MatrixXd> whitened_jq;
  const Eigen::MatrixXd Y = whitenedResiduals(fit, obs, noise, own, &whitened_jq);
  const std::vector<EvidenceVariable> vars = evidenceVariables(data, obs, fit.model, fit.p, true, &whitened_jq);
  if (lof.pure.replicated > 0) {
    // One row per configuration: copies of one configuration are no new configurations of its structure
    // (rows repeated exactly must not change the verdict), so the family is tested on their means.
    std::vector<EvidenceVariable> means = vars;
    const int m = static_cast<int>(residual.front().size());
    for (EvidenceVariable& v : means) {
      v.X = groupMeans(v.X, obs);
      if (v.stacked.size() > 0) v.stacked = groupMeans(v.stacked, obs, m);
    }
    const ModelColumns columns = whitenedModelColumns(fit, obs, noise, true);
    lof.evidence = variableTests(groupMeans(Y, obs), means, &columns);
  } else {
    const ModelColumns columns = whitenedModelColumns(fit, obs, noise, false);
    lof.evidence = variableTests(Y, vars, &columns);
  }
  for (const VariableTest& t : lof.evidence) {
    if (t.p_adjusted < lof.level) lof.unexplained.push_back(t);
  }
  std::stable_sort(lof.unexplained.begin(), lof.unexplained.end(), [](const VariableTest& a, const VariableTest& b) {
    return a.p_value < b.p_value || (a.p_value == b.p_value && a.statistic > b.statistic);
  });
  if (!lof.unexplained.empty()) {
    for (const EvidenceVariable& v : vars) {
      if (v.name != lof.unexplained.front().variable) continue;
      lof.axis_label = v.axis_label;
      lof.axis_values = v.axis_values;
    }
  }
  return lof;
}

std::string describeUnexplained(const std::vector<VariableTest>& unexplained, std::size_t at_most) {
  std::string s;
  const std::size_t k = std::min(at_most, unexplained.size());
  for (std::size_t i = 0; i < k; ++i) {
    const double p = unexplained[i].p_adjusted;  // Holm-adjusted, as the report's table prints it
    s += (i ? (i + 1 == k ? " and " : ", ") : "") + unexplained[i].variable +
         (p < 1e-16 ? std::string(" (p < 1e-16)") : " (p = " + sim::formatNumber("%.2g", p) + ")");
  }
  if (unexplained.size() > k) s += " (and " + std::to_string(unexplained.size() - k) + " more)";
  return s;
}

}  // namespace orbcal::calib

namespace orbcal::calib {

namespace {

/// What a stated floor holds, in words: the tracker's noise and, by NoiseFloors::joint_source, the joint
/// readings' estimate that survived, or why none is counted (with the sums that refused it).
std::string statedFloorWords(const NoiseFloors& n) {
  const auto deg = [](double rad) { return sim::formatNumber("%.2g", rad * sim::kRadToDeg); };
  if (n.joint_source == "survives") {
    return "the stated tracker noise and the joint readings' " + deg(n.joint_floor_rad) +
           " deg (estimated, and resolved beside empirical corrections of every joint)";
  }
  if (n.joint_source != "unstated") return "the stated noise";
  if (!n.estimate_contradicted) return "the stated tracker noise (the joint readings' noise is not stated: none counted)";
  const auto mm = [](double ms_m2) { return sim::formatNumber("%.3g", std::sqrt(ms_m2) * 1e3); };
  return "the stated tracker noise (the joint readings' noise is not stated, and the " + deg(n.joint_estimate_rad) +
         " deg the fits estimate is contradicted by the held-out positions: with it, noise alone would give them " +
         mm(n.estimate_ms_expected_m2) + " mm RMS and a whitened chi-square of " + sim::formatNumber("%.0f", n.estimate_chi2_expected) +
         ", they show " + mm(n.estimate_ms_m2) + " mm and " + sim::formatNumber("%.0f", n.estimate_chi2) + ": none counted)";
}

}  // namespace

std::string unexplainedSentence(const Diagnosis& d) {
  const LackOfFit& l = d.lack_of_fit;
  if (!d.unexplained) return "";
  const auto mm = [](double m) { return sim::formatNumber("%.3g", m * 1e3) + " mm"; };
  const NoiseFloors& n = d.noise;
  const std::string stated = statedFloorWords(n);
  const std::string noise = l.source == NoiseSource::kStated      ? stated
                            : l.source == NoiseSource::kPureError ? "the noise of " + std::to_string(l.pure.replicated) + " repeated configurations (pure error)"
                                                                  : "noise estimated from these residuals";
  const std::string remain = mm(l.excess_rms_m) + " RMS remain above the " + mm(l.noise_position_rms_m) + " " + noise + " gives (" +
                             sim::formatNumber("%.0f", 100.0 * l.excess_share) + " % of the held-out mean square" +
                             (l.tested ? ", lack-of-fit p " + sim::formatNumber("%.2g", l.p_value) : std::string()) + ")";
  const std::string against = l.unexplained.empty() ? ", not structured against any variable tested"
                                                    : ", structured against " + describeUnexplained(l.unexplained);
  if (l.source == NoiseSource::kResiduals) {
    // Nothing independent to measure the excess against: only the structure is reported.
    const std::string what = d.selected.empty() ? "The model leaves structure no cause of the catalog explains"
                                                : "The explanation is partial";
    return what + ": the held-out residuals (position RMS " + mm(l.position_rms_m) + ") are" + against.substr(1) +
           "; with the noise only estimated from these residuals (" + mm(l.noise_position_rms_m) +
           "), how far they stand above it is not measured: state the noise or repeat configurations.";
  }
  if (d.selected.empty()) {
    return "The model leaves structure no cause of the catalog explains: held-out position RMS " + mm(l.position_rms_m) + "; " +
           remain + against + ". Do not take a calibration with this model as complete.";
  }
  std::string s = "The explanation is partial: ";
  for (std::size_t i = 0; i < d.selected.size() && i < d.share_of_excess.size(); ++i) {
    s += (i ? (i + 1 == d.selected.size() ? " and " : ", ") : "") + describeEffect(d.selected[i]) + " explains " +
         sim::formatNumber("%.0f", 100.0 * d.share_of_excess[i]) + " %";
  }
  return s + " of the structure above the noise; " + remain + against + ".";
}

}  // namespace orbcal::calib
