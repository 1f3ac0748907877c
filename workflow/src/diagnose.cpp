#include "orbcal/workflow/diagnose.hpp"

#include "diagnose_noise_text.hpp"

#include <algorithm>
#include <chrono>
#include <numeric>
#include <cmath>
#include <optional>
#include <random>
#include <filesystem>
#include <sstream>

#include "orbcal/workflow/calibrate.hpp"
#include "orbcal/workflow/experiment.hpp"
#include "orbcal/workflow/measured.hpp"
#include "orbcal/workflow/report_html.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/model_io.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/gravity.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/sim/simulate.hpp"
#include "orbcal/vision/measurement.hpp"

#include <opencv2/calib3d.hpp>

namespace orbcal::workflow {

namespace {

std::string effectJson(const sim::Effect& e) {
  std::string j = "{\"effect\": " + sim::jsonString(sim::effectName(e)) + ", \"joints\": [";
  const std::vector<int> joints = sim::effectJoints(e);
  for (std::size_t i = 0; i < joints.size(); ++i) j += (i ? ", " : "") + std::to_string(joints[i] + 1);
  return j + "]";
}

/// The model file of the k-th confounded alternative (from 0), written beside model.yaml.
std::string alternativeName(std::size_t k) { return "alternative" + std::to_string(k + 1); }

/// The selected effects' parameters with their 1-sigma, from the final fit.
struct EffectParams {
  sim::Effect effect;
  std::vector<std::tuple<const sim::ParamInfo*, double, double>> params;  ///< info, value, sigma (SI)
};
std::vector<EffectParams> selectedParams(const calib::Diagnosis& d) {
  std::vector<EffectParams> out;
  const sim::KinematicModel& m = d.fit.model;
  for (std::size_t k = 0; k < m.effects.size(); ++k) {
    out.emplace_back();
    EffectParams& ep = out.back();
    ep.effect = m.effects[k];
    for (const int blk : m.effect_blocks[k]) {
      const sim::ParamBlock& b = m.layout.block(blk);
      for (int i = 0; i < b.size(); ++i) {
        const int idx = b.offset + i;
        ep.params.emplace_back(&b.params[static_cast<std::size_t>(i)], d.fit.p[idx],
                               std::sqrt(std::max(0.0, d.fit.estimate.covariance(idx, idx))));
      }
    }
  }
  return out;
}

}  // namespace

std::string diagnosisJson(const calib::Diagnosis& d, const DistortionCheck& distortion) {
  const auto num = [](double v, const std::string& key) { return sim::jsonNumber(v, "diagnosis.json: " + key); };
  std::ostringstream j;
  // clean: nothing selected, nothing left; effects: the selected model explains what there was;
  // unexplained: its held-out residuals still exceed the noise or are structured (with or without
  // effects selected: `selected` says which).
  j << "{\"verdict\": " << sim::jsonString(d.clean ? "clean" : d.unexplained ? "unexplained" : "effects") << ",\n \"sentence\": " << sim::jsonString(d.verdict)
    << ",\n \"selected\": [";
  const std::vector<EffectParams> sel = selectedParams(d);
  for (std::size_t k = 0; k < sel.size(); ++k) {
    j << (k ? ",\n   " : "\n   ") << effectJson(sel[k].effect) << ", \"parameters\": [";
    for (std::size_t i = 0; i < sel[k].params.size(); ++i) {
      const auto& [info, value, sigma] = sel[k].params[i];
      j << (i ? ", " : "") << "{\"name\": " << sim::jsonString(info->name) << ", \"value\": " << num(value, "selected." + info->name)
        << ", \"sigma\": " << num(sigma, "selected." + info->name + ".sigma") << ", \"unit\": " << sim::jsonString(info->unit) << "}";
    }
    j << "]}";
  }
  if (distortion.selected) {
    static const char* kNames[4] = {"dk1", "dk2", "dp1", "dp2"};
    j << (sel.empty() ? "\n   " : ",\n   ") << "{\"effect\": \"distortion\", \"joints\": [], \"parameters\": [";
    for (std::size_t i = 0; i < 4; ++i) {
      j << (i ? ", " : "") << "{\"name\": \"" << kNames[i] << "\", \"value\": " << num(distortion.dk[i], std::string("selected.") + kNames[i])
        << ", \"sigma\": " << num(distortion.dk_sigma[i], std::string("selected.") + kNames[i] + ".sigma") << ", \"unit\": \"1\"}";
    }
    j << "]}";
  }
  j << "],\n \"selection_observations\": " << d.selection_observations << ",\n \"confounded\": [";
  for (std::size_t c = 0; c < d.confounded.size(); ++c) {
    j << (c ? ", " : "") << "[";
    for (std::size_t i = 0; i < d.confounded[c].effects.size(); ++i) j << (i ? ", " : "") << effectJson(d.confounded[c].effects[i]) << "}";
    if (d.confounded[c].with_geometry) j << (d.confounded[c].effects.empty() ? "" : ", ") << "{\"effect\": \"geometry\", \"joints\": []}";
    j << "]";
  }
  // The alternatives the data cannot tell from the selection, as written beside model.yaml.
  j << "],\n \"alternatives\": [";
  for (std::size_t k = 0; k < d.alternatives.size(); ++k) {
    const calib::Alternative& a = d.alternatives[k];
    j << (k ? ", " : "") << "{\"model\": " << sim::jsonString(alternativeName(k) + ".yaml") << ", \"effects\": [";
    for (std::size_t i = 0; i < a.effects.size(); ++i) j << (i ? ", " : "") << effectJson(a.effects[i]) << "}";
    j << "], \"fit_position_rms_mm\": " << num(a.fit.residuals.position_rms_m * 1e3, "alternatives.fit_position_rms_mm") << "}";
  }
  const calib::MarkerNoise& n = d.base_fit.noise;  // SI: m, rad
  j << "],\n \"noise\": {\"position_m\": " << num(n.sigma_position_m, "noise.position_m") << ", \"rotation_rad\": "
    << num(n.sigma_rotation_rad, "noise.rotation_rad") << ", \"joint_rad\": " << num(n.joint_noise_sigma_rad, "noise.joint_rad")
    << ", \"with_selected\": ";
  // The tracker noise a calibration of the selected effects estimates (NoiseFloors::with_selected).
  if (const std::optional<calib::MarkerNoise>& w = d.noise.with_selected) {
    j << "{\"position_m\": " << num(w->sigma_position_m, "noise.with_selected.position_m") << ", \"rotation_rad\": "
      << num(w->sigma_rotation_rad, "noise.with_selected.rotation_rad") << ", \"joint_rad\": "
      << num(w->joint_noise_sigma_rad, "noise.with_selected.joint_rad") << ", \"observations\": " << d.noise.with_selected_observations << "}}";
  } else {
    j << "null}";
  }
  // The floor the verdict is judged against, and the estimated joint noise beside it (NoiseFloors).
  const calib::NoiseFloors& nf = d.noise;
  const auto fl = [&num](double v, const char* key) { return num(v, std::string("noise_floor.") + key); };
  j << ",\n \"noise_floor\": {\"joint_source\": " << sim::jsonString(nf.joint_source) << ", \"joint_floor_rad\": "
    << fl(nf.joint_floor_rad, "joint_floor_rad") << ", \"joint_estimate_rad\": " << fl(nf.joint_estimate_rad, "joint_estimate_rad")
    << ", \"joint_estimate_sd_rad\": " << fl(nf.survived.estimated[2] ? nf.survived.sigmaSd(2) : 0.0, "joint_estimate_sd_rad")
    << ", \"floor_independent_mm\": " << fl(nf.floor_independent_rms_m * 1e3, "floor_independent_mm")
    << ", \"floor_with_estimate_mm\": " << fl(nf.floor_with_estimate_rms_m * 1e3, "floor_with_estimate_mm")
    << ", \"joint_needed_rad\": " << fl(nf.joint_needed_rad, "joint_needed_rad")
    << ", \"depends_on_noise\": " << (nf.verdict_depends_on_noise ? "true" : "false")
    << ", \"duplicates_dropped\": " << nf.duplicates_dropped << ", \"noise_observations\": " << nf.noise_observations << "}";
  const calib::LackOfFit& l = d.lack_of_fit;
  j << ",\n \"unexplained\": [";
  for (std::size_t i = 0; i < l.unexplained.size(); ++i) {
    j << (i ? ", " : "") << "{\"variable\": " << sim::jsonString(l.unexplained[i].variable) << ", \"statistic\": "
      << num(l.unexplained[i].statistic, "unexplained.statistic") << ", \"dof\": " << l.unexplained[i].dof << ", \"p\": "
      << num(l.unexplained[i].p_adjusted, "unexplained.p") << "}";
  }
  const auto lof = [&num](double v, const char* key) { return num(v, std::string("lack_of_fit.") + key); };
  j << "],\n \"lack_of_fit\": {\"noise_source\": " << sim::jsonString(calib::noiseSourceName(l.source))
    << ", \"tested\": " << (l.tested ? "true" : "false") << ", \"statistic\": " << lof(l.statistic, "statistic")
    << ", \"dof1\": " << lof(l.dof1, "dof1") << ", \"dof2\": " << lof(l.dof2, "dof2") << ", \"p\": " << lof(l.p_value, "p")
    << ", \"level\": " << lof(l.level, "level") << ", \"excess_rms_mm\": " << lof(l.excess_rms_m * 1e3, "excess_rms_mm")
    << ", \"excess_share\": " << lof(l.excess_share, "excess_share") << ", \"estimation_factor\": " << lof(l.estimation_factor, "estimation_factor")
    << ", \"replicated_configurations\": " << l.pure.replicated << ", \"share_of_excess\": [";
  for (std::size_t i = 0; i < d.share_of_excess.size(); ++i) j << (i ? ", " : "") << lof(d.share_of_excess[i], "share_of_excess");
  j << "]}";
  j << ",\n \"heldout\": {\"base\": " << residualJson(d.heldout.base, "diagnosis.json: heldout.base") << ", \"selected\": "
    << residualJson(d.heldout.selected, "diagnosis.json: heldout.selected")
    << ", \"noise_position_rms_mm\": " << num(d.heldout.noise_position_rms_m * 1e3, "heldout.noise_position_rms_mm") << "},\n"
    << " \"seconds\": " << sim::formatNumber("%.3f", d.seconds) << "}\n";
  return j.str();
}

namespace {

/// OpenCV's camera matrix and distortion of a scene camera plus a delta (dk1, dk2, dp1, dp2).
std::pair<cv::Mat, cv::Mat> cvCamera(const sim::Camera& c, const std::array<double, 4>& delta) {
  cv::Mat K = (cv::Mat_<double>(3, 3) << c.fx_px, 0, c.cx_px, 0, c.fy_px, c.cy_px, 0, 0, 1);
  cv::Mat D = (cv::Mat_<double>(1, 5) << c.distortion[0] + delta[0], c.distortion[1] + delta[1], c.distortion[2] + delta[2],
               c.distortion[3] + delta[3], c.distortion[4]);
  return {K, D};
}

/// Corner residuals (px) of each image in `which` at its own best pose (IPPE, then LM) under a camera.
Eigen::VectorXd perImageResiduals(const std::vector<std::vector<cv::Point3f>>& object,
                                  const std::vector<std::vector<cv::Point2f>>& image, const std::vector<std::size_t>& which,
                                  const cv::Mat& K, const cv::Mat& D) {
  std::vector<double> r;
  for (std::size_t i : which) {
    cv::Mat rvec, tvec;
    cv::solvePnP(object[i], image[i], K, D, rvec, tvec, false, cv::SOLVEPNP_IPPE);
    cv::solvePnPRefineLM(object[i], image[i], K, D, rvec, tvec);
    std::vector<cv::Point2f> projected;
    cv::projectPoints(object[i], rvec, tvec, K, D, projected);
    for (std::size_t c = 0; c < projected.size(); ++c) {
      r.push_back(image[i][c].x - projected[c].x);
      r.push_back(image[i][c].y - projected[c].y);
    }
  }
  return Eigen::Map<Eigen::VectorXd>(r.data(), static_cast<Eigen::Index>(r.size()));
}

/// dk (k1, k2, p1, p2 beyond the scene's) from images `which`, each with its own pose: Gauss-Newton on
/// the 4 coefficients with every pose re-optimized at each evaluation (variable projection; the
/// Jacobian by central differences of the re-optimized residuals), focal lengths, principal point and
/// k3 held at the scene's. sigma: 1-sigma from (J^T J)^-1 and the residual variance.
std::array<double, 4> fitDistortion(const std::vector<std::vector<cv::Point3f>>& object,
                                    const std::vector<std::vector<cv::Point2f>>& image, const std::vector<std::size_t>& which,
                                    const sim::Camera& camera, std::array<double, 4>* sigma = nullptr) {
  std::array<double, 4> dk{0, 0, 0, 0};
  const auto residuals = [&](const std::array<double, 4>& at) {
    const auto [K, D] = cvCamera(camera, at);
    return perImageResiduals(object, image, which, K, D);
  };
  constexpr double kStep[4] = {1e-4, 1e-4, 1e-5, 1e-5};  // well inside the coefficients' typical sizes
  Eigen::MatrixXd J;
  Eigen::VectorXd r = residuals(dk);
  for (int it = 0; it < 8; ++it) {
    J.resize(r.size(), 4);
    for (int j = 0; j < 4; ++j) {
      std::array<double, 4> plus = dk, minus = dk;
      plus[static_cast<std::size_t>(j)] += kStep[j];
      minus[static_cast<std::size_t>(j)] -= kStep[j];
      J.col(j) = (residuals(plus) - residuals(minus)) / (2.0 * kStep[j]);
    }
    // r = observed - projected: r(dk + d) ≈ r + J d; minimize |r + J d|.
    const Eigen::Vector4d step = -(J.transpose() * J).ldlt().solve(J.transpose() * r);
    for (int j = 0; j < 4; ++j) dk[static_cast<std::size_t>(j)] += step[j];
    r = residuals(dk);
    if ((step.array().abs() < Eigen::Array4d(1e-7, 1e-7, 1e-8, 1e-8)).all()) break;
  }
  if (sigma) {
    const double dof = std::max(1.0, static_cast<double>(r.size()) - 6.0 * static_cast<double>(which.size()) - 4.0);
    const Eigen::Matrix4d cov = (J.transpose() * J).inverse() * (r.squaredNorm() / dof);
    for (int j = 0; j < 4; ++j) (*sigma)[static_cast<std::size_t>(j)] = std::sqrt(std::max(0.0, cov(j, j)));
  }
  return dk;
}

DistortionCheck checkDistortion(const sim::Dataset& d, const std::vector<vision::Measurement>& meas,
                                const std::vector<std::size_t>& usable, const calib::DiagnoseOptions& o) {
  DistortionCheck c;
  const int n = static_cast<int>(usable.size());
  const int k = std::max(2, o.folds);
  if (n < 2 * k) return c;
  c.tested = true;
  // Distortion is a pattern within each image: every image gets its own pose here, so the arm's
  // errors and the joint noise (a rigid shift of each image's corners) cannot pose as distortion.
  std::vector<std::vector<cv::Point3f>> object(static_cast<std::size_t>(n));
  std::vector<std::vector<cv::Point2f>> image(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const vision::Measurement& m = meas[usable[static_cast<std::size_t>(i)]];
    const std::vector<Eigen::Vector2d>& px = m.corners_px;
    for (std::size_t c2 = 0; c2 < px.size(); ++c2) {
      const Eigen::Vector3d b = sim::cornerInBoard(d.scene.board, m.cornerId(c2));
      object[static_cast<std::size_t>(i)].emplace_back(static_cast<float>(b.x()), static_cast<float>(b.y()), static_cast<float>(b.z()));
      image[static_cast<std::size_t>(i)].emplace_back(static_cast<float>(px[c2].x()), static_cast<float>(px[c2].y()));
    }
  }
  std::vector<std::size_t> all(static_cast<std::size_t>(n));
  std::iota(all.begin(), all.end(), 0);
  std::size_t coords = 0;
  for (const auto& im : image) coords += 2 * im.size();
  const auto [K0, D0] = cvCamera(d.scene.camera, {0, 0, 0, 0});
  const double sse0 = perImageResiduals(object, image, all, K0, D0).squaredNorm();
  c.dk = fitDistortion(object, image, all, d.scene.camera, &c.dk_sigma);
  const auto [K1, D1] = cvCamera(d.scene.camera, c.dk);
  const double sse1 = perImageResiduals(object, image, all, K1, D1).squaredNorm();
  const double dof = static_cast<double>(coords) - 6.0 * n - 4.0;
  const double s2 = sse1 / std::max(1.0, dof);  // the detector's noise, with the distortion modelled
  c.sigma_px = std::sqrt(s2);
  c.lr = (sse0 - sse1) / s2;
  c.p_value = calib::fSurvival(c.lr / 4.0, 4.0, dof);
  // Folds by image, seeded: dk from the training images, each held-out image's own pose under it.
  std::vector<std::size_t> order = all;
  std::mt19937_64 rng = sim::makeRng(o.seed, 0x6469737466ULL);
  std::shuffle(order.begin(), order.end(), rng);
  double held0 = 0.0, held1 = 0.0;
  for (int f = 0; f < k; ++f) {
    std::vector<std::size_t> train, test;
    for (int i = 0; i < n; ++i) (i % k == f ? test : train).push_back(order[static_cast<std::size_t>(i)]);
    const auto [Kf, Df] = cvCamera(d.scene.camera, fitDistortion(object, image, train, d.scene.camera));
    held0 += perImageResiduals(object, image, test, K0, D0).squaredNorm();
    held1 += perImageResiduals(object, image, test, Kf, Df).squaredNorm();
  }
  c.cv_gain = (held0 - held1) / s2;
  c.heldout_rms_without_px = std::sqrt(held0 / static_cast<double>(coords));
  c.heldout_rms_with_px = std::sqrt(held1 / static_cast<double>(coords));
  c.selected = c.p_value < o.alpha && c.cv_gain > 4.0 * o.penalty_per_param;
  return c;
}

/// "What is left unexplained": the selected model's held-out residuals against the noise (the global
/// test) and against the extended variable family.
std::string unexplainedSection(const calib::Diagnosis& d, double alpha) {
  const calib::LackOfFit& l = d.lack_of_fit;
  const auto mm = [](double m) { return sim::formatNumber("%.4f", m * 1e3); };
  std::ostringstream md;
  md << "## What is left unexplained\n\n"
     << (d.selected.empty() ? "Geometry + registration" : "The selected model") << ", held out: position RMS " << mm(l.position_rms_m)
     << " mm; the noise alone gives " << mm(l.noise_position_rms_m) << " mm (";
  if (l.source == calib::NoiseSource::kStated) {
    md << "the stated noise, through the joint Jacobian where joint noise is given or estimated";
  } else if (l.source == calib::NoiseSource::kPureError) {
    md << "pure error of " << l.pure.replicated << " repeated configurations, " << l.pure.dof << " degrees of freedom";
  } else {
    md << "estimated from these residuals: no stated noise and no repeated configurations to test against";
  }
  md << "); above it: " << mm(l.excess_rms_m) << " mm RMS, " << sim::formatNumber("%.0f", 100.0 * l.excess_share)
     << " % of the held-out mean square. Part of a held-out error is the model's own uncertainty (each fold's parameters "
     << "were fitted to the other folds' noisy data): it raises the mean square expected from the noise by about "
     << sim::formatNumber("%.1f", 100.0 * (l.estimation_factor - 1.0)) << " %, and the test allows for it.\n\n";
  if (l.tested) {
    md << "Lack-of-fit test (" << (l.source == calib::NoiseSource::kStated ? "chi-square of the whitened held-out position rows, " : "F against pure error, ")
       << sim::formatNumber("%.0f", l.dof1) << (l.dof2 > 0 ? ", " + sim::formatNumber("%.0f", l.dof2) : std::string()) << " dof): statistic "
       << sim::formatNumber("%.4g", l.statistic) << ", p " << sim::formatNumber("%.2g", l.p_value) << " (level " << sim::formatNumber("%.3g", l.level)
       << ": alpha " << sim::formatNumber("%.3g", alpha) << " split between this test and the variable family). "
       << (l.significant ? "**The residuals exceed the noise.**" : "Not above the noise.") << "\n\n";
  }
  md << "Held-out residuals of " << (d.selected.empty() ? "geometry + registration" : "the selected model")
     << " against each variable of the extended family (harmonics 3-6, joint-angle products, torque powers, quadratic workspace terms), "
     << "Holm-adjusted; * below the level " << sim::formatNumber("%.3g", l.level) << ".\n\n| variable | regressors | F | p (Holm) |\n|---|---|---|---|\n";
  std::vector<calib::VariableTest> rows = l.evidence;
  std::stable_sort(rows.begin(), rows.end(), [](const calib::VariableTest& a, const calib::VariableTest& b) { return a.p_value < b.p_value; });
  int omitted = 0;
  for (const calib::VariableTest& t : rows) {
    if (t.p_adjusted > 0.5) {
      ++omitted;
      continue;
    }
    md << "| " << t.variable << " | " << t.dof << " | " << sim::formatNumber("%.2f", t.statistic) << " | "
       << sim::formatNumber("%.2g", t.p_adjusted) << (t.p_adjusted < l.level ? " *" : "") << " |\n";
  }
  md << "\n(" << omitted << " variables with Holm-adjusted p above 0.5 not listed)\n";
  return md.str();
}

/// Where the selection ran on a subset (DiagnoseOptions::selection_observations): which one, of how many.
std::string selectionSubsetWords(const calib::Diagnosis& dg) {
  if (dg.selection_observations == 0) return "";
  return " The tests and gains are those of a seeded random " + std::to_string(dg.selection_observations) + " of the " +
         std::to_string(dg.residual_base.size() - static_cast<std::size_t>(dg.noise.duplicates_dropped)) +
         " observations (`--selection-observations`); the selected model was fitted, cross-validated and judged on all of them.";
}

/// The candidates' score tests and the variables' F tests, each table with what it tests: the verdict
/// follows the candidates; the evidence table is the base model's residuals against one variable at a time.
std::string testsSection(const calib::Diagnosis& dg, const calib::DiagnoseOptions& o) {
  std::ostringstream md;
  md << "\n## Candidates: what selected the effects\n\nRao's score test (Rao 1948) of each candidate's own columns (the "
        "derivatives of the predicted pose by its parameters, at every sample) beyond the current model (rank: what the model "
        "cannot absorb); the significant ones fitted and cross-validated. The verdict names the candidates this selects."
     << selectionSubsetWords(dg) << "\n\n| step | candidate | params | rank | score | p (Holm) | CV gain |\n|---|---|---|---|---|---|---|\n";
  for (const calib::CandidateResult& c : dg.candidates) {
    if (!c.significant && c.p_adjusted > 0.5) continue;  // the long tail of nothing
    md << "| " << c.step << " | " << sim::formatEffect(c.effect) << " | " << c.params << " | " << c.rank << " | "
       << sim::formatNumber("%.1f", c.score) << " | " << sim::formatNumber("%.2g", c.p_adjusted) << (c.significant ? " *" : "") << " | "
       << (c.cv_gain ? sim::formatNumber("%.1f", *c.cv_gain) : std::string("")) << " |\n";
  }
  md << "\n(candidates with Holm-adjusted p above 0.5 not listed; * significant)\n\n"
     << "## Evidence: held-out residuals of geometry + registration against each variable\n\n"
     << "An F test per variable: the residual components regressed on that variable alone (its regressors: harmonics of a "
        "joint angle, a torque, ...) with fixed coefficients, i.e. an error along a fixed direction. It does not select "
        "anything. An effect of a joint moves the marker along that joint's axis as seen from the marker, a direction that "
        "turns with every other joint: its candidate's score test follows that direction, a variable's F test cannot, so a "
        "candidate can be significant while every variable here reads p = 1.\n\n"
     << "| variable | regressors | F | p (Holm) |\n|---|---|---|---|\n";
  for (const calib::VariableTest& t : dg.evidence) {
    md << "| " << t.variable << " | " << t.dof << " | " << sim::formatNumber("%.2f", t.statistic) << " | "
       << sim::formatNumber("%.2g", t.p_adjusted) << (t.p_adjusted < o.alpha ? " *" : "") << " |\n";
  }
  return md.str();
}

}  // namespace

namespace {

/// residuals.csv (per-sample held-out errors with the variables) and the figures drawn from it; returns
/// the figures' Markdown.
std::string writeResiduals(const calib::Diagnosis& dg, const sim::MeasuredData& data,
                           const std::vector<calib::MarkerObservation>& obs, const std::string& out, const DiagnoseRunOptions& o) {
  // Per-sample held-out errors with the variables, for the figures.
  std::ostringstream csv;
  const int n = data.arm.numJoints();
  csv << "index,session,base_mm,selected_mm";
  for (int j = 0; j < n; ++j) csv << "," << sim::jointEdgeColumn(data.arm, j);
  for (int j = 0; j < n; ++j) csv << "," << sim::jointEffortColumn(data.arm, j);
  for (int j = 1; j <= n; ++j) csv << ",dir" << j;
  csv << ",temperature_C,time_s,selected_x_mm,selected_y_mm,selected_z_mm,unexplained_axis,base_x_mm,base_y_mm,base_z_mm\n";
  for (std::size_t i = 0; i < obs.size(); ++i) {
    const sim::JointSample& s = obs[i].sample;
    csv << i << "," << s.session << "," << dg.residual_base[i].head<3>().norm() * 1e3 << ","
        << dg.residual_selected[i].head<3>().norm() * 1e3;
    for (int j = 0; j < n; ++j) csv << "," << s.q_rad[j] * sim::jointEdgeScale(data.arm, j);
    for (int j = 0; j < n; ++j) csv << "," << (s.hasTorque() ? s.tau_Nm[j] : 0.0);
    for (int j = 0; j < n; ++j) csv << "," << (s.direction.size() == n ? s.direction[j] : 0.0);
    csv << "," << (s.hasTemperature() ? s.temperature_C : 0.0) << "," << (s.hasTime() ? s.time_s : 0.0);
    // The selected model's held-out position residual components (mm; the residual's frame: the
    // marker's for full poses, the measuring system's for positions), and the most significant
    // unexplained variable's axis (0 when nothing is left).
    for (int c = 0; c < 3; ++c) csv << "," << dg.residual_selected[i][c] * 1e3;
    const Eigen::VectorXd& axis = dg.lack_of_fit.axis_values;
    csv << "," << (axis.size() == static_cast<Eigen::Index>(obs.size()) ? axis[static_cast<Eigen::Index>(i)] : 0.0);
    for (int c = 0; c < 3; ++c) csv << "," << dg.residual_base[i][c] * 1e3;  // geometry + registration's, likewise
    csv << "\n";
  }
  sim::writeFileAtomic(out + "/residuals.csv", csv.str());
  // The noise floor: the held-out position RMS the noise alone gives (magnitudes), and its share per
  // axis, RMS / sqrt(3) (signed components).
  const calib::LackOfFit& lof = dg.lack_of_fit;
  const std::string rms_floor = " --floor " + sim::formatNumber("%.6g", lof.noise_position_rms_m * 1e3);
  const std::string axis_floor = " --floor " + sim::formatNumber("%.6g", lof.noise_position_rms_m * 1e3 / std::sqrt(3.0));
  const std::string table = shellQuote(out + "/residuals.csv") + " ";
  std::vector<FigureRequest> figures{{out, "samples.png", "residuals " + table + "index sample" + rms_floor,
                                      "held-out position error per sample, before and after, with the noise floor"}};
  for (const sim::Effect& e : dg.selected) {
    const auto [column, label] = e.kind().revealingVariable(e, data.arm);
    const std::string name = sim::effectName(e) + std::to_string(sim::effectJoints(e).empty() ? 0 : sim::effectJoints(e)[0] + 1);
    const std::string variable = shellQuote(column) + " " + shellQuote(label);
    figures.push_back({out, "residuals_" + name + ".png", "residuals " + table + variable + rms_floor, "held-out position error against " + label});
    figures.push_back({out, "components_" + name + ".png", "components " + table + variable + " --of base" + axis_floor,
                       "held-out residual components (signed) of geometry + registration against " + label + ": what " +
                           sim::formatEffect(e) + " explains"});
  }
  if (!lof.unexplained.empty()) {
    figures.push_back({out, "unexplained.png", "components " + table + "unexplained_axis " + shellQuote(lof.axis_label) + axis_floor,
                       "held-out residual components of the selected model against " + lof.unexplained.front().variable});
  }
  return drawFigures(o.callbacks, o.plots, figures);
}

/// The report's section on the camera's lens distortion (image datasets).
std::string distortionSection(const DistortionCheck& c, const calib::DiagnoseOptions& o) {
  std::ostringstream md;
  md << "\n## The camera: lens distortion the scene does not model\n\n"
     << "Each image's own pose (solvePnP) under the scene's camera, and under the scene's camera plus dk1, dk2, dp1, dp2 "
     << "fitted with every image's pose free (focal lengths, principal point and k3 held; "
     << o.folds << " folds by image): held-out corner RMS " << sim::formatNumber("%.4f", c.heldout_rms_without_px) << " -> "
     << sim::formatNumber("%.4f", c.heldout_rms_with_px) << " px, held-out gain " << sim::formatNumber("%.1f", c.cv_gain)
     << " (must exceed " << sim::formatNumber("%.0f", 4 * o.penalty_per_param) << "), likelihood ratio "
     << sim::formatNumber("%.1f", c.lr) << " (F test p " << sim::formatNumber("%.2g", c.p_value) << "). "
     << (c.selected ? "**Named.**" : "Not named.") << " Fitted on all images: dk1 " << sim::formatNumber("%+.4g", c.dk[0]) << " +- "
     << sim::formatNumber("%.2g", c.dk_sigma[0]) << ", dk2 " << sim::formatNumber("%+.4g", c.dk[1]) << " +- "
     << sim::formatNumber("%.2g", c.dk_sigma[1]) << ", dp1 " << sim::formatNumber("%+.3g", c.dk[2]) << ", dp2 "
     << sim::formatNumber("%+.3g", c.dk[3]) << ".\n";
  return md.str();
}

/// calib::diagnose with its phases as a progress line (none with --quiet).
calib::Diagnosis diagnoseShowingPhases(const sim::MeasuredData& data, const std::vector<calib::MarkerObservation>& obs,
                                       calib::DiagnoseOptions options, const DiagnoseRunOptions& o) {
  Progress bar(o.callbacks.progress, o.quiet ? "" : "diagnose", o.quiet ? 0 : static_cast<int>(calib::kDiagnosePhases.size()));
  options.progress = [&bar](int done, int) { bar.update(done); };
  return calib::diagnose(data, obs, options);
}

}  // namespace

DiagnoseRunResult runDiagnose(const DiagnoseRunOptions& o) {
  DiagnoseRunResult r;
  sim::MeasuredData data;
  std::vector<calib::MarkerObservation> obs;
  const bool measured = std::filesystem::is_regular_file(o.input);
  std::optional<sim::Dataset> dataset;
  std::vector<vision::Measurement> meas;
  std::vector<std::size_t> usable;
  calib::DiagnoseOptions options = o.diagnose;
  if (measured) {
    data = sim::loadMeasuredData(o.input);
    obs = calib::observationsFrom(data, data.has_torque || !data.arm.masses.empty());
  } else {
    dataset = sim::loadDataset(o.input);
    sim::requireJointReadings(*dataset, "diagnose");
    {
      Progress bar(o.callbacks.progress, o.quiet ? "" : "measure images", o.quiet ? 0 : static_cast<int>(dataset->samples.size()));
      meas = vision::measureDataset(*dataset, {}, [&](int done, int) { bar.update(done); });
    }
    for (std::size_t k = 0; k < meas.size(); ++k) {
      if (meas[k].found()) usable.push_back(k);
    }
    ImageMeasuredData im = imageMeasuredData(*dataset, meas, usable);
    data = std::move(im.data);
    obs = std::move(im.observations);
    // As orbcal calibrate: the manifest's joint noise, else Wang et al. 2023's 0.01 deg.
    if (!options.joint_noise_sigma_rad) {
      options.joint_noise_sigma_rad =
          dataset->manifest.joint_noise_sigma_rad > 0.0 ? dataset->manifest.joint_noise_sigma_rad : 0.01 * sim::kDegToRad;
    }
  }
  // The inputs are read: the output folder now holds this run's outcome only (sim::OutputFolder).
  const std::string input_folder = measured ? std::filesystem::path(o.input).parent_path().string() : o.input;
  sim::OutputFolder folder(o.out.empty() ? (input_folder.empty() ? "." : input_folder) + "/diagnosis" : o.out, "orbcal diagnose");
  const std::string& out = folder.path();
  r.diagnosis = diagnoseShowingPhases(data, obs, options, o);
  if (dataset) {
    r.distortion = checkDistortion(*dataset, meas, usable, options);
    if (r.distortion.selected) {
      calib::Diagnosis& dg = r.diagnosis;
      const std::string lens = "lens distortion the scene's camera does not model (held-out corner RMS " +
                               sim::formatNumber("%.3f", r.distortion.heldout_rms_without_px) + " -> " +
                               sim::formatNumber("%.3f", r.distortion.heldout_rms_with_px) + " px; calibrate with --estimate-frames --effects distortion)";
      dg.verdict = dg.clean ? "The model misses " + lens + "." : dg.verdict + " It also misses " + lens + ".";
      dg.clean = false;
    }
  }
  const calib::Diagnosis& dg = r.diagnosis;

  sim::writeFileAtomic(out + "/diagnosis.json", diagnosisJson(dg, r.distortion));
  // The alternatives the data cannot tell from the selection beside it (alternativeN.yaml, listed in
  // model.yaml): `orbcal evaluate` says how far their predictions part on new data.
  std::vector<std::string> alternatives;
  for (std::size_t k = 0; k < dg.alternatives.size(); ++k) {
    const std::string name = alternativeName(k);
    const calib::CalibratedModel am = calib::calibratedModel(dg.alternatives[k].fit, obs);
    sim::writeModelFile(am.model, am.p, parameterRows(dg.alternatives[k].fit), out,
                        "An alternative to model.yaml the data of " + o.input + " could not tell from it (orbcal diagnose " ORBCAL_VERSION ")",
                        name + ".yaml", name + ".robot.yaml");
    alternatives.push_back(name + ".yaml");
  }
  const calib::CalibratedModel cm = calib::calibratedModel(dg.fit, obs);
  sim::writeModelFile(cm.model, cm.p, parameterRows(dg.fit), out,
                                     "Selected by orbcal " ORBCAL_VERSION " (orbcal diagnose) from " + o.input, "model.yaml", "robot.yaml",
                      alternatives);

  const std::string figures = writeResiduals(dg, data, obs, out, o);

  const bool rotation = measuresRotation(data);
  std::ostringstream md;
  md << "# Diagnosis of " << data.arm.name << "\n\n**" << dg.verdict << "**\n\n";
  for (const calib::ConfoundedSet& c : dg.confounded) {
    md << "**Confounded in this data:** ";
    for (std::size_t i = 0; i < c.effects.size(); ++i) md << (i ? ", " : "") << calib::describeEffect(c.effects[i]);
    if (c.with_geometry) md << (c.effects.empty() ? "" : " and ") << "the geometric/registration parameters";
    md << " explain the same residuals here. To separate them, " << c.separate_by << ".\n\n";
  }
  md << "Input `" << o.input << "`: " << obs.size() << " samples in " << data.numSessions() << " session(s); "
     << o.diagnose.folds << "-fold cross-validation by configuration (seed " << o.diagnose.seed << "); candidate tests at "
     << "family-wise error " << o.diagnose.alpha << " (Holm); a parameter must cut the held-out whitened squared error by "
     << o.diagnose.penalty_per_param << " to be added. " << sim::formatNumber("%.2f", dg.seconds) << " s.\n\n"
     << noiseSentence(dg, options, data, obs) << "\n\n"
     << "## Held-out errors (cross-validated)\n\n"
     << "| model | position mean (mm) | position RMS (mm) | position max (mm) |" << (rotation ? " rotation RMS (deg) |" : "")
     << " whitened SSE |\n|---|---|---|---|---|" << (rotation ? "---|" : "") << "\n";
  const auto row = [&](const std::string& name, const calib::ResidualStats& s, double sse) {
    md << "| " << name << " | " << sim::formatNumber("%.4f", s.position_mean_m * 1e3) << " | " << sim::formatNumber("%.4f", s.position_rms_m * 1e3)
       << " | " << sim::formatNumber("%.4f", s.position_max_m * 1e3) << " |"
       << (rotation ? " " + sim::formatNumber("%.4f", s.rotation_rms_rad * sim::kRadToDeg) + " |" : std::string()) << " "
       << sim::formatNumber("%.1f", sse) << " |\n";
  };
  row("geometry + registration", dg.heldout.base, dg.cv_base);
  row(dg.clean ? "(nothing added)" : "selected model", dg.heldout.selected, dg.cv_selected);
  if (!dg.clean) {
    md << "\n## Selected effects (parameters and 1-sigma)\n\n| effect | parameter | value | 1-sigma | unit |\n|---|---|---|---|---|\n";
    for (const EffectParams& ep : selectedParams(dg)) {
      for (const auto& [info, value, sigma] : ep.params) {
        md << "| " << sim::formatEffect(ep.effect) << " | " << info->name << " | " << sim::formatNumber("%+.4g", value * info->display_scale)
           << " | " << sim::formatNumber("%.2g", sigma * info->display_scale) << " | " << info->display_unit << " |\n";
      }
    }
    md << "\n" << sim::signConventions(dg.selected);
  }
  md << "\n" << unexplainedSection(dg, o.diagnose.alpha);
  if (measured) md << "\n## Registration frames (the selected model, fitted to all the data)\n\n" << registrationFramesTable(dg.fit, "the description's");
  if (r.distortion.tested) md << distortionSection(r.distortion, o.diagnose);
  md << testsSection(dg, o.diagnose);
  md << "\n## Figures\n\n" << figures << "\nFiles: `diagnosis.json`, `model.yaml` (the selected model, for `orbcal evaluate`, with "
     << "the range of each effect's driving variables it was fitted on)"
     << (alternatives.empty() ? std::string() : ", `alternative1.yaml`.. (the confounded alternatives, each the selection with one effect "
                                                "replaced; `orbcal evaluate` says how far their predictions part on new data)")
     << ", `residuals.csv`.\n";
  writeReport(out, md.str());
  folder.commit();
  r.json_path = folder.finalPath() + "/diagnosis.json";
  r.model_path = folder.finalPath() + "/model.yaml";
  r.report_path = folder.finalPath() + "/report.md";
  return r;
}

}  // namespace orbcal::workflow
