#pragma once
// `orbcal calibrate <dataset>`: identify the parameter errors of an arm from a dataset of images and
// joint readings (rendered or real; the layout of sim/dataset.hpp), and write the calibrated robot file.
// No ground truth is needed: the gain is measured on held-out samples, against the poses the camera
// measured there. Where the dataset is simulated (its manifest has true errors), the report also
// compares with the truth.
#include <cstdint>
#include <string>

#include "orbcal/calib/consistency.hpp"
#include "orbcal/calib/corner_model.hpp"
#include "orbcal/calib/experiment.hpp"
#include "orbcal/calib/heldout.hpp"
#include "orbcal/calib/measured_fit.hpp"
#include "orbcal/calib/observability.hpp"
#include "orbcal/calib/parameter_classes.hpp"
#include "orbcal/calib/relative_models.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/vision/measurement.hpp"
#include "orbcal/workflow/callbacks.hpp"
#include <optional>

namespace orbcal::workflow {

struct CalibrateOptions {
  std::string dataset;
  std::string method = calib::kDefaultMethod;  ///< a name calib::findMethod takes (as measured data)
  std::string out;                       ///< default: <dataset>/calibration
  double joint_noise_sigma_rad = -1.0;   ///< < 0: the manifest's, or Wang et al. 2023's 0.01 deg if it has none
  /// Share of the usable images kept out for validation, whole configurations (calib::holdoutSplit, as
  /// measured data's); empty: calib::defaultHoldout.
  std::optional<double> holdout;
  std::uint64_t seed = 1;                ///< of the hold-out draw
  bool quiet = false;
  /// Estimate base_T_board and flange_T_camera with the arm's parameters (closed-form start from the
  /// camera poses, then LM), instead of taking the scene's as exact.
  bool estimate_frames = false;
  /// With estimate_frames: effects fitted on the corner model (calib/corner_model.hpp), as --effects
  /// takes them: chain effects of the catalog and `distortion` (the camera's).
  std::vector<std::string> effects;
  /// What of each camera pose the calibration uses (calib/planning.hpp): pose (the absolute pose in the
  /// base frame through the scene's base_T_board, Wang et al. 2023), position, or frame-free quantities
  /// between pairs of images (distance, rotation, dr: Jia et al. 2019), which need no base_T_board.
  std::string model = "pose";
  std::string pairs = "reference";  ///< relative models: each image against the first, or consecutive
  /// Write the calibrated files even when the fit is inconsistent with its noise or the held-out error
  /// grows (the report and the exit status say so all the same).
  bool accept_worse = false;
  bool plots = true;  ///< draw the report's figures (python3 + matplotlib)
  Callbacks callbacks;  ///< progress and figures (callbacks.hpp)
};

/// With CalibrateOptions::effects: geometry + both frames + the chain effects + the distortion block,
/// fitted by LM on the detected corners (calib::CornerMeasurementModel) from the closed-form frame start.
struct CornerEstimate {
  std::vector<sim::Effect> effects;     ///< the chain effects
  sim::KinematicModel model;            ///< the starting model (geometry, both frames, the effects)
  bool distortion = false;              ///< the distortion block is free (else held at 0)
  sim::ParamLayout layout;              ///< the corner model's
  calib::CornerFit fit;                 ///< with the effects (and the distortion where asked)
  calib::CornerFit without;             ///< the same with the distortion block held at 0 (with distortion only)
  Eigen::Vector4d dk = Eigen::Vector4d::Zero(), dk_sigma = Eigen::Vector4d::Zero();
  std::optional<Eigen::Vector4d> dk_true;  ///< the injected distortion of a simulated dataset (0 where none)
  double heldout_rms_px = 0.0, heldout_rms_px_without = 0.0;  ///< corner residual RMS on the held-out images
};

/// With CalibrateOptions::estimate_frames: the fit of geometry + the two frames, and the frames it found.
struct FrameEstimate {
  calib::Fit fit;
  Eigen::VectorXd reference_p;          ///< fit.model's parameters with the nominal geometry, only the frames fitted
  Eigen::Isometry3d base_T_board, flange_T_camera;          ///< estimated
  calib::ResidualStats heldout_before, heldout_after;       ///< scene frames refitted on the nominal arm vs calibrated
  std::optional<CornerEstimate> corners;                    ///< with CalibrateOptions::effects
};

struct CalibrateResult {
  calib::Estimate estimate;
  std::string model = "pose";            ///< the measurement kind used
  calib::ParameterClasses classes;       ///< of the identification set under that model
  calib::ObservabilityIndices observability;  ///< of the identification set, held parameters left out
  /// Relative models: the held-out images paired with the first identification image, nominal vs
  /// calibrated (what a frame-free model can be judged on without base_T_board).
  std::optional<calib::RelativeErrors> relative_before, relative_after;
  /// The fit against its noise model (calib/consistency.hpp), and what is wrong when it fails.
  calib::Consistency consistency;
  std::vector<std::string> outlier_images;  ///< the inconsistent samples' images (pose kinds) or pairs
  std::string likely_cause;                 ///< empty when consistent
  /// The one held-out rule (calib::heldoutVerdict) on the held-out camera poses: the nominal arm (the
  /// scene's frames, or with estimate_frames the frames fitted) against the model written (model.yaml).
  calib::HeldoutVerdict verdict;
  /// The problems, one line each, first in the report and on the terminal; empty when all went well.
  std::vector<std::string> refusals;
  bool written = false;                     ///< model.yaml, robot_calibrated.yaml and estimates.csv were written
  int images = 0, usable = 0, identification = 0, held_out = 0;
  /// Hold-out flange errors of the DH estimate with the scene's frames, against the measured poses (Wang
  /// et al. 2023 Table 4's layout)
  calib::ErrorSummary before, after;
  bool has_truth = false;
  calib::ErrorSummary truth_before, truth_after;  ///< hold-out errors against the true poses (simulation)
  std::string robot_path, report_path;
  std::string urdf_path;                 ///< the calibrated URDF (a URDF robot only)
  /// model.yaml (sim/model_io.hpp, as measured data's): the DH errors with the scene's frames known, or
  /// with estimate_frames the fit of geometry and both frames; robot_calibrated.yaml is its arm.
  std::string model_path;
  double joint_noise_sigma_rad = 0.0;
  std::optional<FrameEstimate> frames;   ///< with estimate_frames
};

CalibrateResult runCalibrate(const CalibrateOptions& o);

/// One line: the identifiability analysis's kept (minimal identifiable set) and held parameters, by name.
std::string formatKeptAndHeld(const calib::ParameterClasses& classes);

/// An image dataset's samples `which` as measured data: world = the board, marker = the camera,
/// world_T_marker = board_T_camera with the vision covariance moved to the camera frame; both frames
/// estimated (shared); torques from the robot file's masses where it has them; approach directions
/// from the sample order.
struct ImageMeasuredData {
  sim::MeasuredData data;
  std::vector<calib::MarkerObservation> observations;
};
/// The detected corners of the samples `which` (obs[i] is sample which[i]), for the corner model.
std::vector<calib::CornerObservation> cornerObservations(const std::vector<calib::MarkerObservation>& obs,
                                                         const std::vector<vision::Measurement>& meas,
                                                         const std::vector<std::size_t>& which);
ImageMeasuredData imageMeasuredData(const sim::Dataset& d, const std::vector<vision::Measurement>& meas,
                                    const std::vector<std::size_t>& which);

}  // namespace orbcal::workflow
