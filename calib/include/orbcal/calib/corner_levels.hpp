#pragma once
// The calibration levels (calib/levels.hpp: offsets, map, full, a list) on the corners of image views
// with joint readings: the robot's kinematic parameters fitted to every detected corner through the
// corner measurement model (calib/corner_model.hpp), whose chain is the hand-eye chain of
// calib/hand_eye.hpp as a sim::KinematicModel:
//   eye in hand: world = the board,  marker = the camera (world_T_base = board_T_base);
//   eye to hand: world = the camera, marker = the board  (world_T_base = camera_T_base).
// The frames start from a hand-eye fit (HandEyeFrames: X = world_T_base, Z = flange_T_marker) at the
// nominal arm; a level is a set of held parameters and, for map, the evidence-scaled prior: the same
// FitOptions, FitControls and estimator (runMethod) as measured data (measured_fit.hpp's
// fitControls). The lens is the camera file's: the distortion block is held.
//
// The judge is that of every small set: leave one configuration out (calib::crossValidatedVerdict),
// each configuration predicted by the level fitted to the others against the frames level fitted to the
// same others (a view's loss: its squared RMS corner distance, calib::viewResidual's mm): a level
// is accepted when it predicts the views significantly better than the frames level.
#include <Eigen/Geometry>
#include <vector>

#include "orbcal/calib/corner_model.hpp"
#include "orbcal/calib/hand_eye.hpp"
#include "orbcal/calib/levels.hpp"
#include "orbcal/calib/measured_fit.hpp"

namespace orbcal::calib {

/// The hand-eye chain of `setup` as a kinematic model of `arm` (one session, both frames estimated),
/// starting at `frames`.
sim::KinematicModel handEyeChainModel(const sim::Arm& arm, const HandEyeFrames& frames);

/// The corner observations of `views` at their joint readings (samples[k]: view k's).
std::vector<CornerObservation> cornerObservations(const std::vector<HandEyeView>& views, const std::vector<sim::JointSample>& samples);

struct CornerLevelFit {
  sim::KinematicModel start;  ///< the chain at the nominal arm and the starting frames
  Eigen::VectorXd p;          ///< fitted: the chain's parameters, then the (held) distortion block
  Estimate estimate;          ///< y = p, its covariance (pixel sigma as below), the held parameters
  double sigma_px = 0.0;      ///< re-estimated from the residuals: sqrt(SSE / dof) per coordinate
  double rms_px = 0.0;        ///< fitted residual RMS per coordinate
  int rows = 0;
  double effective_parameters = 0.0;  ///< free parameters, or map's effective number
  HandEyeFrames frames;       ///< the fitted frames (X, Z) of the fitted arm
  sim::Arm arm;               ///< the nominal arm with the fitted geometric errors
};

/// The level's fit (options: levelOptions applied; `analyze` false skips the covariance) of the
/// observations `which` (all when empty), from `start`.
CornerLevelFit fitCornerLevel(const sim::KinematicModel& start, const sim::Camera& camera, const sim::Board& board,
                              sim::HandEyeSetup setup, const std::vector<CornerObservation>& observations, const FitOptions& options,
                              const std::vector<int>& which = {});

/// Observation k's residuals under a level's fit, as calib::viewResidual measures them.
ViewResidual cornerViewResidual(const CornerLevelFit& fit, const sim::Camera& camera, const sim::Board& board, sim::HandEyeSetup setup,
                                const CornerObservation& observation);

/// A level judged by leave-one-configuration-out cross-validation against the frames level
/// (`frames_cv`: crossValidateHandEye's folds, whose refits start each fold of the level).
struct CornerLevelCrossValidation {
  Level level;
  std::vector<ViewResidual> heldout;   ///< per view: the level fitted without its configuration
  std::vector<HandEyeFrames> refits;   ///< per configuration held out (the jackknife of the frames)
  std::vector<Eigen::VectorXd> refit_p;  ///< their parameters (the jackknife of the robot's)
  HeldoutVerdict verdict;              ///< against the frames level
  double heldout_rms_m = 0.0;          ///< RMS over the views of their held-out mm residual (m)
};
CornerLevelCrossValidation crossValidateCornerLevel(const std::vector<HandEyeView>& views, const std::vector<CornerObservation>& observations,
                                                    const sim::Arm& arm, const sim::Camera& camera, const sim::Board& board,
                                                    sim::HandEyeSetup setup, const Level& level, const FitOptions& options,
                                                    const HandEyeCrossValidation& frames_cv);

/// The jackknife 1-sigma of each parameter from G leave-one-out refits (hand_eye.hpp's formula).
Eigen::VectorXd jackknifeSigma(const std::vector<Eigen::VectorXd>& refits);

}  // namespace orbcal::calib
