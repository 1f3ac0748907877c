#pragma once
// Calibrating measured data (sim/measured.hpp) with a kinematic model of geometry + registration +
// effects: the closed-form start of the unknown frames, the fit with the measurement noise estimated
// from the residuals where the data does not state it, what this data cannot identify, the residual
// statistics, and the prediction of other data with a calibrated model (per-session frames refitted,
// everything else held).
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "orbcal/calib/estimators.hpp"
#include "orbcal/calib/experiment.hpp"
#include "orbcal/calib/marker_model.hpp"
#include "orbcal/calib/observability.hpp"
#include "orbcal/sim/identifiability.hpp"
#include "orbcal/sim/measured.hpp"
#include "orbcal/sim/model.hpp"

namespace orbcal::calib {

/// One observation per measured sample. Where `needs_torque` and the data has no torque column, the
/// torques come from the robot file's mass model (throws InputError naming the description when it has
/// none).
std::vector<MarkerObservation> observationsFrom(const sim::MeasuredData& data, bool needs_torque);

/// True when an effect of the list reads joint torques (compliance).
bool needsTorque(const std::vector<sim::Effect>& effects);

/// The starting model for `data`: the nominal arm, the data's frame sharing and sessions, the effects,
/// and the unknown frames from the closed-form guess (calib/registration.hpp) on the nominal arm.
sim::KinematicModel startingModel(const sim::MeasuredData& data, const std::vector<MarkerObservation>& observations,
                                  std::vector<sim::Effect> effects);

/// startingModel(data, observations, effects) from `start`, a starting model of the same data and
/// observations with other effects (or none): its frames and marker points kept, the closed-form guess
/// (a hand-eye solve) not made again.
sim::KinematicModel startingModelFrom(const sim::KinematicModel& start, const std::vector<MarkerObservation>& observations,
                                      std::vector<sim::Effect> effects);

struct ResidualStats {
  int samples = 0;
  double position_mean_m = 0, position_rms_m = 0, position_max_m = 0;  ///< of |position residual|
  double rotation_rms_rad = 0, rotation_max_rad = 0;                   ///< of the rotation angle; 0 without rotations
  int rotation_samples = 0;  ///< samples with a measured rotation; 0: position-only data (no rotation to report)
};
ResidualStats residualStats(const sim::KinematicModel& model, const Eigen::VectorXd& p,
                            const std::vector<MarkerObservation>& observations);
/// The same statistics of given residuals ([position; rotation] or [position]).
ResidualStats residualStats(const std::vector<Eigen::VectorXd>& residuals);

struct FitOptions {
  /// The estimator, a name findMethod (calib/experiment.hpp) takes: the same list and default as an
  /// image calibration's.
  std::string method = kDefaultMethod;
  /// Measurement noise per axis; estimated from the residuals (variance components of position and
  /// rotation, two refits) when not given.
  std::optional<double> sigma_position_m, sigma_rotation_rad;
  double joint_noise_sigma_rad = 0.0;
  /// Also estimate the joint noise (joint readings vs true angles, carried into R through the joint
  /// Jacobian) as a third variance component, starting from joint_noise_sigma_rad: its share of the
  /// residuals depends on the configuration, unlike the tracker's.
  bool estimate_joint_noise = false;
  std::vector<int> hold;  ///< parameters held at their start whatever the data says
  bool fix_unidentifiable = true;
  /// The analyses beside the estimate: Fit::identifiability, Fit::observability, Fit::weak and the
  /// estimate's covariance. A fit whose parameters alone are wanted (a cross-validation fold) skips
  /// them: the estimate is the same.
  bool analyze = true;
  bool normal_equations = false;  ///< LM steps from the normal equations (LmOptions::normal_equations)
  /// LM: the DH errors and the frame corrections get a Gaussian prior centred on the starting model,
  /// 1-sigma their typical magnitude (sim::ParamInfo::typical: 1 deg and 5 mm for DH errors, 1 deg
  /// and 10 mm for frame corrections; effects get none): the maximum a-posteriori estimate. A real
  /// arm's DH errors are machining and assembly tolerances well inside these, so the prior leaves
  /// what the data determine unchanged (the data weigh them thousands of times more), while the
  /// nearly unidentifiable combinations, which structure the model lacks drags along curved valleys
  /// of the cost (on the real iiwa7 runs: hundreds of iterations toward a 0.2 m link error), stay at
  /// physical sizes and the fit converges.
  bool geometry_prior = true;
  /// Every other parameter (the effects') gets a Gaussian prior too, centred on the start, 1-sigma ten
  /// times its typical magnitude (wide: a real effect of a few typical sizes is not shrunk into the
  /// noise): what diagnose's flexible fits use (calib/src/diagnose_noise.cpp). Their dozens of
  /// smooth terms leave directions the data hardly determine, along which LM without a prior creeps
  /// (100 iterations and more, each round stopping elsewhere); the prior gives the cost one minimum that
  /// LM reaches, leaves what the data determine unchanged, and the noise estimate counts it: the REML's
  /// projection includes the prior's information, and Fit::effective_parameters (so Fit::dof) is the hat
  /// matrix's trace, not the free count.
  bool effect_prior = false;
  /// The maximum a-posteriori level (calib/levels.hpp `map`): the geometry's prior is ridge regression
  /// toward the nominal arm, 1-sigma tau times the typical magnitudes (sim::ParamInfo::typical), with
  /// tau estimated from the data by the evidence (FitControls::scaled_prior); the frames keep the
  /// geometry_prior's guard, effects none. Fit::effective_parameters then says how many parameters the
  /// fit effectively used, and the noise estimate's degrees of freedom are rows minus those.
  bool map = false;
};

/// The estimated noise components (variance components: position and rotation per axis, joint readings)
/// with their uncertainty: REML's inverse Fisher information of the variances, 2 F^-1 (Koch 1999,
/// ch. 3.6), at the final estimate, corrected like the variances for the parameters fitted. A component
/// the data cannot tell from another (rotation against joint noise: both turn the marker) shows a
/// large standard deviation and a correlation near -1.
struct NoiseComponents {
  std::array<bool, 3> estimated{false, false, false};  ///< position, rotation, joint
  Eigen::Vector3d variance = Eigen::Vector3d::Zero();    ///< m^2, rad^2, rad^2
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  ///< of the three variances (0 where not estimated)
  /// 1-sigma of the component's sigma (delta method, sd(variance) / (2 sigma)); where the variance is
  /// within one sd of zero, sqrt(sd(variance)): the scale the data cannot resolve.
  double sigmaSd(int c) const;
  /// The upper end of a 2-sigma interval of the component's sigma: sqrt(max(0, variance) + 2 sd(variance)).
  double sigmaUpper(int c) const;
  /// The variance exceeds twice its standard deviation: the data show the component is above zero.
  bool resolved(int c) const;
  double correlation(int a, int b) const;
};

struct Fit {
  sim::KinematicModel model;  ///< the starting model
  Eigen::VectorXd p0;         ///< its starting parameters
  Eigen::VectorXd p;          ///< fitted: p0 + estimate.y
  Estimate estimate;          ///< y, its covariance, the held parameters
  MarkerNoise noise;          ///< as used in the final fit
  bool noise_estimated = false;
  NoiseComponents noise_components;  ///< where estimate_joint_noise: the three components' uncertainty
  sim::IdentifiabilityReport identifiability;  ///< of the whitened Jacobian at the start
  /// O1-O5 of the fitted samples (whitened rows, typical-magnitude columns, the held parameters left
  /// out; calib/observability.hpp), at the start, with the final noise.
  ObservabilityIndices observability;
  ResidualStats residuals;    ///< at the fit
  /// Free parameters this data determines no better than their typical magnitude (1-sigma above
  /// sim::ParamInfo::typical): numerically identifiable, physically not (e.g. the compliance of a
  /// joint whose torque never leaves the sensor's noise).
  std::vector<int> weak;
  double chi2 = 0.0;          ///< sum of whitened squared residuals at the fit
  int dof = 0;                ///< rows - free parameters (FitOptions::map, effect_prior: rows - effective_parameters, rounded)
  /// The free parameters, or with FitOptions::map or effect_prior the effective number of them (Estimate::
  /// effective_parameters: the hat matrix's trace), and the map prior's scale tau (0 without map).
  double effective_parameters = 0.0;
  double prior_scale = 0.0;
};
/// FitOptions::geometry_prior's 1-sigma per parameter of `layout`: the typical magnitude on the
/// geometry and frame blocks, 0 (no prior) on the effects'. The prior is centred on the starting model
/// (p = 0).
Eigen::VectorXd geometryPriorSigma(const sim::ParamLayout& layout);
/// The prior 1-sigma per parameter `options` ask for on `layout` (geometry_prior's, and with
/// effect_prior every other parameter's typical magnitude); 0: no prior. Empty when there is none.
Eigen::VectorXd fitPriorSigma(const FitOptions& options, const sim::ParamLayout& layout);
/// The estimator's controls of `options` on a model of `layout` whose starting parameters are p0: the
/// hold, the geometry prior (centred on p = 0) and map's scaled prior; any measurement model (marker
/// poses, corners) is fitted with them.
FitControls fitControls(const FitOptions& options, const sim::ParamLayout& layout, const Eigen::VectorXd& p0);
Fit fitMarkerModel(const sim::KinematicModel& start, const std::vector<MarkerObservation>& observations,
                   const FitOptions& options, const Eigen::VectorXd& p0 = {});

/// A calibrated model: the start with the fitted parameters folded in (sim::foldParameters).
struct CalibratedModel {
  sim::KinematicModel model;
  Eigen::VectorXd p;  ///< the effect parameters (frames and geometry folded into the model)
};
CalibratedModel calibratedModel(const Fit& fit);
/// The same, each effect recording the range its driving variables cover in `fitted_on`, the samples
/// the fit saw (sim::recordFittedRanges; model.yaml's `range:`).
CalibratedModel calibratedModel(const Fit& fit, const std::vector<MarkerObservation>& fitted_on);

/// Predicts other data with a calibrated model: every geometric and effect parameter is kept, and so
/// is every frame the data's description calls shared or known (the model's); the frames it calls
/// per_session (e.g. a marker re-mounted for this run) and mount changes are refitted (closed-form
/// start, then LM). Returns the fit of those frames; its `residuals` are the prediction errors.
/// How far `observations` leave the fitted ranges of `model`'s effects (sim::rangeExcesses): one entry per
/// driving variable with a recorded range (an empirical correction's: its basis's domain).
std::vector<sim::RangeExcess> rangeExcesses(const sim::KinematicModel& model, const std::vector<MarkerObservation>& observations);
/// One warning per driving variable some of `observations` leave the fitted range of
/// (sim::rangeExcessText): "compliance:4/3: 40 of 198 samples leave joint 4 torque's fitted range
/// -2.1..21.4 N m, by up to 13.2 N m: its prediction there is an extrapolation of what the data showed".
std::vector<std::string> outsideTrustedRange(const sim::KinematicModel& model, const std::vector<MarkerObservation>& observations);

Fit predictWithModel(const CalibratedModel& calibrated, const sim::MeasuredData& data,
                     const std::vector<MarkerObservation>& observations, const FitOptions& options);

}  // namespace orbcal::calib
