#include "orbcal/calib/experiment.hpp"
#include "orbcal/calib/marker_model.hpp"
#include "orbcal/sim/model.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::calib {

std::vector<MethodSpec> comparisonMethods(double joint_sigma) {
  using Kind = MethodSpec::Kind;
  PoseNoiseModel paper_R;  // Wang et al. 2023: R = diag(0.3 mm, 0.5 deg)^2, no joint noise
  paper_R.source = PoseNoiseModel::Source::kFixed;
  PoseNoiseModel measured_R;  // the measurement's own covariance (vision, or the synthetic noise)
  PoseNoiseModel full_R = measured_R;
  full_R.joint_noise_sigma_rad = joint_sigma;

  EkfOptions paper = EkfOptions::paperLiteral();
  EkfOptions wide_linear;  // orbcal's prior, still J at nominal
  wide_linear.relinearize = false;
  EkfOptions extended;  // orbcal's default
  EkfOptions iterated;
  iterated.iterations_per_update = 3;
  LseOptions unweighted, weighted;
  weighted.weighted = true;
  LmOptions lm, huber;
  huber.loss = LmOptions::Loss::kHuber;

  std::vector<MethodSpec> m;
  m.push_back({"LSE (paper)", "Gauss-Newton, truncated SVD, unweighted (m and rad added as they are)", Kind::kLse, {}, unweighted, {}, paper_R});
  m.push_back({"LSE (weighted)", "Gauss-Newton, truncated SVD, weighted by R = measurement + joint noise", Kind::kLse, {}, weighted, {}, full_R});
  m.push_back({"EKF (paper)", "Wang et al. 2023 as written: P0 0.01 deg / 0.01 mm, Q = 0, J at nominal, R 0.3 mm / 0.5 deg", Kind::kEkf, paper, {}, {}, paper_R});
  m.push_back({"EKF (wide P0 + paper R)", "P0 1 deg / 5 mm, Q = 0, J at nominal, R 0.3 mm / 0.5 deg", Kind::kEkf, wide_linear, {}, {}, paper_R});
  m.push_back({"EKF (measurement R)", "P0 1 deg / 5 mm, re-linearized, R = measurement covariance only", Kind::kEkf, extended, {}, {}, measured_R});
  m.push_back({"EKF", "P0 1 deg / 5 mm, re-linearized, R = measurement + joint noise through J_q (orbcal's default)", Kind::kEkf, extended, {}, {}, full_R});
  m.push_back({"IEKF", "as EKF, 3 re-linearizations per update", Kind::kEkf, iterated, {}, {}, full_R});
  m.push_back({"LM", "Ceres Levenberg-Marquardt, analytic Jacobian, R = measurement + joint noise", Kind::kLm, {}, {}, lm, full_R});
  m.push_back({"LM (Huber)", "as LM with a Huber loss at 3 sigma", Kind::kLm, {}, {}, huber, full_R});
  for (const MethodSpec& s : m) {
    // Names are CSV cells and plot labels: no separators.
    if (s.name.find_first_of(",\n") != std::string::npos) throw std::logic_error("method name with a comma: " + s.name);
  }
  return m;
}

MethodSpec findMethod(const std::vector<MethodSpec>& methods, const std::string& name, const std::string& what) {
  const std::string wanted = name == "LSE" ? "LSE (weighted)" : name;
  std::string others;
  for (const MethodSpec& m : methods) {
    if (m.name == wanted) return m;
    if (m.name != "LM" && m.name != "EKF") others += (others.empty() ? "'" : ", '") + m.name + "'";
  }
  throw sim::InputError(what + ": '" + name + "': expected LM, LSE or EKF, or one of " + others);
}

std::string methodNames() {
  std::string names = "LM, LSE, EKF";
  for (const MethodSpec& m : comparisonMethods(0.0)) {
    if (m.name != "LM" && m.name != "EKF") names += ", " + m.name;
  }
  return names;
}

Estimate runMethod(const MethodSpec& method, const sim::Arm& nominal, const std::vector<PoseObservation>& obs) {
  return runMethod(method, poseModel(nominal, obs, method.noise));
}

namespace {

Estimate runOnce(MethodSpec method, const MeasurementModel& model, const FitControls& controls) {
  for (std::vector<int>* hold : {&method.ekf.hold, &method.lse.hold, &method.lm.hold}) {
    hold->insert(hold->end(), controls.hold.begin(), controls.hold.end());
    std::sort(hold->begin(), hold->end());
    hold->erase(std::unique(hold->begin(), hold->end()), hold->end());
  }
  method.lse.fix_unidentifiable = method.lse.fix_unidentifiable && controls.fix_unidentifiable;
  method.lm.fix_unidentifiable = method.lm.fix_unidentifiable && controls.fix_unidentifiable;
  method.lm.covariance = method.lm.covariance && controls.covariance;
  method.lm.normal_equations = method.lm.normal_equations || controls.normal_equations;
  method.lm.decrease_tolerance = controls.decrease_tolerance;
  method.lm.start = controls.start;
  if (controls.prior_sigma.size() > 0) {
    method.lm.prior_sigma = method.lse.prior_sigma = method.ekf.prior_sigma = controls.prior_sigma;
    method.lm.prior_mean = method.lse.prior_mean = method.ekf.prior_mean = controls.prior_mean;
  }
  Estimate e;
  switch (method.kind) {
    case MethodSpec::Kind::kEkf: e = runEkf(model, method.ekf); break;
    case MethodSpec::Kind::kLse: e = runLse(model, method.lse); break;
    case MethodSpec::Kind::kLm: e = runLm(model, method.lm); break;
  }
  e.method = method.name;
  return e;
}

/// The evidence's prior scale stays within these (a prior of 1e-3 typical sizes holds the parameters at
/// their mean for any data a calibration sees; 1e2 leaves them free).
constexpr double kMinPriorScale = 1e-3, kMaxPriorScale = 1e2;
constexpr int kMaxEvidenceIterations = 40;

/// FitControls::scaled_prior's fixed point.
Estimate runWithEvidence(const MethodSpec& method, const MeasurementModel& model, FitControls c) {
  const int n = model.numParams();
  if (c.prior_sigma.size() == 0) c.prior_sigma = Eigen::VectorXd::Zero(n);
  std::vector<int> scaled;
  for (int i = 0; i < n; ++i) {
    if (c.scaled_prior[i] > 0.0) scaled.push_back(i);
  }
  double tau = 1.0;
  Estimate e;
  Shrinkage s;
  for (int it = 0; it < kMaxEvidenceIterations; ++it) {
    for (int i : scaled) c.prior_sigma[i] = tau * c.scaled_prior[i];
    e = runOnce(method, model, c);
    s = shrinkage(model, e.y, e.held, c.prior_sigma, scaled);
    double q = 0.0;  // sum of the squared scaled deviations from the prior mean
    for (int i : scaled) {
      if (std::binary_search(e.held.begin(), e.held.end(), i)) continue;
      const double dev = (e.y[i] - (c.prior_mean.size() ? c.prior_mean[i] : 0.0)) / c.scaled_prior[i];
      q += dev * dev;
    }
    const double next = s.gamma > 1e-9 && q > 0.0 ? std::clamp(std::sqrt(q / s.gamma), kMinPriorScale, kMaxPriorScale) : kMinPriorScale;
    e.prior_scale = tau;  // the scale e was fitted with
    const bool done = std::abs(std::log(next / tau)) < 1e-3;
    tau = next;
    if (done) break;
  }
  e.effective_parameters = s.effective;
  return e;
}

}  // namespace

Estimate runMethod(MethodSpec method, const MeasurementModel& model, const FitControls& controls) {
  if (controls.scaled_prior.size() > 0) return runWithEvidence(method, model, controls);
  return runOnce(std::move(method), model, controls);
}

Comparison compareMethods(const sim::Arm& nominal, const Eigen::VectorXd& y_true, const std::vector<PoseObservation>& obs,
                          const PlantSamples& validation, const std::vector<MethodSpec>& methods) {
  return compareMethods(nominal, sim::geometricTrueArm(nominal, y_true), obs, validation, methods);
}

Comparison compareMethods(const sim::Arm& nominal, const sim::TrueArm& truth, const std::vector<PoseObservation>& obs,
                          const PlantSamples& validation, const std::vector<MethodSpec>& methods) {
  Comparison c;
  c.observations = static_cast<int>(obs.size());
  c.initial_errors = poseErrors(nominal, validation);
  c.floor_errors = poseErrors(truth, validation);
  c.initial = summarize(c.initial_errors);
  c.floor = summarize(c.floor_errors);
  for (const MethodSpec& m : methods) {
    MethodOutcome o;
    o.method = m;
    o.estimate = runMethod(m, nominal, obs);
    o.errors = poseErrors(calibratedArm(nominal, o.estimate.y), validation);
    o.summary = summarize(o.errors);
    c.methods.push_back(std::move(o));
  }
  return c;
}

Comparison revalidate(const Comparison& c, const sim::Arm& nominal, const Eigen::VectorXd& y_true,
                      const PlantSamples& validation) {
  return revalidate(c, nominal, sim::geometricTrueArm(nominal, y_true), validation);
}

Comparison revalidate(const Comparison& c, const sim::Arm& nominal, const sim::TrueArm& truth,
                      const PlantSamples& validation) {
  Comparison out = c;
  out.initial_errors = poseErrors(nominal, validation);
  out.floor_errors = poseErrors(truth, validation);
  out.initial = summarize(out.initial_errors);
  out.floor = summarize(out.floor_errors);
  for (MethodOutcome& m : out.methods) {
    m.errors = poseErrors(calibratedArm(nominal, m.estimate.y), validation);
    m.summary = summarize(m.errors);
  }
  return out;
}

const MethodOutcome* bestOfKind(const Comparison& c, MethodSpec::Kind kind) {
  const MethodOutcome* best = nullptr;
  for (const MethodOutcome& m : c.methods) {
    if (m.method.kind != kind) continue;
    if (!best || m.summary.position_avg_m < best->summary.position_avg_m) best = &m;
  }
  return best;
}

namespace {
using sim::formatNumber;

void appendErrors(std::ostringstream& out, const std::string& model, const PoseErrors& e) {
  char buf[160];
  for (std::size_t k = 0; k < e.position_m.size(); ++k) {
    const Eigen::Vector3d o = e.orientation_rad[k] * sim::kRadToDeg;
    std::snprintf(buf, sizeof buf, ",%zu,%.6f,%.7f,%.7f,%.7f\n", k, e.position_m[k] * 1e3, o.x(), o.y(), o.z());
    out << model << buf;
  }
}
}  // namespace

std::string formatValidationErrorsCsv(const Comparison& c) {
  std::ostringstream out;
  out << "model,sample,position_mm,x_deg,y_deg,z_deg\n";
  appendErrors(out, "initial", c.initial_errors);
  appendErrors(out, "floor", c.floor_errors);
  for (const MethodOutcome& m : c.methods) appendErrors(out, m.method.name, m.errors);
  return out.str();
}

std::string formatComparisonSummaryCsv(const Comparison& c) {
  std::ostringstream out;
  out << "method,avg_position_mm,max_position_mm,avg_x_deg,avg_y_deg,avg_z_deg,x_floor\n";
  const auto row = [&](const std::string& name, const ErrorSummary& e) {
    const Eigen::Vector3d d = e.orientation_avg_rad * sim::kRadToDeg;
    char buf[200];
    std::snprintf(buf, sizeof buf, ",%.6f,%.6f,%.7f,%.7f,%.7f,%.6f\n", e.position_avg_m * 1e3, e.position_max_m * 1e3, d.x(),
                  d.y(), d.z(), c.floor.position_avg_m > 0 ? e.position_avg_m / c.floor.position_avg_m : 0.0);
    out << name << buf;
  };
  row("initial", c.initial);
  row("floor", c.floor);
  for (const MethodOutcome& m : c.methods) row(m.method.name, m.summary);
  return out.str();
}

std::string formatEstimatesCsv(const sim::Arm& nominal, const Comparison& c, const Eigen::VectorXd* y_true,
                               const ParameterClasses* classes) {
  std::ostringstream out;
  out << "method,parameter,unit,estimate,sigma,truth,held,class\n";
  char buf[200];
  const sim::ParamBlock g = sim::geometryBlock(nominal);
  for (const MethodOutcome& m : c.methods) {
    const Estimate& e = m.estimate;
    for (Eigen::Index i = 0; i < e.y.size(); ++i) {
      const sim::ParamInfo& info = g.params[static_cast<std::size_t>(i)];
      const double s = info.display_scale;
      const bool held = std::find(e.held.begin(), e.held.end(), static_cast<int>(i)) != e.held.end();
      const std::string truth = y_true ? formatNumber("%.6f", (*y_true)[i] * s) : "";
      const bool classified = classes && static_cast<std::size_t>(i) < classes->classes.size();
      std::snprintf(buf, sizeof buf, ",%s,%s,%.6f,%.6f,%s,%d,%s\n", info.name.c_str(), info.display_unit.c_str(), e.y[i] * s,
                    std::sqrt(std::max(0.0, e.covariance(i, i))) * s, truth.c_str(), held ? 1 : 0,
                    classified ? paramClassName(classes->classes[static_cast<std::size_t>(i)]) : "");
      out << m.method.name << buf;
    }
  }
  return out.str();
}

namespace {
/// RMS over the length parameters (a and d) of y, mm.
double lengthRmsMm(const sim::Arm& nominal, const Eigen::VectorXd& y) {
  const sim::ParamBlock g = sim::geometryBlock(nominal);
  double sum = 0.0;
  int n = 0;
  for (Eigen::Index i = 0; i < y.size(); ++i) {
    if (g.params[static_cast<std::size_t>(i)].quantity != sim::Quantity::kLength) continue;
    sum += y[i] * y[i];
    ++n;
  }
  return n ? std::sqrt(sum / n) * 1e3 : 0.0;
}
}  // namespace

std::string formatMethodsTable(const sim::Arm& nominal, const Comparison& c, const Eigen::VectorXd& y_true) {
  char buf[640];
  std::snprintf(buf, sizeof buf,
                "| method | settings | iterations | rank | time (ms) | converged | held | RMS a, d estimate (mm; true %.3f) | "
                "avg position (mm) | / floor | suspicious estimates |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
                lengthRmsMm(nominal, y_true));
  std::string out = buf;
  for (const MethodOutcome& m : c.methods) {
    std::string held;
    for (int p : m.estimate.held) held += (held.empty() ? "" : " ") + sim::paramName(nominal, p);
    std::snprintf(buf, sizeof buf, "| %s | %s | %d | %d | %.2f | %s | %s | %.3f | %.4f | %.3f | ", m.method.name.c_str(),
                  m.method.description.c_str(), m.estimate.iterations, m.estimate.rank, m.estimate.seconds * 1e3,
                  m.estimate.converged ? "yes" : "no", held.empty() ? "-" : held.c_str(), lengthRmsMm(nominal, m.estimate.y),
                  m.summary.position_avg_m * 1e3, m.summary.position_avg_m / c.floor.position_avg_m);
    out += buf;
    std::string flagged;
    for (const std::string& f : suspiciousEstimates(nominal, m.estimate, &y_true)) flagged += (flagged.empty() ? "" : "; ") + f;
    out += (flagged.empty() ? std::string("-") : "**" + flagged + "**") + " |\n";
  }
  std::snprintf(buf, sizeof buf, "| floor | true parameters, control noise only | | | | | | %.3f | %.4f | 1.000 | |\n",
                lengthRmsMm(nominal, y_true), c.floor.position_avg_m * 1e3);
  return out + buf;
}

std::string formatComparisonTable4(const Comparison& c) {
  std::vector<std::pair<std::string, ErrorSummary>> cols;
  for (const MethodOutcome& m : c.methods) cols.emplace_back(m.method.name, m.summary);
  cols.emplace_back("floor", c.floor);
  return formatTable4(c.initial, cols);
}

std::string formatComparisonSummary(const Comparison& c) {
  std::string out =
      "| model | avg position (mm) | / floor | extreme position (mm) | avg orientation X / Y / Z (deg) | improvement |\n"
      "|---|---|---|---|---|---|\n";
  const auto row = [&](const std::string& name, const ErrorSummary& e) {
    char buf[320];
    const Eigen::Vector3d o = e.orientation_avg_rad * sim::kRadToDeg;
    std::snprintf(buf, sizeof buf, "| %s | %.4f | %.3f | %.4f | %.4f / %.4f / %.4f | %.1f%% |\n", name.c_str(),
                  e.position_avg_m * 1e3, e.position_avg_m / c.floor.position_avg_m, e.position_max_m * 1e3, o.x(), o.y(), o.z(),
                  100.0 * improvement(c.initial.position_avg_m, e.position_avg_m));
    out += buf;
  };
  row("initial (nominal arm)", c.initial);
  for (const MethodOutcome& m : c.methods) row(m.method.name, m.summary);
  row("floor (true parameters)", c.floor);
  return out;
}

std::string formatComparisonDetail(const Comparison& c) {
  std::string out;
  for (const MethodOutcome& m : c.methods) {
    out += "#### " + m.method.name + "\n\n" + formatTable4(c.initial, {{m.method.name, m.summary}, {"floor", c.floor}}) + "\n";
  }
  return out;
}

namespace {
/// Suspicious (see the header) at parameter i.
bool suspicious(double estimate, double typical, const double* truth) {
  if (truth) return std::abs(estimate - *truth) > 10.0 * std::max(std::abs(*truth), 0.1 * typical);
  return std::abs(estimate) > 10.0 * typical;
}
/// v [info.unit] in info's display unit, signed, 3 decimals.
std::string displayValue(const sim::ParamInfo& info, double v) { return sim::formatNumber("%+.3f", v * info.display_scale); }
}  // namespace

std::vector<std::string> suspiciousEstimates(const sim::Arm& nominal, const Estimate& e, const Eigen::VectorXd* y_true) {
  const sim::ParamBlock g = sim::geometryBlock(nominal);
  std::vector<std::string> out;
  for (int i = 0; i < nominal.numParams(); ++i) {
    const double* truth = y_true ? &(*y_true)[i] : nullptr;
    const sim::ParamInfo& info = g.params[static_cast<std::size_t>(i)];
    if (!suspicious(e.y[i], info.typical, truth)) continue;
    out.push_back(info.name + " = " + displayValue(info, e.y[i]) + " " + info.display_unit +
                  (truth ? " (injected " + displayValue(info, *truth) + ")" : ""));
  }
  return out;
}

std::string formatEstimatesAgainstTruth(const sim::Arm& nominal, const Comparison& c, const Eigen::VectorXd& y_true,
                                        const std::vector<std::string>& methods) {
  const sim::ParamBlock g = sim::geometryBlock(nominal);
  std::string out = "| parameter | injected |";
  std::string rule = "|---|---|";
  std::vector<const MethodOutcome*> shown;
  for (const std::string& name : methods) {
    for (const MethodOutcome& m : c.methods) {
      if (m.method.name == name) shown.push_back(&m);
    }
  }
  for (const MethodOutcome* m : shown) {
    out += " " + m->method.name + " |";
    rule += "---|";
  }
  out += "\n" + rule + "\n";
  for (int i = 0; i < nominal.numParams(); ++i) {
    const sim::ParamInfo& info = g.params[static_cast<std::size_t>(i)];
    out += "| " + info.name + " (" + info.display_unit + ") | " + displayValue(info, y_true[i]) + " |";
    for (const MethodOutcome* m : shown) {
      const Estimate& e = m->estimate;
      const bool held = std::find(e.held.begin(), e.held.end(), i) != e.held.end();
      std::string cell = displayValue(info, e.y[i]) +
                         (held ? " (held)" : " +- " + sim::formatNumber("%.3f", std::sqrt(std::max(0.0, e.covariance(i, i))) * info.display_scale));
      if (suspicious(e.y[i], info.typical, &y_true[i])) cell = "**" + cell + "**";
      out += " " + cell + " |";
    }
    out += "\n";
  }
  return out;
}

}  // namespace orbcal::calib
