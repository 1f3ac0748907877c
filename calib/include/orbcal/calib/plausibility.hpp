#pragma once
// Physical plausibility of a fit of measured data: what no real arm and instrument can show, checked on
// every fit `calibrate`, `diagnose` and `evaluate` make, whether the noise is stated or estimated. Data
// read in the wrong unit or convention (metres declared mm, radians declared deg, a quaternion stored
// x, y, z, w where the description says w, x, y, z) or with the wrong robot file fits badly or bends
// the arm out of shape; a fit never passes that off as a calibration.
//
//  1. The registration residual: the nominal arm with only the unknown frames fitted (or a calibrated
//     model predicting the data). An uncalibrated arm misses its nominal poses by its joint zero
//     offsets and link tolerances times its lever arms: a few millimetres on arms of 1 to 2 m reach
//     (e.g. Nubiola and Bonev 2013, an ABB IRB 1600) and well under a degree in orientation. The
//     bounds are 5 % of the arm's reach in position RMS (an angle error of 3 degrees over the whole
//     arm; 63 mm on the iiwa7's 1.27 m) and 5 degrees in rotation RMS; they scale with the reach
//     because angle errors do.
//  2. The calibrated geometry: a length parameter (a, d; a URDF origin's x, y, z) that moves by more
//     than 5 % of its link's nominal length, or by more than 1 % of the reach where that is more (a
//     link of nominal length 0 still has a tolerance), and an angle parameter (theta, alpha, beta,
//     roll, pitch, yaw) that moves by more than 10 degrees, describe an arm built far from its drawing:
//     refused where the data pin the move down, beyond its bound by more than 3 of its 1-sigma. A
//     parameter the data barely determine (real data where only some joints move) wanders along what
//     the data cannot see, and the report names it as weak; that is no sign of a wrong unit.
//
// A refusal is one InputError line naming the description, what exceeded which bound, the likely
// causes (length unit, angle unit, quaternion order, joint order or sign, wrong robot file), and what
// fits better: the nominal arm's registration with each other reading tried (the other length unit,
// the other angle unit, the quaternion read x, y, z, w), e.g. "with pose.length_unit: m the nominal
// arm's registration residual is 0.082 mm RMS".
#include <string>
#include <vector>

#include "orbcal/calib/measured_fit.hpp"

namespace orbcal::calib {

struct PlausibilityBounds {
  double reach_m = 0.0;            ///< sim::characteristicLength of the arm
  double position_rms_m = 0.0;     ///< registration residual, 3-D position RMS: 5 % of the reach
  double rotation_rms_rad = 0.0;   ///< registration residual, rotation RMS: 5 deg
  double angle_move_rad = 0.0;     ///< an angle parameter's move: 10 deg
  /// A length parameter's move: max(5 % of its link's nominal length, 1 % of the reach); `param` is a
  /// geometry parameter of `arm` (sim::geometryBlock), whose joint names the link.
  double lengthMove(const sim::Arm& arm, const sim::ParamInfo& param) const;
};
PlausibilityBounds plausibilityBounds(const sim::Arm& arm);

/// The registration alone: the unknown frames of `start` (base, marker and mount blocks) fitted, every
/// geometric and effect parameter held at its start (`options.hold` gets them).
Fit fitRegistration(const sim::KinematicModel& start, const std::vector<MarkerObservation>& obs, FitOptions options);

/// The nominal arm's registration on `data` (startingModel without effects, then fitRegistration with
/// the description's noise, or estimated): its residual statistics.
ResidualStats nominalRegistration(const sim::MeasuredData& data);

/// Throws InputError when `residuals` exceed the bounds of `data`'s arm. `what` names them, e.g. "the
/// nominal arm's registration residual", "the prediction residual of model.yaml".
void requirePlausibleResidual(const sim::MeasuredData& data, const ResidualStats& residuals, const std::string& what);

/// How far a fit's position RMS may lie above the least-squares fit's (LM) of the same model on the same
/// samples: a robust loss or a prior moves it by tens of percent on data the model holds, while an
/// estimator that stopped short of the fit (a linearized EKF with a tight prior, far from the data)
/// stays where it started, orders of magnitude above.
constexpr double kFarAboveLeastSquares = 2.0;

/// Why `fit` (of `observations` with `options`) is refused on its own samples, whatever part of the data
/// is held out (--holdout 0 too); empty when it is not. Its position residual RMS is compared with the
/// least-squares fit's (refitted here with LM unless options.method is LM): more than
/// kFarAboveLeastSquares times it, the residuals are far above the noise and what the model cannot hold,
/// and the estimate is not a calibration. One sentence naming both figures and the way out.
std::string fitRefusal(const Fit& fit, const std::vector<MarkerObservation>& observations, const FitOptions& options);

/// Throws InputError when a geometric parameter of `fit` (a fit of `data` started at its nominal arm)
/// moved beyond its bound by more than 3 of its 1-sigma (the fit's covariance; 0 without one).
void requirePlausibleGeometry(const sim::MeasuredData& data, const Fit& fit);

/// The end of every refusal above: "; likely causes: ...; with ... the nominal arm's registration
/// residual is ...". Tries the other readings of `data` (nominalRegistration of each).
std::string likelyCauses(const sim::MeasuredData& data);

}  // namespace orbcal::calib
