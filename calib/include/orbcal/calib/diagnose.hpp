#pragma once
// Model diagnosis (`orbcal diagnose`): from measured data, does the model (geometry + registration)
// leave structure in its residuals, which physical cause of the effect catalog explains it, with which
// parameters, and how much better does the extended model predict data it has not seen?
//
//  1. Cross-validation: k folds by configuration (repeated measurements of one configuration stay in
//     one fold), seeded; every model is scored by its held-out whitened squared error.
//  2. Evidence: the held-out residuals of the base model regressed on each variable (joint angles with
//     harmonics, torques, temperature, time, workspace position, approach direction, sample order);
//     F tests, Holm's step-down control of the family-wise error.
//  3. Candidates: every effect of the catalog the data can express (compliance needs torques, thermal a
//     temperature that varies, ...), each tested by Rao's score test at the current fit (its Jacobian
//     columns with the model's own column space projected out: what the model cannot already absorb),
//     Holm-controlled; the significant ones are fitted and scored by cross-validation. Forward: the
//     best cross-validated gain is added while it exceeds a penalty per parameter; backward: an effect
//     whose removal costs less than its penalty is dropped. Stops when nothing significant is left.
//  4. Confounding: candidates that predict held-out data about as well as the chosen one (their
//     cross-validated gains within a margin), or a cause the geometry mostly absorbs, are named as a
//     set, with the measurement that would separate them.
#include <array>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "orbcal/calib/lack_of_fit.hpp"
#include "orbcal/calib/measured_fit.hpp"

namespace orbcal::calib {

/// The phases of a diagnosis, in the order it runs them (DiagnoseOptions::progress).
inline constexpr std::array<const char*, 6> kDiagnosePhases{
    "registration check", "noise and base model's fit", "base model's cross-validation and evidence", "forward selection",
    "backward elimination", "confounded alternatives and judgement against the noise floor (side by side)"};

struct DiagnoseOptions {
  int folds = 5;
  std::uint64_t seed = 1;
  double alpha = 0.01;              ///< family-wise error rate of each step's candidate tests (Holm)
  double penalty_per_param = 2.0;   ///< cross-validated gain (whitened SSE) an added parameter must earn
  int max_effects = 4;
  int harmonics = 2;                ///< of the cyclic candidates (the search also tries up to max_order, then picks by CV)
  /// The highest order searched for causes with orders (cyclic harmonics; compliance's degree 1 or 3)
  /// and for the empirical corrections' degree.
  int max_order = 6;
  /// Where structure is left that no cause of the catalog explains, also try empirical corrections
  /// (sim/src/effects/empirical.cpp), selected by cross-validation like the causes, reported as empirical.
  bool empirical = true;
  /// Two significant causes are one set when either, fitted alone, reaches the other's cross-validated
  /// gain to within this fraction: the data cannot tell which it is.
  double confounding_gain_margin = 0.1;
  std::optional<double> sigma_position_m, sigma_rotation_rad;  ///< else estimated from the base fit
  /// Joint readings vs true angles, carried into every R; else (measured data without a covariance
  /// per sample) estimated from the base fit as a third variance component beside the tracker's.
  std::optional<double> joint_noise_sigma_rad;
  /// Cross-validation folds fitted for their parameters alone (FitOptions::analyze off) and every fit's
  /// LM steps from the normal equations: the same decisions, faster. Off only to time the full path (orbcal-bench diagnose --baseline).
  bool lean_fits = true;
  /// Each fold's parameters by one Gauss-Newton step, on the fold's training samples, from the fit of
  /// the model to all the data (approximate leave-group-out cross-validation; Rad and Maleki 2020 give
  /// the leave-one-out case): one fit per model instead of one per fold. A fold's optimum lies within
  /// the noise's share of one fold of the full fit, where one step reaches it to second order; its
  /// held-out residuals are then evaluated exactly. Off: every fold refitted to convergence.
  bool one_step_folds = true;
  /// The noise's variance components, and the flexible fit they are estimated with, from a seeded random
  /// subset of this many observations where there are more (0: every observation). A variance
  /// component's relative standard error is about sqrt(2 / rows): 0.6 % from 20,000 observations of 3
  /// rows each, where a verdict's floor moves by tens of percent; the flexible fit's time grows with its
  /// observations (docs/benchmarks.md). The subset is enlarged to what the most flexible level that every
  /// observation allows needs, and not used where it would leave out a session (diagnose_noise.hpp).
  int noise_observations = 20000;
  /// The selection (forward selection, backward elimination: the score tests and cross-validations that
  /// choose the effects) on a seeded random subset of this many observations where there are more (0:
  /// every observation), the same subset as the noise's where the sizes agree; the selected model is then
  /// fitted, cross-validated and judged (lack of fit, noise floors) on every observation, and so are its
  /// alternatives. What a subset can miss is small and still judged: an effect earns its place when its
  /// cross-validated gain exceeds penalty_per_param per parameter, so one the subset misses moves the
  /// whitened mean square of 20,000 observations (60,000 rows) by less than 2 / 60,000 per parameter,
  /// and whatever it leaves stays in the residuals that the lack-of-fit test reads on every observation.
  int selection_observations = 20000;
  /// Told, on the calling thread, as each phase starts: (k, kDiagnosePhases.size()) before phase k,
  /// then (size, size) when the diagnosis is done. Empty: silent.
  std::function<void(int done, int total)> progress;
};

/// One candidate at one forward step.
struct CandidateResult {
  sim::Effect effect;
  int params = 0;
  int rank = 0;           ///< of its columns beyond the current model's (0: absorbed by it)
  double score = 0;       ///< score statistic (chi-square scale)
  double p_value = 1, p_adjusted = 1;
  bool significant = false;
  std::optional<double> cv_gain;  ///< held-out whitened SSE decrease, where fitted
  int step = 0;
};

struct ConfoundedSet {
  std::vector<sim::Effect> effects;  ///< may hold one effect confounded with the geometry
  bool with_geometry = false;        ///< the geometry/registration absorbs most of it
  /// The measurement that would separate them, with the ranges of their driving variables beyond which
  /// their predictions part (diagnose's model.yaml lists the alternatives; `orbcal evaluate` compares).
  std::string separate_by;
};

/// A model the data cannot tell from the selected one: the selection with one selected effect replaced
/// by another member of its confounded set, fitted on all the data.
struct Alternative {
  std::vector<sim::Effect> effects;
  Fit fit;
};

struct HeldoutStats {
  ResidualStats base, selected;  ///< of the cross-validated held-out residuals
  double noise_position_rms_m = 0;  ///< 3-D position RMS the noise alone gives (LackOfFit)
};

/// The noise of a diagnosis: what every fit whitens with, and the floor the verdict is judged against.
/// The floor may hold joint-reading noise only from a source independent of the residuals it judges:
/// stated (the description's noise.joint_deg, --joint-noise-deg), pure error of repeated
/// configurations, or an estimate that survives a model flexible enough to take smooth structure
/// (the selected model plus, per joint, harmonics, smooth functions of its own angle and torque,
/// couplings to every other joint and its link's bending: diagnose_noise.hpp's flexibleFit), is resolved
/// there (its variance above twice its standard deviation), leaves no structure there (lack_of_fit's
/// variable family) and is not contradicted by the held-out positions (estimate_contradicted). Otherwise
/// an estimated joint noise whitens the fits but stays out of the floor, and the report gives both floors.
struct NoiseFloors {
  MarkerNoise whitening;         ///< as every fit whitens with it
  bool tracker_stated = false;   ///< the tracker's sigmas (or each sample's own covariance) are given
  bool joint_stated = false;     ///< the joint readings' noise is given
  bool joint_estimated = false;  ///< the joint readings' noise is a variance component of the fits
  /// Degree of the flexible model's empirical corrections the noise was estimated with (0: none, the
  /// geometry + registration fit's residuals: too few samples for them).
  int flexible_degree = 0;
  /// The observations the noise was estimated on, where a seeded random subset of them
  /// (DiagnoseOptions::noise_observations); 0: all.
  int noise_observations = 0;
  NoiseComponents components;          ///< of the flexible fit that whitens (where estimated)
  /// The flexible fit's residuals are still structured (lack_of_fit's family): its joint-noise estimate
  /// may be structure it could not take, and stays out of the floor.
  bool flexible_structured = false;
  /// The held-out position residuals contradict the estimated joint noise: with the tracker's noise plus
  /// it, their whitened chi-square (`estimate_chi2`, less the folds' estimation share; chi-square(3 per
  /// sample) under that noise) or their plain mean square (`estimate_ms_m2`; a scaled chi-square about
  /// `estimate_ms_expected_m2`) falls below its lower alpha/2 quantile. Unmodelled structure only raises
  /// both, so a sum too small says the estimate holds more than the positions show (structure elsewhere,
  /// e.g. in the rotations or at other lever arms, that it was stretched to cover).
  bool estimate_contradicted = false;
  double estimate_chi2 = 0.0, estimate_chi2_expected = 0.0;
  double estimate_ms_m2 = 0.0, estimate_ms_expected_m2 = 0.0;
  NoiseComponents survived;            ///< of the selected model + empirical corrections (where estimated)
  double joint_estimate_rad = 0.0;     ///< the joint noise of `survived`
  double joint_floor_rad = 0.0;        ///< the joint noise in the verdict's floor
  std::string joint_source;            ///< "stated", "pure error", "survives", "unstated" (then 0 in the floor)
  /// Held-out position RMS the noise gives (no estimation variance): without any joint noise that is
  /// not stated, and with the estimated one (the same where none is estimated).
  double floor_independent_rms_m = 0.0, floor_with_estimate_rms_m = 0.0;
  /// The joint-reading noise at which the selected model's held-out position residuals would be noise
  /// (0 when the tracker's noise alone covers them).
  double joint_needed_rad = 0.0;
  /// The verdict would differ with the estimated joint noise in the floor, or nothing independent of
  /// the residuals measures the noise (no stated noise, no repeats): the verdict says so, with the plan.
  bool verdict_depends_on_noise = false;
  int duplicates_dropped = 0;  ///< rows that repeat another row exactly (readings and measurement): counted once
  /// The tracker noise `orbcal calibrate --effects <selected>` estimates on every input row (its fit:
  /// position and rotation variance components where not stated; the joint readings as stated, else not
  /// modelled), which the report gives beside the whitening noise. Filled where that can differ from
  /// it: something selected, some noise estimated, no sample with its own covariance. On a long log,
  /// estimated on a seeded random subset as the noise is (DiagnoseOptions::noise_observations).
  std::optional<MarkerNoise> with_selected;
  int with_selected_observations = 0;  ///< the size of that subset; 0: every input row
  /// The verdict's floor is stated, not estimated from the residuals it judges: the tracker's noise (or
  /// each sample's covariance) is given, and the joint readings' part is too or, beside repeated
  /// configurations, not needed (then their scatter, pure error, judges instead).
  bool floorStated() const { return tracker_stated && joint_source != "pure error"; }
};

struct Diagnosis {
  /// Nothing selected and nothing left: the base model's held-out residuals are noise.
  bool clean = true;
  /// The selected model's held-out residuals exceed the noise or are structured (lack_of_fit.left()):
  /// never clean, and with effects selected their explanation is partial.
  bool unexplained = false;
  std::vector<sim::Effect> selected;
  Fit fit;                       ///< the selected model on all the data
  Fit base_fit;                  ///< geometry + registration on all the data
  std::vector<ConfoundedSet> confounded;
  /// Per confounded set of a selected effect, per other member: the alternative model (written beside
  /// model.yaml, so that evaluate says how far their predictions part on new data).
  std::vector<Alternative> alternatives;
  std::vector<CandidateResult> candidates;  ///< every step's tests
  std::vector<VariableTest> evidence;       ///< base model's held-out residuals vs variables
  HeldoutStats heldout;
  double cv_base = 0, cv_selected = 0;      ///< held-out whitened SSE
  /// Held-out residuals (position, m) per sample of the base and the selected model, for figures.
  std::vector<Eigen::VectorXd> residual_base, residual_selected;
  /// The selected model's (the base model's when nothing is selected) held-out residuals against the
  /// noise and the extended variable family (lack_of_fit.hpp).
  LackOfFit lack_of_fit;
  /// Per selected effect (in order), its held-out position mean-square gain (over the model with the
  /// effects before it) as a share of the base model's excess over the noise; filled when unexplained.
  std::vector<double> share_of_excess;
  NoiseFloors noise;                        ///< the whitening noise and the verdict's floor
  /// The observations the selection ran on where a seeded random subset (DiagnoseOptions::
  /// selection_observations; the candidates' score tests and CV gains are theirs), else 0: all of them.
  int selection_observations = 0;
  std::string verdict;                      ///< one sentence a user can act on
  double seconds = 0;
};

/// `data` gives the arm, the sessions and the frame sharing; `observations` the samples (torques filled
/// where compliance candidates need them: calib::observationsFrom(data, true) when the data or the
/// robot's masses allow it).
Diagnosis diagnose(const sim::MeasuredData& data, const std::vector<MarkerObservation>& observations,
                   const DiagnoseOptions& options);

/// The verdict's account of what the selected model leaves (lack_of_fit): how far its held-out position
/// RMS stands above the noise, the share of each named cause in the base model's excess, and the
/// variables the rest is structured against. Empty when nothing is left.
std::string unexplainedSentence(const Diagnosis& d);

/// The survival function of the chi-square distribution with k degrees of freedom: P(X > x).
double chiSquareSurvival(double x, double k);
/// The survival function of the F distribution F(d1, d2): P(X > f).
double fSurvival(double f, double d1, double d2);
/// Student's t critical value: the t > 0 with P(|T| > t) = two_sided_alpha for `dof` degrees of freedom
/// (e.g. 2.228 for 0.05 and 10): the half-width of a confidence interval in standard errors.
double studentTCritical(double two_sided_alpha, double dof);
/// Holm's step-down adjusted p-values (family-wise error control), same order as the input.
std::vector<double> holmAdjust(const std::vector<double>& p);

/// "compliance of joint 2", "thermal expansion", ... (people's words for an effect).
std::string describeEffect(const sim::Effect& e);

}  // namespace orbcal::calib
