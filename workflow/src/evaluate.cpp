// `orbcal evaluate` and orbcal.evaluate: a calibrated model predicting other measured data, against the
// nominal arm with its frames fitted to the same data; where it extrapolates, and its confounded alternatives.
#include <algorithm>
#include <cmath>
#include <sstream>

#include "orbcal/calib/marker_model.hpp"
#include "orbcal/calib/plausibility.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/model_io.hpp"
#include "orbcal/workflow/measured.hpp"
#include "orbcal/workflow/report_html.hpp"
#include "extrapolation.hpp"
#include "measured_verdict.hpp"

namespace orbcal::workflow {

using sim::formatNumber;
using measured_detail::readingWarnings;

namespace {

/// Per-configuration ids of `obs`, numbered 0, 1, ... in the order of their first sample
/// (calib::configurationGroups).
std::vector<int> configurationIds(const std::vector<calib::MarkerObservation>& obs) {
  std::vector<std::vector<int>> groups;
  for (const auto& [key, members] : calib::configurationGroups(obs)) groups.push_back(members);
  std::sort(groups.begin(), groups.end(), [](const std::vector<int>& a, const std::vector<int>& b) { return a.front() < b.front(); });
  std::vector<int> id(obs.size(), 0);
  for (std::size_t g = 0; g < groups.size(); ++g) {
    for (int i : groups[g]) id[static_cast<std::size_t>(i)] = static_cast<int>(g);
  }
  return id;
}

/// residuals.csv of an evaluation: one row per sample, the model's prediction error (the signed
/// position components in mm, in the residual's frame: the marker's for full poses, the measuring
/// system's for positions; its length; the rotation angle in deg where measured) and the baseline's.
std::string evaluationResidualsCsv(const std::vector<calib::MarkerObservation>& obs, const EvaluateResult& e,
                                   const calib::Fit& baseline, bool rotation) {
  const calib::Fit& model = e.fit;
  const std::vector<int> config = configurationIds(obs);
  const auto num = [](double v) { return "," + formatNumber("%.6g", v); };
  std::ostringstream csv;
  csv << "index,session,configuration,x_mm,y_mm,z_mm,position_mm" << (rotation ? ",rotation_deg" : "") << ",baseline_position_mm"
      << extrapolation::csvHeader(e) << "\n";
  for (std::size_t i = 0; i < obs.size(); ++i) {
    const Eigen::VectorXd r = calib::markerResidual(model.model, model.p, obs[i]);
    const Eigen::VectorXd b = calib::markerResidual(baseline.model, baseline.p, obs[i]);
    csv << i << "," << obs[i].sample.session << "," << config[i] << num(r[0] * 1e3) << num(r[1] * 1e3) << num(r[2] * 1e3)
        << num(r.head<3>().norm() * 1e3);
    if (rotation) csv << (obs[i].has_rotation ? num(r.tail<3>().norm() * sim::kRadToDeg) : std::string(","));
    csv << num(b.head<3>().norm() * 1e3) << extrapolation::csvCells(e, i) << "\n";
  }
  return csv.str();
}

/// evaluate's verdict, the report's first paragraph (boxed on the page): the prediction against the
/// nominal arm with its frames fitted to the same data, and the floor the stated tracker noise alone
/// gives (sqrt(3) sigma per axis: the RMS of a 3-D error), where the description states it.
std::string evaluationVerdict(const calib::ResidualStats& prediction, const calib::ResidualStats& baseline,
                              const std::optional<double>& noise_position_m) {
  const bool better = prediction.position_rms_m < baseline.position_rms_m;
  const auto mm = [](double m) { return sim::formatNumber("%.4f", m * 1e3) + " mm"; };
  std::string v = std::string("**The model predicts these data ") + (better ? "better" : "no better") +
                  " than the nominal arm: position RMS " + mm(prediction.position_rms_m) + " against " +
                  mm(baseline.position_rms_m) + " (the nominal arm with its frames fitted to these data).**";
  if (noise_position_m) {
    v += " The tracker noise the description states alone gives about " + mm(std::sqrt(3.0) * *noise_position_m) + " RMS.";
  }
  return v + "\n\n";
}

}  // namespace

calib::Fit evaluationBaseline(const sim::MeasuredData& data, const std::vector<calib::MarkerObservation>& obs, calib::FitOptions fo) {
  fo.analyze = false;
  return calib::fitRegistration(calib::startingModel(data, obs, {}), obs, fo);
}

EvaluateResult runEvaluate(const std::string& model_file, const std::string& description, const std::string& out) {
  return runEvaluate(sim::loadModelFile(model_file), model_file, sim::loadMeasuredData(description), out);
}

EvaluateResult runEvaluate(const sim::LoadedModel& lm, const std::string& model_name, const sim::MeasuredData& data_in,
                           const std::string& out) {
  sim::MeasuredData data = data_in;
  const std::string& description = data.description;
  if (data.arm.numJoints() != lm.model.arm.numJoints()) {
    throw sim::InputError(description + ": robot: " + std::to_string(data.arm.numJoints()) + " joints, but the model " +
                          model_name + " has " + std::to_string(lm.model.arm.numJoints()));
  }
  data.arm.masses = lm.model.arm.masses.empty() ? data.arm.masses : lm.model.arm.masses;
  const std::vector<calib::MarkerObservation> obs = calib::observationsFrom(data, calib::needsTorque(lm.model.effects));
  calib::FitOptions fo;
  fo.sigma_position_m = data.noise_position_m;
  fo.sigma_rotation_rad = data.noise_rotation_rad;
  fo.joint_noise_sigma_rad = data.noise_joint_rad.value_or(0.0);
  EvaluateResult r;
  r.fit = calib::predictWithModel({lm.model, lm.p}, data, obs, fo);
  r.refitted = r.fit.model.layout.size() - static_cast<int>(r.fit.estimate.held.size());
  calib::requirePlausibleResidual(data, r.fit.residuals, "the prediction residual of " + model_name);
  const calib::Fit baseline = evaluationBaseline(data, obs, fo);
  r.baseline = baseline.residuals;
  sim::OutputFolder folder(out, "orbcal evaluate");  // the inputs are read and plausible
  r.warnings = readingWarnings(data);
  for (const std::string& w : calib::outsideTrustedRange(lm.model, obs)) r.warnings.push_back(w);
  r.excess = calib::rangeExcesses(lm.model, obs);
  r.alternatives = extrapolation::compareAlternatives(lm.alternatives, data, obs, fo, r.fit, r.excess);
  const bool rotation = measuresRotation(data);
  std::string json = residualJson(r.fit.residuals, out + "/evaluation.json");
  json.insert(json.size() - 1, ", \"refitted_parameters\": " + std::to_string(r.refitted) + ", \"baseline\": " +
                                   residualJson(r.baseline, out + "/evaluation.json: baseline") + ", \"model\": " +
                                   sim::jsonString(model_name) + ", \"data\": " + sim::jsonString(description) +
                                   extrapolation::jsonFields(r, out + "/evaluation.json"));
  sim::writeFileAtomic(folder.path() + "/evaluation.json", json + "\n");
  sim::writeFileAtomic(folder.path() + "/residuals.csv", evaluationResidualsCsv(obs, r, baseline, rotation));
  std::ostringstream md;
  md << "# Evaluation of `" << model_name << "` on `" << description << "`\n\n"
     << evaluationVerdict(r.fit.residuals, r.baseline, data.noise_position_m) << "Every geometric and effect parameter is the model's; "
     << (r.refitted > 0 ? "the per-session frames of the data were refitted (" + std::to_string(r.refitted) + " parameters)."
                        : std::string("nothing was refitted (the data's frames are the model's)."))
     << " The baseline is the nominal arm of the description with every registration frame fitted to this data.\n\n"
     << statsTableHeader(rotation) << statsTableRow("prediction", r.fit.residuals, rotation)
     << statsTableRow("baseline: nominal arm, frames fitted", r.baseline, rotation)
     << "\nPer sample (with its configuration): `residuals.csv`.\n";
  md << extrapolation::reportSection(r) << "\n## Registration frames\n\n" << registrationFramesTable(r.fit, "the model's");
  writeReport(folder.path(), md.str(), "evaluation.md");
  folder.commit();
  r.json_path = out + "/evaluation.json";
  r.report_path = out + "/evaluation.md";
  r.residuals_path = out + "/residuals.csv";
  return r;
}

}  // namespace orbcal::workflow
