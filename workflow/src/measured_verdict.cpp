#include "measured_verdict.hpp"

#include <sstream>

#include "orbcal/calib/diagnose.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"

namespace orbcal::workflow::measured_detail {

using sim::formatNumber;

/// Diagnose's lack-of-fit tests (calib/lack_of_fit.hpp) on the calibrated model's held-out residuals:
/// the global test against the noise where it is given, and the extended variable family. Where they
/// flag something, the sentence that says structure is left and which command names it.
std::string structureLeft(const MeasuredCalibrateResult& r, const sim::MeasuredData& data, const std::string& description,
                          const std::vector<calib::MarkerObservation>& held, const std::vector<Eigen::VectorXd>& after,
                          calib::LackOfFit& lof) {
  if (held.size() < 10) return "";
  // The parameters come from the identification samples alone: their covariance is the held-out
  // prediction's estimation variance as it is (one "fold").
  lof = calib::lackOfFit(data, held, r.fit, r.fit.noise, after, !r.fit.noise_estimated, 1, calib::DiagnoseOptions{}.alpha);
  if (!lof.left()) return "";
  std::string why = lof.unexplained.empty() ? "" : "structured against " + calib::describeUnexplained(lof.unexplained);
  if (lof.significant) {
    why += std::string(why.empty() ? "" : ", and ") + "above the noise (held-out position RMS " +
           formatNumber("%.3g", lof.position_rms_m * 1e3) + " mm against the " + formatNumber("%.3g", lof.noise_position_rms_m * 1e3) +
           " mm the " + (lof.source == calib::NoiseSource::kStated ? "stated noise" : "repeated configurations' scatter") + " gives; p " + formatNumber("%.2g", lof.p_value) + ")";
  }
  return "Structure is left: the calibrated model's held-out residuals are " + why +
         ": the model misses an effect. `orbcal diagnose " + description + "` names it and the --effects to calibrate with";
}

/// The comment at the top of the model files a calibration writes: what wrote them, from what.
std::string modelHeader(const sim::MeasuredData& data, const MeasuredCalibrateOptions& o) {
  std::ostringstream header;
  header << "Calibrated by orbcal " << ORBCAL_VERSION << " (orbcal calibrate) from " << o.description << "\n"
         << "nominal: " << data.robot_file << "; effects: " << (o.effects.empty() ? "none" : "");
  for (const std::string& e : o.effects) header << e << " ";
  return header.str();
}

/// The report's first lines: each reason the calibration is not accepted, or that it is, and whether
/// model.yaml was written.
std::string verdictLines(const MeasuredCalibrateResult& r, bool write_model) {
  const std::string written = write_model ? "model.yaml was written because --accept-worse was given." : "model.yaml was not written.";
  const std::string rms = formatNumber("%.4f", r.heldout_before.position_rms_m * 1e3) + " -> " +
                          formatNumber("%.4f", r.heldout_after.position_rms_m * 1e3) + " mm";
  std::ostringstream md;
  const std::string samples = r.cross_validated ? "samples, each by a fit without its configuration," : "held-out samples";
  for (const std::string& w : r.warnings) md << "**Warning:** " << w << ".\n\n";
  if (r.worse) md << "**The calibrated model predicts the " << samples << " WORSE than the nominal arm (position RMS " << rms << ").** " << written << "\n\n";
  if ((!r.worse || !r.gain.enough) && !r.refusal.empty()) md << "**The calibration is not accepted: " << r.refusal << ".** " << written << "\n\n";
  if (!r.fit_refusal.empty()) md << "**The calibration is not accepted: " << r.fit_refusal << ".** " << written << "\n\n";
  if (r.inconsistent) {
    md << "**The fit is inconsistent with the given measurement noise: " << inconsistencyText(r) << ".** " << written << "\n\n";
  }
  if (!r.worse && r.refusals.empty()) {
    md << "**Accepted: model.yaml was written ("
       << (r.held_out > 0 ? "held-out position RMS, nominal arm -> calibrated: " + rms
           : r.cross_validated ? "cross-validated position RMS, nominal arm -> calibrated: " + rms
                               : "nothing held out: the checks on the fit alone decided")
       << ").**\n\n";
  }
  if (!r.structure_left.empty()) md << "**" << r.structure_left << ".**\n\n";
  return md.str();
}

}  // namespace orbcal::workflow::measured_detail
