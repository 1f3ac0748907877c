#pragma once
// Comparing estimators on one identification set and one validation set, as Wang et al. 2023's Table 4
// does, plus the control-noise floor (the validation error the true parameters leave) that no
// estimator can beat. The measurement source (rendered images, real images, synthetic poses) is the
// caller's: this file needs only observations and the validation plant.
#include <string>
#include <vector>

#include "orbcal/calib/estimators.hpp"
#include "orbcal/calib/marker_model.hpp"
#include "orbcal/calib/model.hpp"
#include "orbcal/calib/parameter_classes.hpp"
#include "orbcal/calib/validation.hpp"

namespace orbcal::calib {

struct MethodSpec {
  enum class Kind { kEkf, kLse, kLm };
  std::string name;         ///< short, for tables and plots
  std::string description;  ///< its settings, one line
  Kind kind = Kind::kEkf;
  EkfOptions ekf;
  LseOptions lse;
  LmOptions lm;
  PoseNoiseModel noise;     ///< where R comes from
};

/// The comparison for measurements whose plant has joint control noise `joint_noise_sigma_rad`:
/// Wang et al. 2023's LSE and EKF as written (paper-literal presets), one change at a time towards orbcal's
/// defaults (wide prior, R from the measurement plus the joint noise, re-linearized), the iterated
/// EKF, and LM with and without a robust loss. orbcal's default EKF is the one named "EKF".
std::vector<MethodSpec> comparisonMethods(double joint_noise_sigma_rad);
/// The estimator of every calibration, from images and from measured data alike, unless told otherwise.
inline constexpr const char* kDefaultMethod = "LM";
/// The method named `name` from `methods` (comparisonMethods()); "LSE" is the weighted one, "LSE
/// (weighted)". Throws InputError naming `what` and listing the names otherwise.
MethodSpec findMethod(const std::vector<MethodSpec>& methods, const std::string& name, const std::string& what = "--method");
/// Every name findMethod takes, the short ones first ("LM, LSE, EKF, LSE (paper), ..."), for --help.
std::string methodNames();

/// What a calibration sets on top of its method's own settings, whichever estimator that is.
struct FitControls {
  std::vector<int> hold;            ///< parameters held at zero whatever the data says (every estimator)
  bool fix_unidentifiable = true;   ///< LSE, LM: also hold one parameter per unidentifiable group
  bool covariance = true;           ///< LM: the estimate's covariance (LmOptions::covariance)
  bool normal_equations = false;    ///< LM: LmOptions::normal_equations
  double decrease_tolerance = 1e-6; ///< LM on the normal equations: LmOptions::decrease_tolerance
  /// A Gaussian prior (LmOptions::prior_sigma) for every estimator: LM's prior residuals, LSE's
  /// pseudo-observations, the EKF's P0; empty: none.
  Eigen::VectorXd prior_sigma, prior_mean;
  /// The maximum a-posteriori estimate with the prior's strength from the data: on the parameters
  /// where scaled_prior_i > 0 the prior sigma is tau * scaled_prior_i (ridge regression toward
  /// prior_mean, weighted by 1/scaled_prior^2), and tau maximises the evidence of the linearized model
  /// (MacKay 1992; in geodesy the prior's variance component, Koch and Kusche 2002): refit, then
  /// tau^2 = sum ((y_i - mean_i) / scaled_prior_i)^2 / gamma, gamma the well-determined parameters
  /// among them (shrinkage()), until tau changes by less than 0.1 %. Empty: the prior as given.
  Eigen::VectorXd scaled_prior;
  Eigen::VectorXd start;  ///< LM: LmOptions::start
};

Estimate runMethod(const MethodSpec& method, const sim::Arm& nominal, const std::vector<PoseObservation>& observations);
/// The one fitting entry point of both data paths: the method's estimator (its EKF, LSE or LM options)
/// on any measurement model, with `controls` applied; method.noise is the model's business there.
Estimate runMethod(MethodSpec method, const MeasurementModel& model, const FitControls& controls = {});

struct MethodOutcome {
  MethodSpec method;
  Estimate estimate;
  PoseErrors errors;     ///< on the validation set, after compensation
  ErrorSummary summary;
};

struct Comparison {
  int observations = 0;
  PoseErrors initial_errors, floor_errors;
  ErrorSummary initial;  ///< nominal model
  ErrorSummary floor;    ///< the true model (effects included): what the control noise alone leaves
  std::vector<MethodOutcome> methods;
};

/// The floor is poseErrors(truth, validation): the true model with its effects, driven by the
/// commanded joints. The y_true form is a plant of DH errors alone (sim::geometricTrueArm).
Comparison compareMethods(const sim::Arm& nominal, const sim::TrueArm& truth,
                          const std::vector<PoseObservation>& observations, const PlantSamples& validation,
                          const std::vector<MethodSpec>& methods);
Comparison compareMethods(const sim::Arm& nominal, const Eigen::VectorXd& y_true,
                          const std::vector<PoseObservation>& observations, const PlantSamples& validation,
                          const std::vector<MethodSpec>& methods);

/// The same estimates validated against another plant (e.g. the validation poses a camera measured).
Comparison revalidate(const Comparison& c, const sim::Arm& nominal, const sim::TrueArm& truth,
                      const PlantSamples& validation);
Comparison revalidate(const Comparison& c, const sim::Arm& nominal, const Eigen::VectorXd& y_true,
                      const PlantSamples& validation);

/// The method with the lowest average validation position error among those of `kind`; nullptr if none.
const MethodOutcome* bestOfKind(const Comparison& c, MethodSpec::Kind kind);

/// One row per (model, validation sample): model, sample, position_mm, x_deg, y_deg, z_deg.
/// Models: "initial", "floor" and each method. For box plots.
std::string formatValidationErrorsCsv(const Comparison& c);
/// One row per model (initial, floor, each method): average and largest validation position error [mm],
/// average X/Y/Z orientation error [deg] and the average position error over the floor's (x_floor).
std::string formatComparisonSummaryCsv(const Comparison& c);
/// One row per (method, parameter): estimate, 1-sigma and truth in deg or mm, held, and, where
/// `classes` are given, its class (independent; relative: in an unidentifiable combination, only the
/// combination is determined; ineffective). Without a truth (y_true null: real data) the truth cells
/// are empty; without classes the class cells.
std::string formatEstimatesCsv(const sim::Arm& nominal, const Comparison& c, const Eigen::VectorXd* y_true,
                               const ParameterClasses* classes = nullptr);
/// Markdown: per method its settings, iterations, rank, wall time, the RMS of its length estimates
/// (a and d, against the RMS of the true ones: a prior too tight shows as lengths that never move), and
/// average position error against the floor.
std::string formatMethodsTable(const sim::Arm& nominal, const Comparison& c, const Eigen::VectorXd& y_true);
/// The Table 4 layout (validation.hpp) of a comparison.
std::string formatComparisonTable4(const Comparison& c);
/// A short summary, one row per model (initial, each method, floor): average and extreme position error,
/// over the floor, average orientation X/Y/Z, improvement. Markdown, mm and deg.
std::string formatComparisonSummary(const Comparison& c);
/// Per method, its own Table 4 layout (initial against that method), for the detail below a summary.
std::string formatComparisonDetail(const Comparison& c);

/// Estimates not to be trusted: with the truth known, those off by more than 10 times the larger of the
/// truth and a tenth of the parameter's typical magnitude (sim::geometryBlock: 1 deg, 5 mm); without it,
/// those beyond 10 typical magnitudes (a DH error of 10 deg or 50 mm is a wrong model, not an error).
/// One entry per parameter: "a1 = +143.032 mm (injected +0.500)".
std::vector<std::string> suspiciousEstimates(const sim::Arm& nominal, const Estimate& e, const Eigen::VectorXd* y_true);
/// Identified against injected, one row per parameter, a column per method named (deg and mm, +- 1 sigma);
/// suspicious estimates in bold.
std::string formatEstimatesAgainstTruth(const sim::Arm& nominal, const Comparison& c, const Eigen::VectorXd& y_true,
                                        const std::vector<std::string>& methods);

}  // namespace orbcal::calib
