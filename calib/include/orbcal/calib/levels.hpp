#pragma once
// Calibration levels: which geometric parameters a calibration of measured data frees, and how. Users of
// motion-capture and tracker data compare nested sets; with few configurations and much noise the
// smaller set can predict unseen poses better than the full one, whose extra parameters then fit the noise.
//
//   frames   the registration frames only (the nominal geometry is kept)
//   offsets  the joints' zero offsets (theta_i) + the frames
//   map      every parameter, the geometry shrunk toward the nominal arm by a prior of the layout's
//            typical sizes whose strength the data set (FitOptions::map: the maximum a-posteriori fit,
//            ridge regression as geodesy and robot calibration regularize small data sets); its
//            effective number of parameters lies between the frames' and the full set's
//   full     every parameter the data identifies
//   a list   the named geometric parameters (sim::ParamLayout names: theta1,theta3,d2) + the frames
//
// Effects (--effects) are free at every level. A level is a set of held parameters (FitOptions::hold)
// and, for map, the prior (FitOptions::map): the estimator is the same. `auto` picks the level by
// repeated cross-validation by configuration on the training data (calib/heldout.hpp's folds and fits):
// map, unless the level whose held-out position RMS over kLevelRepeats differently seeded fold splits is
// smallest predicts significantly better; it says how sure that is (the share of the repeats each level
// wins, and the paired comparison of the chosen level with the other over the configurations).
#include <cstdint>
#include <string>
#include <vector>

#include "orbcal/calib/heldout.hpp"
#include "orbcal/calib/measured_fit.hpp"
#include "orbcal/sim/measured.hpp"

namespace orbcal::calib {

enum class LevelKind { kAuto, kFrames, kOffsets, kMap, kFull, kList };

struct Level {
  LevelKind kind = LevelKind::kAuto;
  std::vector<std::string> names;  ///< kList: the free geometric parameters' names
};

/// Reads "auto", "frames", "offsets", "map", "full" or a comma-separated list of parameter names; InputError
/// naming `what` (e.g. "--level") for an empty text or an empty name in a list.
Level parseLevel(const std::string& text, const std::string& what);
/// "auto", "frames", "offsets", "map", "full", or the list as given ("theta1,theta3,d2").
std::string levelName(const Level& level);

/// The parameters of `model` a (non-auto) level holds at their start: the geometric ones it does not
/// free, sorted. InputError naming `what` for a listed name that is not a parameter of the model.
std::vector<int> levelHold(const sim::KinematicModel& model, const Level& level, const std::string& what);
/// `options` with a (non-auto) level applied: its hold (levelHold) and, for map, FitOptions::map.
FitOptions levelOptions(FitOptions options, const sim::KinematicModel& model, const Level& level, const std::string& what);

/// The number of folds of the level choice (diagnose's default), how often it is repeated with other
/// seeds, and the fewest configurations it is made on: two per fold, so that every fold holds out more
/// than one configuration and its training set keeps four fifths of them to fix the frames.
constexpr int kLevelFolds = 5;
constexpr int kLevelRepeats = 8;
constexpr int kMinLevelConfigurations = 2 * kLevelFolds;

struct LevelScore {
  Level level;
  double heldout_rms_m = 0.0;  ///< cross-validated held-out position RMS, pooled over the repeats
  int free = 0;                ///< parameters the level leaves free
  double effective = 0.0;      ///< map: the folds' mean effective number of parameters; else `free`
  int wins = 0;                ///< repeats in which this level predicted best
};

struct LevelChoice {
  Level chosen;                    ///< never kAuto
  std::vector<LevelScore> scores;  ///< frames, offsets, map, full (empty when `chosen` was asked for)
  int folds = 0, repeats = 0, configurations = 0;
  bool asked = false;              ///< the level was given, not chosen
  /// The chosen level against the one it was chosen over (map against the best of the others; another
  /// level against map): per configuration, that level's held-out squared position error minus the
  /// chosen one's (averaged over the repeats): its mean (m^2), standard error, t = mean / se and the
  /// one-sided p of the paired test.
  std::string runner_up;
  double margin_m2 = 0.0, margin_se_m2 = 0.0, margin_t = 0.0, margin_p = 1.0;
};

/// Scores frames, offsets, map and full (with `effects`) by cross-validation by configuration of
/// `observations`, kLevelFolds folds, repeated kLevelRepeats times with seeds derived from `seed`, and
/// chooses map, whose shrinkage the data already set, unless the level of the smallest held-out
/// position RMS pooled over the repeats predicts significantly better than map (the held-out rule's
/// paired one-sided test of the per-configuration squared errors at kHeldoutGainAlpha): on 37 noisy
/// configurations the cross-validated RMS of the levels differ by chance as much as by merit. `options` as the calibration uses them (hold and map are replaced by each level's); noise not
/// given is estimated once from the full fit. With fewer than kMinLevelConfigurations configurations:
/// full, without scores.
LevelChoice chooseLevel(const sim::MeasuredData& data, const std::vector<MarkerObservation>& observations,
                        const std::vector<sim::Effect>& effects, FitOptions options, std::uint64_t seed);

/// The choice of a given level: `level` itself, or chooseLevel's where it is auto.
LevelChoice resolveLevel(const Level& level, const sim::MeasuredData& data, const std::vector<MarkerObservation>& observations,
                         const std::vector<sim::Effect>& effects, const FitOptions& options, std::uint64_t seed);

/// One sentence for the terminal and the report: "level map (chosen by 5-fold cross-validation repeated 8
/// times on 37 configurations: held-out position RMS frames 2.104 mm (12 free), offsets 0.512 mm (20
/// free), map 0.498 mm (44 free, 17.3 effective), full 0.655 mm (44 free); map predicted best in 6 of
/// the 8 repeats, offsets in 2; against the runner-up offsets, its held-out squared error per
/// configuration is lower by 0.012 +- 0.005 mm^2, t = 2.4)", or "level frames (as asked)".
std::string levelSentence(const LevelChoice& choice);

}  // namespace orbcal::calib
