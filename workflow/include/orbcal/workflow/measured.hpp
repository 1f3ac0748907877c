#pragma once
// Measured data at the command line: `orbcal calibrate DESCRIPTION.yaml` (fit geometry + registration
// + chosen effects, held-out check, model.yaml), `orbcal evaluate` (predict other data with a
// calibrated model) and `orbcal simulate` (tracker-style data with hidden effects and its truth).
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "orbcal/calib/heldout.hpp"
#include "orbcal/calib/levels.hpp"
#include "orbcal/calib/lack_of_fit.hpp"
#include "orbcal/calib/measured_fit.hpp"
#include "orbcal/calib/parameter_classes.hpp"
#include "orbcal/sim/model_io.hpp"
#include "orbcal/sim/simulate.hpp"
#include "orbcal/workflow/callbacks.hpp"

namespace orbcal::workflow {

struct ImageCalibrateResult;  // measured_images.hpp

struct MeasuredCalibrateOptions {
  std::string description;
  std::string out;                       ///< default: <description's folder>/calibration
  std::vector<std::string> effects;      ///< "compliance:2,4", ... (free at every level)
  calib::Level level;                    ///< which geometric parameters are free (calib/levels.hpp); auto: by cross-validation
  std::string method = calib::kDefaultMethod;  ///< a name calib::findMethod takes
  /// Share of the configurations kept out (seeded; calib/heldout.hpp); empty: calib::defaultHoldout.
  std::optional<double> holdout;
  std::uint64_t seed = 1;
  std::optional<double> noise_position_m, noise_rotation_rad;  ///< override the description's
  bool accept_worse = false;
  Callbacks callbacks;                   ///< progress (none here) and the figure drawer
  bool plots = true;                     ///< draw the report's figures (heldout.png, parameters.png)
};

struct MeasuredCalibrateResult {
  calib::Fit fit;                        ///< on the identification samples
  calib::LevelChoice level;              ///< the level fitted, and why
  calib::ResidualStats heldout_before;   ///< geometry-free model (nominal arm, registration fitted)
  calib::ResidualStats heldout_after;    ///< the calibrated model
  int samples = 0, identification = 0, held_out = 0;
  /// Too few configurations for a held-out split (calib::judgeByCrossValidation): every sample fitted, and
  /// the gain judged by leave-one-configuration-out cross-validation (heldout_before/after and gain are
  /// then of the cross-validated residuals of all the samples).
  bool cross_validated = false;
  /// Accepted with a warning, one line each: joint readings past a limit (sim::nearLimitWarnings).
  std::vector<std::string> warnings;
  bool worse = false;                    ///< held-out position RMS grew (never at the frames level without effects: the reference itself)
  calib::HeldoutGain gain;               ///< the held-out gain and its test (calib/heldout.hpp)
  std::string refusal;                   ///< why the held-out gain is not accepted (calib::heldoutVerdict); empty: accepted or none held out
  /// Why the fit itself is refused, whatever the split (calib::fitRefusal); empty: not.
  std::string fit_refusal;
  /// What the calibrated model leaves: its held-out residuals against the noise and the variables
  /// diagnose's lack-of-fit tests use (calib/lack_of_fit.hpp); `structure_left` is the sentence that
  /// says so and which command names it (empty: nothing flagged, or too few held-out samples to test).
  calib::LackOfFit lack_of_fit;
  std::string structure_left;
  /// With the noise given (not estimated): the fit's chi-square against chi-square(dof) at the alpha of
  /// calib::Consistency; inconsistent when P(chi-square(dof) > chi2) < alpha.
  bool inconsistent = false;
  double consistency_p = 1.0;
  /// Every reason the calibration is not accepted, one line each (the fit's inconsistency, refusal,
  /// fit_refusal), as the terminal and the report's top say them; empty: accepted.
  std::vector<std::string> refusals;
  /// Held-out samples beyond the range the identification samples covered, one line per driving variable
  /// of an effect (calib::outsideTrustedRange): there the held-out figures measure extrapolation.
  std::vector<std::string> extrapolation;
  std::string model_path, report_path;
  /// The model written as model.yaml (the fit folded in, each effect with the range of the data it was
  /// fitted on: calib::calibratedModel(fit, fitted samples)); unset where none was written.
  std::optional<calib::CalibratedModel> model;
  /// A description of images (sim::describesImages): the hand-eye calibration's result
  /// (runImageCalibrate); then `refusals` and `report_path` are its, and the fields above are unset.
  std::shared_ptr<const ImageCalibrateResult> images;
};

/// `orbcal calibrate DESC.yaml`: reads o.description and calibrates it (the overload below).
MeasuredCalibrateResult runMeasuredCalibrate(const MeasuredCalibrateOptions& o);
/// The one measured-data calibration, on data already read (the command line's and Python's alike):
/// hold-out split, fit, plausibility checks, held-out verdict and refusals, model files (when accepted
/// or o.accept_worse) and report.md in o.out (default <o.description's folder>/calibration);
/// o.description names the data in the report and the files' headers.
MeasuredCalibrateResult runMeasuredCalibrate(const sim::MeasuredData& data, const MeasuredCalibrateOptions& o);

/// What every calibration writes into `out` (image datasets and measured data alike): model.yaml and
/// `robot_name` (sim/model_io.hpp) and, for programs outside orbcal (sim/export.hpp,
/// sim/urdf_export.hpp), robot_calibrated.urdf, frames.yaml and effects.yaml. `robot_name` of a URDF
/// robot names robot_calibrated.urdf as its URDF. Returns the model file's path.
/// estimates.csv of every calibration: one row per parameter of the fit's layout: name, effect, display
/// unit, estimate and 1-sigma in that unit, the injected value of a simulated dataset's geometry errors
/// where `geometry_truth` is given (else empty), held 0/1, and the parameter class where `classes` covers
/// the layout (calib/parameter_classes.hpp; else empty). What tools/plot_report.py's parameters figure reads.
std::string estimatesCsv(const calib::Fit& fit, const calib::ParameterClasses* classes = nullptr,
                         const Eigen::VectorXd* geometry_truth = nullptr);

/// The parameter table of every calibration report (Markdown): one row per parameter of the fit's
/// layout, its name, block, value and 1-sigma in its display unit, and whether the data determine it
/// (held; only in a combination with the others of its group: `classes` where it covers the layout,
/// else the fit's identifiability). With `geometry_truth`, a truth column (a simulated dataset's
/// injected geometry errors).
std::string parameterTable(const calib::Fit& fit, const calib::ParameterClasses* classes = nullptr,
                           const Eigen::VectorXd* geometry_truth = nullptr);

/// The registration frames of a measured-data fit as every report shows them (Markdown: a sentence, then a
/// table): one row per frame and session, world_T_base and flange_T_marker as fitted (sim::foldParameters),
/// position in mm and rotation as roll, pitch, yaw in deg, with the 1-sigma and the held parameters of
/// each fitted one; a frame the fit did not fit (known) is one row saying whose it is (`known`).
std::string registrationFramesTable(const calib::Fit& fit, const std::string& known);

std::string writeModelAndExports(const calib::CalibratedModel& cm, const std::vector<sim::ParameterRow>& rows, const std::string& out,
                                 const std::string& header, const std::string& robot_name = "robot.yaml");
/// Why a measured-data fit is inconsistent with its given noise, one line (report and terminal).
std::string inconsistencyText(const MeasuredCalibrateResult& r);

/// `name` if calib::findMethod takes it (the one estimator list of both data paths: LM, LSE, EKF and
/// their variants; case as written); InputError naming `what` otherwise.
std::string parseFitMethod(const std::string& name, const std::string& what);

/// A confounded alternative of the evaluated model (diagnose's alternativeN.yaml) predicting the same data.
struct AlternativePrediction {
  std::string path;                  ///< its model file
  std::string effects;               ///< its effects' specs, "compliance:2 link_bending:3"
  calib::ResidualStats residuals;    ///< its own prediction errors on the data
  std::vector<double> divergence_m;  ///< per sample: how far its predicted position lies from the model's
  int beyond = 0;                    ///< samples beyond some fitted range of the model's effects
  double beyond_rms_m = 0.0, beyond_max_m = 0.0;  ///< the divergence there (0 without such samples)
  double within_rms_m = 0.0;         ///< and on the others
};

struct EvaluateResult {
  calib::Fit fit;  ///< per-session frames refitted; residuals = prediction errors
  int refitted = 0;  ///< parameters the evaluation fitted to the data (the per-session frames' free ones)
  /// The baseline beside the model: the description's nominal arm with every registration frame fitted
  /// to this data (no geometry, no effects).
  calib::ResidualStats baseline;
  /// Joint readings past a limit (sim/joint_limits.hpp), then effects applied outside the range of the data they were fitted on, one line per driving variable
  /// (calib::outsideTrustedRange): how many samples, and by how much at most.
  std::vector<std::string> warnings;
  std::vector<sim::RangeExcess> excess;  ///< the same per sample (residuals.csv's `beyond_range`)
  std::vector<AlternativePrediction> alternatives;  ///< the model file's `alternatives:`, each predicting the data
  std::string json_path, report_path, residuals_path;
};
/// The baseline of an evaluation: the description's nominal arm with every registration frame fitted to
/// `obs` (no geometry, no effects), with the noise of `fo` (no identifiability analysis).
calib::Fit evaluationBaseline(const sim::MeasuredData& data, const std::vector<calib::MarkerObservation>& obs, calib::FitOptions fo);
/// `orbcal evaluate`: reads the model file and the description, then the overload below.
EvaluateResult runEvaluate(const std::string& model_file, const std::string& description, const std::string& out);
/// The one evaluation, on a model and data already read (the command line's and Python's alike): the
/// prediction with the per-session frames refitted, the baseline, the warnings (joint readings past a
/// limit, effects applied beyond their fitted ranges), the model's alternatives (model.alternatives, model
/// files) compared, and evaluation.json, residuals.csv, evaluation.md and report.html in `out`.
/// `model_name` names the model in the report, evaluation.json and messages; data.description the data.
EvaluateResult runEvaluate(const sim::LoadedModel& model, const std::string& model_name, const sim::MeasuredData& data,
                           const std::string& out);

/// Writes measurements.yaml + session CSVs + robot.yaml into `out`, and the truth (a model file) into
/// `out`/truth/. Returns the simulated data.
sim::SimulatedData runSimulate(const sim::Arm& arm, const sim::SimulationSpec& spec, const std::string& out);

/// Parameter rows (display units are the caller's) of a fit: every parameter, value p, 1-sigma, held.
std::vector<sim::ParameterRow> parameterRows(const calib::Fit& fit);

/// JSON of residual statistics in mm and deg: {"samples": .., "position_mean_mm": .., ...}; the rotation
/// fields only where rotations were measured (ResidualStats::rotation_samples). `key` names the file and
/// the field for the message of a non-finite number (sim::jsonNumber).
std::string residualJson(const calib::ResidualStats& s, const std::string& key);

/// True when some sample of `data` measures a rotation; false for position-only data, whose reports
/// then show no rotation noise, rotation column or rotation figure.
bool measuresRotation(const sim::MeasuredData& data);

/// The tracker noise, 1 sigma per axis, as calibrate and diagnose print it (report and terminal alike):
/// "position 0.0297 mm, rotation 0.0019 deg" in three significant digits (a small noise keeps its
/// digits, not "0.0000"); the rotation only when `rotation`.
std::string noiseText(const calib::MarkerNoise& n, bool rotation);

/// Residual statistics as a Markdown table in mm and deg: the header, then one row per model; the
/// rotation column only when `rotation`.
std::string statsTableHeader(bool rotation);
std::string statsTableRow(const std::string& model, const calib::ResidualStats& s, bool rotation);

}  // namespace orbcal::workflow
