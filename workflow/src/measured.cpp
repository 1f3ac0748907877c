#include "orbcal/workflow/measured.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <filesystem>
#include <sstream>

#include "orbcal/workflow/report_html.hpp"
#include "orbcal/workflow/measured_images.hpp"
#include "orbcal/sim/image_views.hpp"
#include "orbcal/calib/consistency.hpp"
#include "orbcal/calib/diagnose.hpp"
#include "orbcal/calib/heldout.hpp"
#include "orbcal/calib/plausibility.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/export.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/joint_limits.hpp"
#include "orbcal/sim/model_io.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/sim/urdf_export.hpp"
#include "measured_figures.hpp"
#include "measured_verdict.hpp"

namespace orbcal::workflow {

using sim::formatNumber;
using measured_detail::modelHeader;
using measured_detail::readingWarnings;
using measured_detail::combinationPartners;
using measured_detail::structureLeft;
using measured_detail::verdictLines;

std::vector<std::string> measured_detail::readingWarnings(const sim::MeasuredData& data) {
  std::vector<Eigen::VectorXd> q;
  for (const sim::MeasuredPose& p : data.poses) q.push_back(p.sample.q_rad);
  return sim::nearLimitWarnings(data.arm, q);
}

std::vector<std::string> measured_detail::combinationPartners(const std::vector<sim::Redundancy>& groups, int n) {
  std::vector<std::string> partners(static_cast<std::size_t>(n));
  for (const sim::Redundancy& g : groups) {
    for (std::size_t a = 0; a < g.params.size(); ++a) {
      std::string& text = partners[static_cast<std::size_t>(g.params[a])];
      for (std::size_t b = 0; b < g.names.size(); ++b) {
        if (b != a) text += (text.empty() ? "" : ", ") + g.names[b];
      }
    }
  }
  return partners;
}

std::string parseFitMethod(const std::string& name, const std::string& what) {
  calib::findMethod(calib::comparisonMethods(0.0), name, what);
  return name;
}

std::vector<sim::ParameterRow> parameterRows(const calib::Fit& fit) {
  std::vector<sim::ParameterRow> rows;
  const sim::ParamLayout& L = fit.model.layout;
  for (int i = 0; i < L.size(); ++i) {
    const bool held = std::binary_search(fit.estimate.held.begin(), fit.estimate.held.end(), i);
    const double var = fit.estimate.covariance.rows() > i ? fit.estimate.covariance(i, i) : NAN;
    rows.push_back({L.param(i).name, L.block(L.blockOf(i)).effect, L.param(i).unit, fit.p[i],
                    held ? 0.0 : std::sqrt(std::max(0.0, var)), held});
  }
  return rows;
}

std::string residualJson(const calib::ResidualStats& s, const std::string& key) {
  const auto number = [&key](const char* name, double v) { return "\"" + std::string(name) + "\": " + sim::jsonNumber(v, key + "." + name); };
  std::string json = "{\"samples\": " + std::to_string(s.samples) + ", " + number("position_mean_mm", s.position_mean_m * 1e3) +
                     ", " + number("position_rms_mm", s.position_rms_m * 1e3) + ", " + number("position_max_mm", s.position_max_m * 1e3);
  if (s.rotation_samples > 0) {
    json += ", " + number("rotation_rms_deg", s.rotation_rms_rad * sim::kRadToDeg) + ", " +
            number("rotation_max_deg", s.rotation_max_rad * sim::kRadToDeg);
  }
  return json + "}";
}

bool measuresRotation(const sim::MeasuredData& data) {
  return std::any_of(data.poses.begin(), data.poses.end(), [](const sim::MeasuredPose& p) { return p.has_rotation; });
}

std::string noiseText(const calib::MarkerNoise& n, bool rotation) {
  return "position " + formatNumber("%.3g", n.sigma_position_m * 1e3) + " mm" +
         (rotation ? ", rotation " + formatNumber("%.3g", n.sigma_rotation_rad * sim::kRadToDeg) + " deg" : std::string());
}

std::string statsTableHeader(bool rotation) {
  return rotation ? "| model | samples | position mean (mm) | position RMS (mm) | position max (mm) | rotation RMS (deg) |\n"
                    "|---|---|---|---|---|---|\n"
                  : "| model | samples | position mean (mm) | position RMS (mm) | position max (mm) |\n|---|---|---|---|---|\n";
}

std::string statsTableRow(const std::string& model, const calib::ResidualStats& s, bool rotation) {
  return "| " + model + " | " + std::to_string(s.samples) + " | " + formatNumber("%.4f", s.position_mean_m * 1e3) + " | " +
         formatNumber("%.4f", s.position_rms_m * 1e3) + " | " + formatNumber("%.4f", s.position_max_m * 1e3) + " |" +
         (rotation ? " " + formatNumber("%.4f", s.rotation_rms_rad * sim::kRadToDeg) + " |" : std::string()) + "\n";
}

namespace {

/// `classes` where they cover `layout` (one class per parameter), else nullptr.
const calib::ParameterClasses* coveringClasses(const sim::ParamLayout& layout, const calib::ParameterClasses* classes) {
  return classes && static_cast<int>(classes->classes.size()) == layout.size() ? classes : nullptr;
}

/// The injected value (SI) of parameter i of `layout` where it is a geometry parameter `truth` holds, else nullptr.
const double* geometryTruth(const sim::ParamLayout& layout, const Eigen::VectorXd* truth, int i) {
  const int g = layout.find(sim::BlockKind::kGeometry);
  if (!truth || g < 0) return nullptr;
  const int k = i - layout.block(g).offset;
  return k >= 0 && k < layout.block(g).size() && k < truth->size() ? &(*truth)[k] : nullptr;
}

/// A compliance (rad/(N*m)) also as the stiffness people quote, 1/c in N*m/rad with its 1-sigma
/// (sigma_c / c^2), one line after the table for each fitted one; "" when there is none.
std::string stiffnessLines(const calib::Fit& fit) {
  std::string out;
  const std::vector<sim::ParameterRow> rows = parameterRows(fit);
  for (int i = 0; i < fit.model.layout.size(); ++i) {
    const sim::ParamInfo& info = fit.model.layout.param(i);
    const sim::ParameterRow& r = rows[static_cast<std::size_t>(i)];
    if (info.display_unit != "rad/(N*m)" || r.held || !(r.value > 0.0)) continue;
    out += "- " + r.name + ": stiffness " + formatNumber("%.5g", 1.0 / r.value) + " N*m/rad (1-sigma " +
           formatNumber("%.3g", r.sigma / (r.value * r.value)) + ")\n";
  }
  return out.empty() ? out : "\nAs stiffness (1 / compliance):\n\n" + out;
}

}  // namespace

std::string parameterTable(const calib::Fit& fit, const calib::ParameterClasses* classes, const Eigen::VectorXd* geometry_truth) {
  const sim::ParamLayout& L = fit.model.layout;
  const calib::ParameterClasses* classified = coveringClasses(L, classes);
  std::string md = std::string("| parameter | block | value | 1-sigma | unit | determined |") + (geometry_truth ? " truth |" : "") +
                   "\n|---|---|---|---|---|---|" + (geometry_truth ? "---|" : "") + "\n";
  const std::vector<sim::ParameterRow> rows = parameterRows(fit);
  const std::vector<std::string> partners =
      combinationPartners(classified ? classified->groups : fit.identifiability.redundancies, L.size());
  bool frames = false;
  for (int i = 0; i < L.size(); ++i) {
    const sim::BlockKind kind = L.block(L.blockOf(i)).kind;
    if (kind == sim::BlockKind::kBase || kind == sim::BlockKind::kMarker) {  // shown as frames (registrationFramesTable), not as increments
      frames = true;
      continue;
    }
    const sim::ParamInfo& info = L.param(i);
    const sim::ParameterRow& r = rows[static_cast<std::size_t>(i)];
    const std::string& with = partners[static_cast<std::size_t>(i)];
    const bool ineffective = classified && classified->classes[static_cast<std::size_t>(i)] == calib::ParamClass::kIneffective;
    md += "| " + r.name + " | " + r.effect + " | " + formatNumber("%+.5g", r.value * info.display_scale) + " | " +
          (r.held ? std::string("held") : formatNumber("%.3g", r.sigma * info.display_scale)) + " | " + info.display_unit + " | " +
          (r.held ? std::string(ineffective ? "no: held at nominal (the measurement does not see it)"
                                            : "no: held at nominal (unidentifiable here)")
                  : with.empty() ? std::string("yes") : "only in a combination with " + with + " (the value alone is not)") +
          " |";
    if (geometry_truth) {
      const double* t = geometryTruth(L, geometry_truth, i);
      md += " " + (t ? formatNumber("%+.5g", *t * info.display_scale) : std::string()) + " |";
    }
    md += "\n";
  }
  if (frames) md += "\nThe registration frames are shown as frames, not as the parameters of their fit (`estimates.csv` lists those).\n";
  return md + stiffnessLines(fit);
}

std::string estimatesCsv(const calib::Fit& fit, const calib::ParameterClasses* classes, const Eigen::VectorXd* geometry_truth) {
  std::ostringstream csv;
  csv << "parameter,effect,unit,estimate,sigma,truth,held,class\n";
  const sim::ParamLayout& L = fit.model.layout;
  const calib::ParameterClasses* classified = coveringClasses(L, classes);
  const std::vector<sim::ParameterRow> rows = parameterRows(fit);
  for (int i = 0; i < L.size(); ++i) {
    const sim::ParamInfo& info = L.param(i);
    const sim::ParameterRow& r = rows[static_cast<std::size_t>(i)];
    const double* t = geometryTruth(L, geometry_truth, i);
    csv << r.name << "," << r.effect << "," << info.display_unit << "," << sim::exactNumber(r.value * info.display_scale) << ","
        << (std::isfinite(r.sigma) ? sim::exactNumber(r.sigma * info.display_scale) : std::string()) << ","
        << (t ? sim::exactNumber(*t * info.display_scale) : std::string()) << "," << (r.held ? 1 : 0) << ","
        << (classified ? calib::paramClassName(classified->classes[static_cast<std::size_t>(i)]) : "") << "\n";
  }
  return csv.str();
}

namespace {

std::string weakList(const calib::Fit& fit) {
  std::string out;
  for (int i : fit.weak) out += (out.empty() ? "" : ", ") + fit.model.layout.param(i).name;
  return out.empty() ? "none" : out;
}

std::string folderOf(const std::string& path) {
  const std::filesystem::path p = std::filesystem::path(path).parent_path();
  return p.empty() ? "." : p.string();
}

/// The one hold-out split (calib::holdoutSplit): whole configurations, stratified by session, seeded.
void splitHeldOut(const std::vector<calib::MarkerObservation>& all, const MeasuredCalibrateOptions& o,
                  std::vector<calib::MarkerObservation>& ident, std::vector<calib::MarkerObservation>& held) {
  const std::vector<int> part = calib::holdoutSplit(all, o.holdout, o.seed);
  for (std::size_t k = 0; k < all.size(); ++k) (part[k] == 1 ? held : ident).push_back(all[k]);
}

/// The estimator and the noise: the options' where given, else the description's.
calib::FitOptions fitOptionsOf(const MeasuredCalibrateOptions& o, const sim::MeasuredData& data) {
  calib::FitOptions fo;
  fo.method = o.method;
  fo.sigma_position_m = o.noise_position_m ? o.noise_position_m : data.noise_position_m;
  fo.sigma_rotation_rad = o.noise_rotation_rad ? o.noise_rotation_rad : data.noise_rotation_rad;
  fo.joint_noise_sigma_rad = data.noise_joint_rad.value_or(0.0);
  return fo;
}

/// What the calibration is judged on: the held-out observations and their residuals under the nominal
/// arm and the calibrated model, and the verdict (calib::heldoutVerdict or crossValidatedVerdict).
struct Judgement {
  std::vector<calib::MarkerObservation> obs;
  std::vector<Eigen::VectorXd> before, after;
  calib::HeldoutVerdict verdict;
};

/// A set too small for a held-out split: every configuration predicted by the nominal arm and by the
/// calibrated model fitted (at `level`, the registration of the reference likewise) to all the others.
Judgement crossValidatedJudgement(const sim::MeasuredData& data, const std::vector<calib::MarkerObservation>& all,
                                  const std::vector<sim::Effect>& effects, const calib::Level& level, calib::FitOptions fo) {
  fo.analyze = false;
  const calib::FoldPredictor predict = [&](const std::vector<int>& train_index, const std::vector<int>& test_index) {
    std::vector<calib::MarkerObservation> train, test;
    for (int i : train_index) train.push_back(all[static_cast<std::size_t>(i)]);
    for (int i : test_index) test.push_back(all[static_cast<std::size_t>(i)]);
    const sim::KinematicModel start = calib::startingModel(data, train, effects);
    const calib::Fit reference = calib::fitRegistration(start, train, fo);
    const calib::Fit fit = calib::fitMarkerModel(start, train, calib::levelOptions(fo, start, level, "--level"));
    return calib::FoldPrediction{calib::markerResiduals(start, reference.p, test), calib::markerResiduals(start, fit.p, test)};
  };
  Judgement j;
  j.obs = all;
  j.verdict = calib::crossValidatedVerdict(all, predict, &j.before, &j.after);
  return j;
}

}  // namespace

std::string writeModelAndExports(const calib::CalibratedModel& cm, const std::vector<sim::ParameterRow>& rows, const std::string& out,
                                 const std::string& header, const std::string& robot_name) {
  sim::KinematicModel model = cm.model;
  const sim::Arm& arm = model.arm;
  const std::string what = arm.urdf.empty() ? "the calibrated DH table as a chain from base_link to flange"
                                            : "the joint origins of the chain " + arm.urdf.base_link + " -> " + arm.urdf.tip_link + " calibrated";
  sim::writeCalibratedUrdf(arm, out + "/robot_calibrated.urdf", header.substr(0, header.find('\n')) + "; " + what);
  if (!model.arm.urdf.empty()) model.arm.urdf.file = out + "/robot_calibrated.urdf";
  sim::writeFileAtomic(out + "/frames.yaml", sim::formatFramesFile(model, header));
  sim::writeFileAtomic(out + "/effects.yaml", sim::formatEffectsFile(model, cm.p, robot_name, header));
  return sim::writeModelFile(model, cm.p, rows, out, header, "model.yaml", robot_name);
}

std::string inconsistencyText(const MeasuredCalibrateResult& r) {
  return "chi-square " + formatNumber("%.1f", r.fit.chi2) + " for " + std::to_string(r.fit.dof) + " degrees of freedom (" +
         formatNumber("%.2f", r.fit.chi2 / r.fit.dof) + " per degree, p = " + formatNumber("%.2g", r.consistency_p) +
         "); the noise given is too small for these residuals (" +
         (r.fit.noise.joint_noise_sigma_rad > 0.0 ? std::string("the tracker's or the joint readings'")
                                                  : std::string("or the joint readings have noise the description does not state: noise.joint_deg")) +
         "), or the model misses an effect (`orbcal diagnose` names it)";
}

namespace {

/// Every reason a measured-data calibration is not accepted, one line each, in the order they are said.
std::vector<std::string> refusalsOf(const MeasuredCalibrateResult& r) {
  std::vector<std::string> out;
  if (r.inconsistent) out.push_back("the fit is inconsistent with the given measurement noise: " + inconsistencyText(r));
  for (const std::string* why : {&r.refusal, &r.fit_refusal}) {
    if (!why->empty()) out.push_back(*why);
  }
  return out;
}

/// The geometric parameters in people's words: "28 DH errors (4 per joint)", or for a URDF chain "49 errors
/// of the joints iiwa_joint_1 ... iiwa_joint_7 (7 each: zero offset, origin x, y, z, roll, pitch, yaw)".
std::string geometryWords(const sim::Arm& arm) {
  const int n = arm.numJoints(), per = n > 0 ? arm.numParams() / n : 0;
  if (arm.convention != sim::DhConvention::kUrdf || arm.urdf.joint_names.size() != static_cast<std::size_t>(n) || n == 0) {
    return std::to_string(arm.numParams()) + " DH errors (" + std::to_string(per) + " per joint)";
  }
  return std::to_string(arm.numParams()) + " errors of the joints " + arm.urdf.joint_names.front() + " ... " + arm.urdf.joint_names.back() + " (" +
         std::to_string(per) + " each: zero offset, origin x, y, z, roll, pitch, yaw)";
}

}  // namespace

MeasuredCalibrateResult runMeasuredCalibrate(const MeasuredCalibrateOptions& o) {
  calib::checkHoldout(o.holdout);
  if (sim::describesImages(o.description)) {  // images: the hand-eye and board frames (measured_images.hpp)
    MeasuredCalibrateResult r;
    auto images = std::make_shared<ImageCalibrateResult>(runImageCalibrate(o));
    r.refusals = images->refusals;
    r.report_path = images->report_path;
    r.images = std::move(images);
    return r;
  }
  return runMeasuredCalibrate(sim::loadMeasuredData(o.description), o);
}

MeasuredCalibrateResult runMeasuredCalibrate(const sim::MeasuredData& data, const MeasuredCalibrateOptions& o) {
  calib::checkHoldout(o.holdout);
  MeasuredCalibrateResult r;
  std::vector<sim::Effect> effects;
  for (const std::string& e : o.effects) effects.push_back(sim::parseEffect(e, data.arm.numJoints(), "--effects"));
  const std::vector<calib::MarkerObservation> all = calib::observationsFrom(data, calib::needsTorque(effects));
  r.samples = static_cast<int>(all.size());

  const int configurations = calib::countConfigurations(all);
  r.cross_validated = calib::judgeByCrossValidation(configurations, o.holdout);
  std::vector<calib::MarkerObservation> ident, held;
  if (r.cross_validated) ident = all;
  else splitHeldOut(all, o, ident, held);
  r.identification = static_cast<int>(ident.size());
  r.held_out = static_cast<int>(held.size());
  r.warnings = readingWarnings(data);

  calib::FitOptions fo = fitOptionsOf(o, data);
  sim::KinematicModel start;
  try {
    start = calib::startingModel(data, ident, effects);
  } catch (const std::invalid_argument& e) {
    throw sim::InputError(std::string("--effects: ") + e.what());
  }
  // The reference: the nominal arm with only the registration fitted; a physically impossible one (or
  // calibrated geometry) is refused before anything is written.
  r.level = calib::resolveLevel(o.level, data, ident, effects, fo, o.seed);
  const calib::FitOptions unleveled = fo;
  fo = calib::levelOptions(fo, start, r.level.chosen, "--level");
  const calib::Fit reference = calib::fitRegistration(start, ident, fo);
  calib::requirePlausibleResidual(data, reference.residuals, "the nominal arm's registration residual");
  r.fit = calib::fitMarkerModel(start, ident, fo);
  calib::requirePlausibleGeometry(data, r.fit);
  // The inputs are read and checked: the output folder now holds this run's outcome only (sim::OutputFolder).
  sim::OutputFolder folder(o.out.empty() ? folderOf(o.description) + "/calibration" : o.out, "orbcal calibrate");
  const std::string& out = folder.path();
  Judgement judged;
  if (r.cross_validated) {
    judged = crossValidatedJudgement(data, all, effects, r.level.chosen, unleveled);
  } else {
    judged = {held, calib::markerResiduals(start, reference.p, held), calib::markerResiduals(start, r.fit.p, held), {}};
    judged.verdict = calib::heldoutVerdict(held, judged.before, judged.after, o.holdout, configurations);
  }
  const calib::HeldoutVerdict& verdict = judged.verdict;
  r.heldout_before = calib::residualStats(judged.before);
  r.heldout_after = calib::residualStats(judged.after);
  r.gain = verdict.gain;
  // The frames level without effects is the reference itself (the nominal arm, registration fitted):
  // there is no gain over it to test; nor is there one when nothing is held out: the checks on the fit
  // alone (consistency, fitRefusal) decide then.
  const bool reference_level = r.level.chosen.kind == calib::LevelKind::kFrames && effects.empty();
  r.worse = !reference_level && verdict.worse;
  r.refusal = reference_level || (held.empty() && !r.cross_validated) ? "" : verdict.refusal;
  r.fit_refusal = calib::fitRefusal(r.fit, ident, fo);
  r.structure_left = structureLeft(r, data, o.description, judged.obs, judged.after, r.lack_of_fit);

  const calib::CalibratedModel cm = calib::calibratedModel(r.fit, ident);
  // Held-out samples beyond the ranges the identification data covered: their figures extrapolate.
  r.extrapolation = calib::outsideTrustedRange(cm.model, held);
  if (!r.fit.noise_estimated && r.fit.dof > 0) {
    r.consistency_p = calib::chiSquareSurvival(r.fit.chi2, r.fit.dof);
    r.inconsistent = r.consistency_p < calib::Consistency{}.alpha;
  }
  r.refusals = refusalsOf(r);
  const bool write_model = (!r.worse && r.refusals.empty()) || o.accept_worse;
  if (write_model) r.model = cm;  // what model.yaml holds
  if (write_model) r.model_path = folder.published(writeModelAndExports(cm, parameterRows(r.fit), out, modelHeader(data, o)));

  const bool rotation = measuresRotation(data);
  std::ostringstream md;
  md << "# Calibration of " << data.arm.name << " from measured data\n\n";
  md << verdictLines(r, write_model);
  md << "Description `" << o.description << "`: " << r.samples << " samples in " << data.numSessions() << " session(s); "
     << (r.cross_validated ? "all " + std::to_string(r.identification) + " fitted; judged by cross-validation over their " +
                                 std::to_string(configurations) + " configurations (too few to hold " +
                                 std::to_string(calib::kMinHeldoutConfigurations) + " out), each predicted by the nominal arm and the "
                                 "calibrated model fitted at the same level to the others.\n\n"
                           : std::to_string(r.identification) + " fitted, " + std::to_string(r.held_out) + " held out (" +
                                 std::to_string(r.gain.configurations) + " configurations; seed " + std::to_string(o.seed) +
                                 ", per session).\n\n")
     << "Model: geometry (" << geometryWords(data.arm) << ") + registration (base " << sim::frameSharingName(data.base)
     << ", marker " << sim::frameSharingName(data.marker) << ")";
  for (const std::string& e : o.effects) md << " + " << e;
  md << "; " << r.fit.model.layout.size() << " parameters, " << r.fit.estimate.held.size() << " held (by the level or as unidentifiable)"
     << (fo.map ? "; the geometry's prior at " + formatNumber("%.3g", r.fit.prior_scale) + " times its typical sizes (by the evidence) leaves " +
                      formatNumber("%.1f", r.fit.effective_parameters) + " effective parameters"
                : std::string())
     << ".\n\n"
     << "Calibrated at " << calib::levelSentence(r.level) << ".\n\n"
     << "Measurement noise (1 sigma per axis): " << noiseText(r.fit.noise, rotation)
     << (r.fit.noise_estimated ? " (estimated from the residuals)" : " (given)") << "; joint readings "
     << formatNumber("%.4f", r.fit.noise.joint_noise_sigma_rad * sim::kRadToDeg) << " deg"
     << (data.noise_joint_rad ? " (given)" : " (not given: not modelled)") << ". chi-square " << formatNumber("%.1f", r.fit.chi2)
     << " for " << r.fit.dof << " degrees of freedom.\n\n"
     << (r.cross_validated ? "## Cross-validated prediction\n\n" : "## Held-out prediction\n\n") << statsTableHeader(rotation) << statsTableRow("nominal arm, registration fitted", r.heldout_before, rotation)
     << statsTableRow("calibrated", r.heldout_after, rotation) << "\n" << calib::formatHeldoutGain(r.gain) << ".\n\n";
  for (const std::string& w : r.extrapolation) md << "**Held out beyond the fitted range:** " << w << ".\n\n";
  md << "## Fit residuals\n\n" << statsTableHeader(rotation)
     << statsTableRow("calibrated (fitted samples)", r.fit.residuals, rotation)
     << "\n## What this data cannot identify\n\n```\n" << sim::formatIdentifiability(r.fit.identifiability) << "```\n\n"
     << "Held parameters stay at their nominal value; the rest carry their observable combinations.\n\n"
     << "Observability indices of the fitted samples (Borm & Menq 1991 O1 to Sun & Hollerbach 2008 O5; whitened rows, "
        "columns in typical magnitudes, held parameters left out; larger is better): "
     << calib::formatIndices(r.fit.observability) << ".\n\n"
     << "Determined no better than their typical magnitude (1-sigma above it; the data barely informs them): "
     << weakList(r.fit) << ".\n\n"
     << "## Parameters\n\n" << parameterTable(r.fit) << "\n" << sim::signConventions(effects) << "\n## Registration frames\n\n"
     << registrationFramesTable(r.fit, "the description's") << "\n## Figures\n\n"
     << measured_detail::measuredFigures(o.callbacks, o.plots, out, r.fit, judged.obs, judged.before, judged.after, write_model)
     << "\n## Files\n\n" << (write_model ? "`model.yaml` with `robot.yaml` (orbcal's model: `orbcal evaluate`, `--robot robot.yaml`), "
                                              "`estimates.csv` (every parameter); for other programs `robot_calibrated.urdf` (the "
                                              "calibrated chain), `frames.yaml` (the registration frames) and `effects.yaml` (the "
                                              "fitted effects with the formulas that apply them; docs/export.md); " : "")
     << "`heldout.csv` (per held-out sample).\n";
  writeReport(out, md.str());
  folder.commit();
  r.report_path = folder.finalPath() + "/report.md";
  return r;
}

sim::SimulatedData runSimulate(const sim::Arm& arm, const sim::SimulationSpec& spec, const std::string& final_out) {
  sim::SimulatedData s = sim::simulateMeasured(arm, spec);
  sim::OutputFolder folder(final_out, "orbcal simulate");
  const std::string& out = folder.path();
  sim::writeFileAtomic(out + "/robot.yaml", sim::formatArm(arm, "Nominal robot of a dataset simulated by orbcal simulate from " + arm.source));
  s.data.description = folder.published(sim::writeMeasuredData(s.data, out, "robot.yaml"));
  const sim::FoldedModel truth = sim::foldParameters(s.truth, s.p_true);
  std::vector<sim::ParameterRow> rows;
  for (int i = 0; i < s.truth.layout.size(); ++i) {
    const sim::ParamInfo& p = s.truth.layout.param(i);
    rows.push_back({p.name, s.truth.layout.block(s.truth.layout.blockOf(i)).effect, p.unit, s.p_true[i], 0.0, false});
  }
  sim::writeModelFile(truth.model, truth.p, rows, out + "/truth", "The truth of the dataset simulated by orbcal simulate (seed " +
                                                                        std::to_string(spec.seed) + ")");
  folder.commit();
  return s;
}

}  // namespace orbcal::workflow
