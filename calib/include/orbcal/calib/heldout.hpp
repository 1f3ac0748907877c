#pragma once
// Held-out validation of measured data, one way for every path (`orbcal calibrate DESC.yaml`'s hold-out,
// `orbcal diagnose`'s cross-validation folds):
//
//  1. The split is by configuration: every measurement of one configuration (same session, every joint
//     reading within kSameConfigurationRad; configurationGroups) lands on the same side, so a row
//     repeated in the file can never be fitted and "predicted" at once.
//  2. A calibration is accepted on held-out data only when at least kMinHeldoutConfigurations
//     configurations are held out and its gain over the nominal arm is significant against the scatter
//     of the held-out errors: a one-sided paired test of the per-configuration loss differentials
//     d_g = |r_nominal|^2 - |r_calibrated|^2 (position, m^2, averaged over the rows of configuration g),
//     t = mean(d) / (sd(d) / sqrt(G)) against Student's t with G - 1 degrees of freedom (Diebold and
//     Mariano 1995), at the significance level diagnose's tests use (0.01).
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "orbcal/calib/marker_model.hpp"
#include "orbcal/calib/measured_fit.hpp"

namespace orbcal::calib {

/// Two readings of one joint closer than this are one configuration (rad; m for a prismatic reading):
/// copies and re-reads of one pose agree to the encoder's last digits, and 1e-6 rad moves a marker 1 m
/// out by 1 um, below any tracker's noise, so nothing can be learnt from one that the other lacks.
constexpr double kSameConfigurationRad = 1e-6;

/// At least this many held-out configurations: the paired test's scatter is then estimated with 9 or
/// more degrees of freedom (Student's one-sided 1 % point 2.82 against 2.33 for infinitely many), and a
/// mean of squared-error differences, skewed as they are, is near enough to normal only from about ten.
constexpr int kMinHeldoutConfigurations = 10;

/// The significance level of the held-out gain test (the level of diagnose's tests).
constexpr double kHeldoutGainAlpha = 0.01;

/// The share of the configurations held out when none is given: 20 % (Wang et al. 2023 validate on a
/// separate fifth), raised to kMinHeldoutConfigurations where that still leaves at least as many to fit
/// (20 to 50 configurations hold out 10: a 40-image dataset is judged on 10, not 8). Fewer than
/// 2 kMinHeldoutConfigurations configurations keep 20 %, and the refusal says how many to measure.
constexpr double kDefaultHoldoutShare = 0.2;
double defaultHoldout(int configurations);

/// Configurations (replicate groups): observations of one session whose joint readings all agree within
/// kSameConfigurationRad, joined transitively (single linkage), keyed by (session, the readings of the
/// group's first observation in nrad), members in index order. Every split, the pure error and the
/// group means of diagnose's evidence use these.
std::map<std::vector<long long>, std::vector<int>> configurationGroups(const std::vector<MarkerObservation>& obs);

/// The one split of measured samples into parts (cross-validation folds, or fitted | held out): each
/// configuration goes whole to one part. The configurations are shuffled per session (seeded) and dealt,
/// session after session, each to the part furthest below its share of those dealt so far (the lowest
/// part on a tie): equal shares deal round-robin, and every part gets its share of every session to one
/// configuration. `shares` > 0 (normalised here). Returns the part of each observation.
std::vector<int> splitByConfiguration(const std::vector<MarkerObservation>& obs, const std::vector<double>& shares,
                                      std::uint64_t seed);

/// A share to hold out outside [0, 1): InputError naming --holdout (checked before any work).
void checkHoldout(std::optional<double> holdout);

/// The one fitted | held-out split of every calibration (images and measured data): splitByConfiguration
/// with shares {1 - h, h}, h = `holdout` or, when empty, defaultHoldout(countConfigurations(obs)); h = 0
/// fits everything. Returns 1 for each held-out observation, 0 for each fitted one. A share outside
/// [0, 1): InputError naming --holdout.
std::vector<int> holdoutSplit(const std::vector<MarkerObservation>& obs, std::optional<double> holdout, std::uint64_t seed);

/// The number of configurations among `obs` (configurationGroups).
int countConfigurations(const std::vector<MarkerObservation>& obs);

/// Held-out residuals of every observation by cross-validation: each fold's model is fitted to the other
/// folds (FitOptions as given, its hold included) and predicts the fold's observations.
struct CrossValidation {
  double sse = 0.0;                       ///< held-out whitened SSE (each fold's fitted noise)
  std::vector<Eigen::VectorXd> residual;  ///< held-out residual per observation ([position; rotation] or [position])
  double effective_parameters = 0.0;      ///< the folds' mean Fit::effective_parameters
};
/// `fold`: the fold of each observation, 0..folds-1 (splitByConfiguration); `start(train)`: the starting
/// model of a fold's training observations, every fold's with the same layout; `p0`: the starting
/// parameters of every fold (empty: zero). The folds are fitted in parallel. A fold without observations
/// is skipped.
CrossValidation crossValidateFits(const std::vector<MarkerObservation>& obs, const std::vector<int>& fold, int folds,
                                  const std::function<sim::KinematicModel(const std::vector<MarkerObservation>&)>& start,
                                  const FitOptions& options, const Eigen::VectorXd& p0 = {});

/// Position loss |r_pos|^2 (m^2) of each configuration of `obs` (configurationGroups' order), averaged
/// over its rows: the unit of every paired comparison of held-out errors.
std::vector<double> configurationLosses(const std::vector<MarkerObservation>& obs, const std::vector<Eigen::VectorXd>& residual);

/// The held-out gain of a calibrated model over the nominal arm (registration fitted) and its test.
/// Camera views (calib/hand_eye.hpp) are judged by the same test: the corner fit against the closed form
/// it starts from, each view's residual its RMS corner distance (a 1-vector, m).
struct HeldoutGain {
  std::string reference = "the nominal arm";  ///< what the calibrated model is compared with, for the sentences
  int configurations = 0;          ///< held out (cross-validated: all, each predicted once)
  bool cross_validated = false;    ///< by crossValidatedVerdict: every configuration predicted by a fit without it
  double before_rms_m = 0.0;       ///< position RMS over the held-out rows: nominal arm
  double after_rms_m = 0.0;        ///< calibrated
  double t = 0.0;                  ///< the paired statistic (0 with fewer than two configurations)
  double p_value = 1.0;            ///< one-sided: P(T > t) under "no gain"
  bool enough = false;             ///< configurations >= kMinHeldoutConfigurations
  bool significant = false;        ///< enough and p_value < kHeldoutGainAlpha
};

/// The test above on held-out observations `obs` and their residuals ([position; rotation] or
/// [position]) under the nominal arm (`before`) and the calibrated model (`after`).
HeldoutGain heldoutGain(const std::vector<MarkerObservation>& obs, const std::vector<Eigen::VectorXd>& before,
                        const std::vector<Eigen::VectorXd>& after);
/// The same on items grouped by configuration (`groups`: the items of each, indices into before / after);
/// an item's loss is the squared norm of its residual's first (up to) 3 components (m^2).
HeldoutGain heldoutGain(const std::vector<std::vector<int>>& groups, const std::vector<Eigen::VectorXd>& before,
                        const std::vector<Eigen::VectorXd>& after);

/// Why a gain is not accepted, one sentence a user can act on ("only 3 configurations held out, ...");
/// empty when it is significant. `holdout`: the fraction held out, for the advice, or empty where it
/// was defaultHoldout's; `total`: the configurations in all.
std::string heldoutRefusal(const HeldoutGain& g, std::optional<double> holdout, int total);

/// The test in one sentence, for reports: "12 held-out configurations; the gain over the nominal arm,
/// one-sided paired test of their squared position errors: t = 4.10, p = 0.00088 (accepted at p < 0.01
/// with at least 10 configurations)".
std::string formatHeldoutGain(const HeldoutGain& g);

/// The one rule by which a calibration is accepted on held-out data, whatever the data (camera poses
/// from images, tracker poses or positions): its gain over the nominal arm (heldoutGain) must be
/// significant on at least kMinHeldoutConfigurations configurations. A calibration that predicts them
/// worse is refused as such; too few configurations say nothing either way, and that alone is said.
struct HeldoutVerdict {
  HeldoutGain gain;
  bool worse = false;   ///< the calibrated model's held-out position RMS exceeds the nominal arm's
  std::string refusal;  ///< one sentence a user can act on; empty: accepted
};
/// `held`: the held-out observations with their residuals under the nominal arm (`before`, its frames
/// as the path takes them: known, or fitted with the nominal geometry) and the calibrated model
/// (`after`); `holdout` and `total` as heldoutRefusal takes them.
HeldoutVerdict heldoutVerdict(const std::vector<MarkerObservation>& held, const std::vector<Eigen::VectorXd>& before,
                              const std::vector<Eigen::VectorXd>& after, std::optional<double> holdout, int total);

/// A set too small for a held-out split is judged by cross-validation over all of its configurations:
/// with the hold-out left to its default (none given), fewer than 2 kMinHeldoutConfigurations
/// configurations would hold out fewer than kMinHeldoutConfigurations.
bool judgeByCrossValidation(int configurations, std::optional<double> holdout);

/// One fold of a cross-validated judgement: the residuals of the observations `test` (indices into the
/// set, in order) under the nominal arm and the calibrated model, both fitted to `train` alone (the
/// nominal arm's frames included), whatever the data (camera poses from images, tracker poses).
struct FoldPrediction {
  std::vector<Eigen::VectorXd> before, after;
};
using FoldPredictor = std::function<FoldPrediction(const std::vector<int>& train, const std::vector<int>& test)>;

/// The held-out rule (heldoutVerdict: the paired one-sided test of per-configuration squared errors,
/// nominal vs calibrated, at least kMinHeldoutConfigurations) on residuals that no fit saw: leave one
/// configuration out, every configuration predicted once by `predict` fitted to all the others (the
/// folds in parallel). Fewer than kMinHeldoutConfigurations configurations in all are refused unfitted:
/// cross-validation cannot justify them either. `before` and `after` (when given) get every
/// observation's cross-validated residuals.
HeldoutVerdict crossValidatedVerdict(const std::vector<MarkerObservation>& obs, const FoldPredictor& predict,
                                     std::vector<Eigen::VectorXd>* before = nullptr, std::vector<Eigen::VectorXd>* after = nullptr);
/// The same judge on any items (measured observations above; camera views, calib/hand_eye.hpp), grouped
/// by `configuration` (each item's, 0..G-1): every configuration held out once, the folds in parallel.
/// `reference`: what `before` predicts with, named in the sentences ("the nominal arm").
HeldoutVerdict crossValidatedVerdict(const std::vector<int>& configuration, const FoldPredictor& predict, const std::string& reference,
                                     std::vector<Eigen::VectorXd>* before = nullptr, std::vector<Eigen::VectorXd>* after = nullptr);

}  // namespace orbcal::calib
