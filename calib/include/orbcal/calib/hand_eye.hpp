#pragma once
// Hand-eye calibration on the corners of real images: the two frames that close the chain from the
// arm's flange poses to the board's corners seen by the camera, with no robot model beyond the flange
// poses (given by the controller, or the nominal arm's at the joint readings).
//
// The chain is the registration chain of measured data (calib/registration.hpp), with
//   eye in hand (camera on the flange, board fixed): world = board,  marker = camera,
//       board_T_camera_k = board_T_base * base_T_flange_k * flange_T_camera;
//   eye to hand (camera fixed, board on the flange):  world = camera, marker = board,
//       camera_T_board_k = camera_T_base * base_T_flange_k * flange_T_board.
// X = world_T_base and Z = flange_T_marker are the unknowns. The start is closed-form: Shah's (2013)
// robot-world / hand-eye rotations (OpenCV's calibrateRobotWorldHandEye) and least-squares
// translations (calib::initialRegistration) on each view's own board pose (PnP). The fit then
// minimises the corner reprojection error over all views (Levenberg-Marquardt on the 12 corrections
// X = X0 exp(dx), Z = Z0 exp(dz), sim::posePlus; central-difference Jacobian):
//   nu_k,i = uv_k,i - project(camera, camera_T_board_k(X, Z) P_i),   P_i = sim::cornerInBoard(board, id).
//
// Uncertainty: a robot's pose error moves all corners of a view together, so the corner residuals are
// not independent and the Gauss-Newton covariance is too small; the frames' 1-sigma is the jackknife
// over the configurations (leave one out; Efron and Stein 1981): var = (G - 1) / G * sum (theta_g -
// mean)^2 of the refits, per axis of the frame's parent (jackknifeSigma).
#include <Eigen/Geometry>
#include <array>
#include <string>
#include <vector>

#include "orbcal/calib/heldout.hpp"
#include "orbcal/sim/image_views.hpp"
#include "orbcal/sim/scene.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::calib {

/// One view: the flange pose, the detected corners (by identity) and the view's own board pose.
struct HandEyeView {
  Eigen::Isometry3d base_T_flange = Eigen::Isometry3d::Identity();
  std::vector<Eigen::Vector2d> corners_px;
  std::vector<int> ids;                    ///< inner corner of each of corners_px (sim::cornerInBoard)
  Eigen::Isometry3d camera_T_board = Eigen::Isometry3d::Identity();  ///< PnP of this view alone
  double pnp_sigma_px = 0.0;               ///< that PnP's residual sigma per coordinate (vision::BoardPose)
};

/// The two frames: X = world_T_base, Z = flange_T_marker (names by setup in the file comment).
struct HandEyeFrames {
  Eigen::Isometry3d world_T_base = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d flange_T_marker = Eigen::Isometry3d::Identity();
};

/// camera_T_board of view `base_T_flange` under `frames` and `setup`.
Eigen::Isometry3d predictedCameraTBoard(const HandEyeFrames& frames, const Eigen::Isometry3d& base_T_flange, sim::HandEyeSetup setup);

/// The closed-form start (file comment). std::invalid_argument on fewer than 3 views or flange
/// rotations about fewer than two axes.
HandEyeFrames closedFormHandEye(const std::vector<HandEyeView>& views, sim::HandEyeSetup setup);

struct HandEyeFit {
  HandEyeFrames frames;
  /// With the lens fitted: the radial distortion (k1, k2) added to the stated camera's, which the
  /// corners show beyond it (the stated intrinsics' k1, k2 held otherwise: zero).
  bool lens_fitted = false;
  Eigen::Vector2d lens_k = Eigen::Vector2d::Zero();
  double rms_px = 0.0;        ///< over every corner coordinate
  int corners = 0;            ///< detected corners used
  int iterations = 0;
  bool converged = false;
};

/// The corner-level fit from `start` on the views `which` (all when empty); with fit_lens the camera's
/// radial distortion k1, k2 too (two more parameters, added to the stated ones: a lens the stated
/// intrinsics miss moves every view's outer corners alike, which the frames alone absorb wrongly).
HandEyeFit fitHandEyeCorners(const std::vector<HandEyeView>& views, const sim::Camera& camera, const sim::Board& board,
                             sim::HandEyeSetup setup, const HandEyeFrames& start, const std::vector<int>& which = {},
                             bool fit_lens = false);
/// `camera` with `lens_k` added to its k1, k2.
sim::Camera withLens(const sim::Camera& camera, const Eigen::Vector2d& lens_k);

/// A view's residuals under `frames`: the RMS over its corner coordinates of the reprojection residual
/// (px), and the RMS over its corners of the residual's length carried to the corner's distance,
/// |nu_i| z_i / sqrt(fx fy) (m: how far from the corner, across the line of sight, the chain puts it).
struct ViewResidual {
  double rms_px = 0.0;  ///< per coordinate
  double rms_m = 0.0;   ///< per corner (a distance)
};
ViewResidual viewResidual(const HandEyeView& view, const HandEyeFrames& frames, const sim::Camera& camera, const sim::Board& board,
                          sim::HandEyeSetup setup);
/// The same for corners `corners_px` of identities `ids` seen at a given camera_T_board (any chain's).
ViewResidual viewResidual(const std::vector<Eigen::Vector2d>& corners_px, const std::vector<int>& ids, const Eigen::Isometry3d& camera_T_board,
                          const sim::Camera& camera, const sim::Board& board);

/// Configurations of the views: views whose flange poses agree within 1 um and 1 urad are one (a row
/// repeated in the file), numbered from 0 in the order of their first view.
std::vector<int> viewConfigurations(const std::vector<HandEyeView>& views);

/// A board that is the same after a half turn (sim::halfTurnSymmetric: circle grids) is detected in an
/// order that may be turned by half a turn (vision/circles.hpp); the flange motions tell. The relative
/// motion of two views, A = base_T_flange_i^-1 base_T_flange_j, and the camera's (eye in hand,
/// P_i P_j^-1, P = camera_T_board) or the board's (eye to hand, P_i^-1 P_j) are conjugate (A Z = Z B),
/// so they share their rotation angle and their translation along the rotation axis; one view turned
/// (P_j sim::halfTurn) changes both. halfTurnDisagreements: per pair (i, j) (index i n + j), the
/// disagreement |angle_A - angle_B| + 1 rad/m | |t_A . axis_A| - |t_B . axis_B| | with neither view turned
/// [0] or one of them [1]. resolveHalfTurns labels the views so that the sum over all pairs is least
/// (each view tried as the reference that labels the others), keeps the orientation most views were
/// detected in, and turns the others: ids k -> numCorners() - 1 - k and camera_T_board * halfTurn. A view
/// whose median disagreement with the others is not below half the median in its other orientation is
/// ambiguous (its order cannot be told; the caller leaves it out). Nothing changes for a board without
/// the symmetry or fewer than 3 views.
struct HalfTurnResolution {
  std::vector<bool> turned;     ///< per view: its order was turned
  std::vector<bool> ambiguous;  ///< per view: neither orientation agrees clearly with the other views
};
std::vector<std::array<double, 2>> halfTurnDisagreements(const std::vector<HandEyeView>& views, const sim::Board& board,
                                                        sim::HandEyeSetup setup);
HalfTurnResolution resolveHalfTurns(std::vector<HandEyeView>& views, const sim::Board& board, sim::HandEyeSetup setup);

/// Leave-one-configuration-out cross-validation of the corner fit, judged by the one judge of small
/// sets (calib::crossValidatedVerdict, calib/heldout.hpp, as measured data): every configuration is
/// predicted by the closed form and by the corner fit, both fitted to the other configurations; the
/// corner fit is accepted when it predicts them better than the closed form, significantly, over at
/// least kMinHeldoutConfigurations configurations (a view's loss: its squared RMS corner distance).
/// Per view its residuals under both fold fits, and each refit's frames (for the jackknife); with fewer
/// configurations nothing is fitted (the verdict says so).
struct HandEyeCrossValidation {
  std::vector<ViewResidual> heldout;        ///< per view: the corner fit without its configuration
  std::vector<ViewResidual> heldout_start;  ///< per view: that fold's closed form
  int configurations = 0;
  std::vector<HandEyeFrames> refits;        ///< one per configuration held out
  std::vector<Eigen::Vector2d> refit_lens;  ///< their lens (k1, k2 added; zero unless fitted)
  HeldoutVerdict verdict;
};
/// `full` with its lens fitted (full.lens_fitted) is judged against the stated lens instead: every fold
/// fits the frames and k1, k2 from `stated_lens`'s refit of the same configuration, and the reference
/// (heldout_start) is stated_lens's held-out residual of the view (the corner fit with the stated lens).
HandEyeCrossValidation crossValidateHandEye(const std::vector<HandEyeView>& views, const sim::Camera& camera, const sim::Board& board,
                                            sim::HandEyeSetup setup, const HandEyeFit& full,
                                            const HandEyeCrossValidation* stated_lens = nullptr);

/// The jackknife 1-sigma of a frame a_T_b from its G leave-one-out refits (file comment), per axis of
/// the parent frame a: [translation (m); rotation (rad), logSO3(R_refit R_full^T)]; zero below 2 refits.
sim::Vector6d jackknifeSigma(const std::vector<Eigen::Isometry3d>& refits, const Eigen::Isometry3d& full);

}  // namespace orbcal::calib
