#pragma once
// Measured data at the command line: `orbcal calibrate DESCRIPTION.yaml` (fit geometry + registration
// + chosen effects, held-out check, model.yaml), `orbcal evaluate` (predict other data with a
// calibrated model) and `orbcal simulate` (tracker-style data with hidden effects and its truth).
#include <cstdint>
#include <string>
#include <vector>

#include "orbcal/calib/heldout.hpp"
#include "orbcal/calib/measured_fit.hpp"
#include "orbcal/sim/model_io.hpp"
#include "orbcal/sim/simulate.hpp"
#include "orbcal/workflow/callbacks.hpp"

namespace orbcal::workflow {

struct MeasuredCalibrateOptions {
  std::string description;
  std::string out;                       ///< default: <description's folder>/calibration
  std::vector<std::string> effects;      ///< "compliance:2,4", ...
  calib::FitOptions::Method method = calib::FitOptions::Method::kLm;
  double holdout = 0.2;                  ///< share of the configurations kept out (seeded; calib/heldout.hpp)
  std::uint64_t seed = 1;
  std::optional<double> noise_position_m, noise_rotation_rad;  ///< override the description's
  bool accept_worse = false;
  Callbacks callbacks;                   ///< progress (none here) and the figure drawer
  bool plots = true;                     ///< draw the report's figures (heldout.png, parameters.png)
};

struct MeasuredCalibrateResult {
  calib::Fit fit;                        ///< on the identification samples
  calib::ResidualStats heldout_before;   ///< geometry-free model (nominal arm, registration fitted)
  calib::ResidualStats heldout_after;    ///< the calibrated model
  int samples = 0, identification = 0, held_out = 0;
  bool worse = false;                    ///< held-out position RMS grew
  calib::HeldoutGain gain;               ///< the held-out gain and its test (calib/heldout.hpp)
  std::string refusal;                   ///< why the gain is not accepted (calib::heldoutRefusal); empty: accepted
  /// With the noise given (not estimated): the fit's chi-square against chi-square(dof) at the alpha of
  /// calib::Consistency; inconsistent when P(chi-square(dof) > chi2) < alpha.
  bool inconsistent = false;
  double consistency_p = 1.0;
  std::string model_path, report_path;
};

MeasuredCalibrateResult runMeasuredCalibrate(const MeasuredCalibrateOptions& o);
/// Why a measured-data fit is inconsistent with its given noise, one line (report and terminal).
std::string inconsistencyText(const MeasuredCalibrateResult& r);

/// "LM", "LSE", "EKF" (case as written); InputError naming `what` otherwise.
calib::FitOptions::Method parseFitMethod(const std::string& name, const std::string& what);

struct EvaluateResult {
  calib::Fit fit;  ///< per-session frames refitted; residuals = prediction errors
  std::vector<std::string> warnings;  ///< empirical corrections applied outside their fitted range
  std::string json_path, report_path;
};
EvaluateResult runEvaluate(const std::string& model_file, const std::string& description, const std::string& out);

/// Writes measurements.yaml + session CSVs + robot.yaml into `out`, and the truth (a model file) into
/// `out`/truth/. Returns the simulated data.
sim::SimulatedData runSimulate(const sim::Arm& arm, const sim::SimulationSpec& spec, const std::string& out);

/// Parameter rows (display units are the caller's) of a fit: every parameter, value p, 1-sigma, held.
std::vector<sim::ParameterRow> parameterRows(const calib::Fit& fit);

/// JSON of residual statistics in mm and deg: {"samples": .., "position_mean_mm": .., ...}. `key` names
/// the file and the field for the message of a non-finite number (sim::jsonNumber).
std::string residualJson(const calib::ResidualStats& s, const std::string& key);

}  // namespace orbcal::workflow
