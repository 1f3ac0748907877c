#pragma once
// orbcal's experiments: the image-to-parameters pipeline (render -> detect -> pose ->
// estimators -> validation) and the presets that reproduce Wang et al. 2023's Tables 4-5 and Fig. 8, plus the
// control-noise floor. Each writes CSV files and a Markdown report with PNG figures into its folder.
// Rendered datasets live under <out>/datasets/ and are reused by later runs with the same inputs
// (render resumes and skips finished images), so an interrupted experiment picks up where it stopped.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "orbcal/calib/experiment.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/truth.hpp"
#include "orbcal/vision/measurement.hpp"
#include "orbcal/workflow/callbacks.hpp"

namespace orbcal::workflow {

/// The presets of `orbcal experiment --preset`.
inline const std::vector<std::string> kExperimentPresets{"table4", "table5", "fig8", "floor", "selection", "jia2019", "liu2012"};

struct ExperimentOptions {
  std::string robot = "builtin:ssrms.yaml";
  std::string base_link, tip_link;  ///< a URDF robot's chain (empty: its root and only leaf link)
  sim::RobotSource robotSource() const { return {robot, base_link, tip_link}; }
  std::string scene = "builtin:default_scene.yaml";
  std::string out = "orbcal-out";
  sim::ErrorSetSpec errors;                            ///< injected (default: Wang et al. 2023 Table 3; or an error-set file)
  double joint_noise_sigma_rad = 0.01 * 3.14159265358979323846 / 180.0;  ///< Wang et al. 2023: 0.01 deg
  int identification = 50;
  int validation = 200;
  int repetitions = 10;                                ///< table5, fig8, floor
  std::uint64_t seed = 1;
  std::string source = "images";                       ///< fig8: "images" or "synthetic"
  bool plots = true;                                   ///< draw the PNG figures (python3 + matplotlib)
  bool quiet = false;                                  ///< no progress bars
  /// Estimators to compare (names from calib::comparisonMethods, e.g. "LM", "EKF (paper)"); empty: the
  /// preset's own (table4 / run: all of them; table5, fig8: LSE (paper), EKF (paper), EKF, LM).
  std::vector<std::string> methods;
  Callbacks callbacks;  ///< progress and figures (callbacks.hpp)
};

/// o.methods when given (each checked: an unknown name is an InputError listing the names), else `preset`.
std::vector<calib::MethodSpec> chosenMethods(const ExperimentOptions& o, std::vector<calib::MethodSpec> preset);

/// A rendered dataset and what the vision pipeline measured in it.
struct MeasuredSet {
  sim::Dataset dataset;
  std::vector<vision::Measurement> measurements;
  vision::MeasurementSummary summary;
  calib::PlantSamples plant;                      ///< commanded and true joints, true flange poses, covariates
  std::vector<calib::PoseObservation> observations;  ///< the found ones, with the vision covariance
  double render_seconds = 0, measure_seconds = 0;
};

/// Renders (or resumes) <out>/datasets/<prefix>-n<count>-s<seed>-<fingerprint of the inputs> and measures it.
MeasuredSet renderAndMeasure(const ExperimentOptions& o, const std::string& prefix, int count, std::uint64_t seed);

struct Table4Result {
  calib::Comparison comparison;           ///< validation against the true poses
  calib::Comparison measured_comparison;  ///< validation against the poses the camera measured
  MeasuredSet identification, validation;
  std::string report_path;
  double seconds = 0;
};

/// Table 4 from rendered images: Table 3 errors (or o.errors), control noise, o.identification +
/// o.validation configurations, every method of calib::comparisonMethods. Writes <out>/<folder>/.
Table4Result runTable4(const ExperimentOptions& o, const std::string& folder = "table4");
void runTable5(const ExperimentOptions& o);
void runFig8(const ExperimentOptions& o);
void runFloor(const ExperimentOptions& o);
/// Selected (O3, O1) against random configurations at equal counts, every measurement kind, and the main
/// job's rendered setting (experiment_selection.cpp).
void runSelection(const ExperimentOptions& o);
void runJia2019(const ExperimentOptions& o);  ///< Jia et al. 2019 (experiment_jia2019.cpp)
void runLiu2012(const ExperimentOptions& o);  ///< Liu et al. 2012: laser ranger to a plane, Table 5 (experiment_liu2012.cpp)

/// The headline of a Table 4 run, a few lines for the terminal.
std::string table4Headline(const Table4Result& r);

// Shared by the presets.
/// Seeds: repetition r of an experiment with seed s uses s + r for its identification set and
/// s + kValidationSeedOffset + r for its validation set, so the two never share configurations or noise.
inline constexpr std::uint64_t kValidationSeedOffset = 1000000;
using sim::formatNumber;  // printf-style formatting of one number (sim/csv.hpp)
/// The injected effects of a plant for a report (a paragraph naming `source`, the error-set file, and a
/// code block); "" without effects.
std::string injectedEffects(const sim::TrueArm& truth, const std::string& source);
/// Runs a shell command line (its own redirections included) and returns its exit status (pclose's:
/// 0 for success, -1 when it cannot start) and what it printed on standard output.
std::pair<int, std::string> shellOutput(const std::string& command);

/// The mean and the sample standard deviation (n - 1 in the denominator) of a list: the spread over
/// repetitions or seeds that every preset and study summary reports. (0, 0) for an empty list.
std::pair<double, double> meanAndStd(const std::vector<double>& v);

/// FNV-1a, 64 bit: a stable fingerprint of a text (the same on every run and machine).
std::uint64_t fingerprint(const std::string& text);

/// drawFigure (callbacks.hpp) with the options' callbacks and plots switch.
std::string drawFigure(const ExperimentOptions& o, const std::string& folder, const std::string& args,
                       const std::string& png, const std::string& caption);

}  // namespace orbcal::workflow
