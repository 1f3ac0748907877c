#pragma once
// `orbcal calibrate DESCRIPTION.yaml` on a description of real images (sim/image_views.hpp): the board
// detected in every image (what a capture tool drew masked as the description says), the hand-eye and
// board frames from a closed-form start and the corner-level fit (calib/hand_eye.hpp), judged by
// leave-one-configuration-out cross-validation (10 to 30 views are too few to hold out a fifth; the judge
// and refusal rule of small measured sets, calib::crossValidatedVerdict), and
// written as frames.yaml (the two frames with their jackknife 1-sigma), views.csv (per view: the
// detection, the fitted and the cross-validated residuals in px and mm) and report.md.
//
// workflow::runMeasuredCalibrate calls it for a description with `images:`; Python can call either.
#include <string>
#include <vector>

#include <optional>

#include "orbcal/calib/corner_levels.hpp"
#include "orbcal/calib/hand_eye.hpp"
#include "orbcal/sim/image_views.hpp"
#include "orbcal/vision/real_views.hpp"
#include "orbcal/workflow/measured.hpp"

namespace orbcal::workflow {

/// What became of one row of the description.
struct ImageViewOutcome {
  std::string image, where;
  bool used = false;               ///< the board was found and the view entered the fit
  std::string reason;              ///< why not (the detection's reason and detail)
  int corners = 0;
  double pnp_rms_px = 0.0;         ///< the view's own PnP residual (RMS distance, px)
  double pnp_sigma_px = 0.0;       ///< its noise per pixel coordinate, sqrt(SSE / (2N - 6))
  int ignored_px = 0;              ///< pixels masked and filled before detection
  Eigen::Isometry3d camera_T_board = Eigen::Isometry3d::Identity();  ///< the view's own PnP (used views), orbcal's board frame
  Eigen::Isometry3d base_T_flange = Eigen::Isometry3d::Identity();   ///< as read (m)
  std::vector<int> lost_markers;   ///< markers the pose puts in view that were not decoded
  bool half_turned = false;        ///< a half-turn-symmetric board's order turned to agree with the others (calib::resolveHalfTurns)
  calib::ViewResidual fitted, heldout;  ///< under the full fit, and under the fit without its configuration
};

/// At least this many configurations with a detected board: the jackknife then has 3 or more refits,
/// and the closed form 3 or more motions.
constexpr int kMinHandEyeConfigurations = 4;

struct ImageCalibrateResult {
  sim::HandEyeSetup setup = sim::HandEyeSetup::kEyeInHand;
  std::vector<ImageViewOutcome> views;   ///< one per row
  int used = 0, configurations = 0;
  calib::HandEyeFrames start;            ///< the closed form's
  calib::HandEyeFit fit;
  calib::HandEyeCrossValidation cv;
  /// The frames as written, in the board frame of the description's convention: hand_T_eye is
  /// flange_T_camera (eye in hand) or flange_T_board (eye to hand); base_T_other is base_T_board or
  /// base_T_camera. Their jackknife 1-sigma (calib::jackknifeSigma).
  Eigen::Isometry3d hand_T_eye = Eigen::Isometry3d::Identity(), base_T_other = Eigen::Isometry3d::Identity();
  sim::Vector6d hand_sigma = sim::Vector6d::Zero(), base_sigma = sim::Vector6d::Zero();
  /// RMS over the used views of the cross-validated (held-out) residuals of the corner fit and of the
  /// closed form (each fitted without the view's configuration), of the fitted residuals, and the median
  /// PnP noise (the detection's, known independently of the chain). Held-out figures only where
  /// cross_validated (at least calib::kMinHeldoutConfigurations configurations).
  bool cross_validated = false;
  double heldout_rms_px = 0.0, heldout_rms_mm = 0.0, heldout_start_rms_px = 0.0, heldout_start_rms_mm = 0.0;
  double fitted_rms_px = 0.0, fitted_rms_mm = 0.0, detection_sigma_px = 0.0;
  /// The level calibrated: frames, or with joint readings a robot level (calib/corner_levels.hpp): the
  /// level asked for, or with auto the robot level of the smallest cross-validated mm residual among
  /// those that predict the views significantly better than the frames level (frames when none does).
  /// `tried`: the robot levels judged (offsets, map, full with auto); `robot`: the chosen one's fit on
  /// every view and `robot_sigma` its parameters' jackknife 1-sigma. The frames, the views' residuals
  /// and the figures above are then the robot level's; `frames_heldout_rms_mm` keeps the frames level's.
  calib::Level level{calib::LevelKind::kFrames, {}};
  std::vector<calib::CornerLevelCrossValidation> tried;
  std::optional<calib::CornerLevelFit> robot;
  Eigen::VectorXd robot_sigma;
  double frames_heldout_rms_px = 0.0, frames_heldout_rms_mm = 0.0;
  /// The lens check (once the frames level is cross-validated, without joint readings or at --level frames):
  /// the camera's radial distortion k1, k2
  /// fitted with the frames on the corners (added to the stated ones), cross-validated against the
  /// stated lens by the same judge (lens_verdict; the reference is each view's held-out residual with
  /// the stated lens). Taken when it predicts the views held out significantly better: `fit`, the frames,
  /// the views' residuals and the figures above (and a robot level's fit) are then with that lens, and
  /// frames.yaml gives it (`camera_distortion_added`); lens_stated_heldout_rms_* keep the stated lens's.
  bool lens_checked = false, lens_taken = false;
  Eigen::Vector2d lens_k = Eigen::Vector2d::Zero(), lens_sigma = Eigen::Vector2d::Zero();  ///< k1, k2 and their jackknife 1-sigma
  double lens_shift_px = 0.0;            ///< what lens_k moves the image corner farthest from the principal point by
  calib::HeldoutVerdict lens_verdict;
  double lens_stated_heldout_rms_px = 0.0, lens_stated_heldout_rms_mm = 0.0;
  std::string level_sentence;            ///< for the terminal and the report: "level offsets (as asked)"
  std::vector<std::string> warnings;     ///< re-orthonormalised poses, ...
  std::vector<std::string> refusals;     ///< empty: accepted
  double seconds = 0.0;                  ///< wall time of detection + fit + cross-validation
  std::string frames_path, views_path, report_path;
  std::vector<vision::ViewMeasurement> detections;  ///< per row, by runImageCalibrate (calibrateImageViews takes them again)
};

/// The board detected in every row of `data` (2 images at a time: images are large); a mask that
/// cannot be read: InputError naming the row.
std::vector<vision::ViewMeasurement> detectImageViews(const sim::ImageViews& data);

/// The fit and its judgement on the detections of the rows of `data` (one per row): runImageCalibrate
/// without reading images or writing files (`seconds`, the paths and `detections` left empty).
/// `level`: frames (the default), auto, or with joint readings any level (calib/levels.hpp); auto without
/// joint readings is frames. InputError naming --level for a robot level without joint readings.
ImageCalibrateResult calibrateImageViews(const sim::ImageViews& data, const std::vector<vision::ViewMeasurement>& detections,
                                         const calib::Level& level = {calib::LevelKind::kFrames, {}});

/// The whole run: read, detect, fit, cross-validate, write (into o.out, default <description's
/// folder>/calibration). o.level: auto or frames, or with joint readings (robot + joints) any level;
/// o.effects empty; o.holdout empty (the judge is cross-validation): InputError naming the option
/// otherwise.
ImageCalibrateResult runImageCalibrate(const MeasuredCalibrateOptions& o);

}  // namespace orbcal::workflow
