#pragma once
// Calibration levels: which geometric parameters a calibration of measured data frees. Users of motion-
// capture and tracker data compare three nested sets; with few configurations and much noise the smaller
// set can predict unseen poses better than the full one, whose extra parameters then fit the noise.
//
//   frames   the registration frames only (the nominal geometry is kept)
//   offsets  the joints' zero offsets (theta_i) + the frames
//   full     every parameter the data identifies
//   a list   the named geometric parameters (sim::ParamLayout names: theta1,theta3,d2) + the frames
//
// Effects (--effects) are free at every level. A level is a set of held parameters (FitOptions::hold):
// the estimator is the same. `auto` picks the level by cross-validation by configuration on the training
// data (calib/heldout.hpp's folds and fits), the one whose held-out position RMS is smallest.
#include <cstdint>
#include <string>
#include <vector>

#include "orbcal/calib/heldout.hpp"
#include "orbcal/calib/measured_fit.hpp"
#include "orbcal/sim/measured.hpp"

namespace orbcal::calib {

enum class LevelKind { kAuto, kFrames, kOffsets, kFull, kList };

struct Level {
  LevelKind kind = LevelKind::kAuto;
  std::vector<std::string> names;  ///< kList: the free geometric parameters' names
};

/// Reads "auto", "frames", "offsets", "full" or a comma-separated list of parameter names; InputError
/// naming `what` (e.g. "--level") for an empty text or an empty name in a list.
Level parseLevel(const std::string& text, const std::string& what);
/// "auto", "frames", "offsets", "full", or the list as given ("theta1,theta3,d2").
std::string levelName(const Level& level);

/// The parameters of `model` a (non-auto) level holds at their start: the geometric ones it does not
/// free, sorted. InputError naming `what` for a listed name that is not a parameter of the model.
std::vector<int> levelHold(const sim::KinematicModel& model, const Level& level, const std::string& what);

/// The number of folds of the level choice (diagnose's default), and the fewest configurations it is
/// made on: two per fold, so that every fold holds out more than one configuration and its training
/// set keeps four fifths of them to fix the frames.
constexpr int kLevelFolds = 5;
constexpr int kMinLevelConfigurations = 2 * kLevelFolds;

struct LevelScore {
  Level level;
  double heldout_rms_m = 0.0;  ///< cross-validated held-out position RMS
  int free = 0;                ///< parameters the level leaves free
};

struct LevelChoice {
  Level chosen;                    ///< never kAuto
  std::vector<LevelScore> scores;  ///< frames, offsets, full (empty when `chosen` was asked for)
  int folds = 0, configurations = 0;
  bool asked = false;              ///< the level was given, not chosen
};

/// Scores frames, offsets and full (with `effects`) by cross-validation by configuration of
/// `observations` (kLevelFolds folds, seeded) and chooses the one of the smallest held-out position RMS
/// (the smaller level on a tie). `options` as the calibration uses them (hold is replaced by each
/// level's); noise not given is estimated once from the full fit. With fewer than
/// kMinLevelConfigurations configurations: full, without scores.
LevelChoice chooseLevel(const sim::MeasuredData& data, const std::vector<MarkerObservation>& observations,
                        const std::vector<sim::Effect>& effects, FitOptions options, std::uint64_t seed);

/// The choice of a given level: `level` itself, or chooseLevel's where it is auto.
LevelChoice resolveLevel(const Level& level, const sim::MeasuredData& data, const std::vector<MarkerObservation>& observations,
                         const std::vector<sim::Effect>& effects, const FitOptions& options, std::uint64_t seed);

/// One sentence for the terminal and the report: "level offsets (chosen by 5-fold cross-validation on 30
/// configurations: held-out position RMS frames 2.104 mm, offsets 0.512 mm, full 0.655 mm)", or "level
/// frames (as asked)".
std::string levelSentence(const LevelChoice& choice);

}  // namespace orbcal::calib
