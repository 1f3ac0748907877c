#pragma once
// What the image calibration's steps share (calibrate.cpp fits, calibrate_report.cpp reports); not part
// of the library's interface.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "orbcal/calib/planning.hpp"
#include "orbcal/sim/truth.hpp"
#include "orbcal/workflow/calibrate.hpp"

namespace orbcal::workflow::calibrate_detail {

/// One image calibration in progress: its inputs, the split and the fit.
struct CalibrationRun {
  explicit CalibrationRun(const CalibrateOptions& options) : o(options) {}
  const CalibrateOptions& o;
  sim::Dataset d;
  calib::MeasurementKind kind = calib::MeasurementKind::kPose;
  std::string out;                ///< the output folder being written
  std::string measurements_path;  ///< where measurements.csv ends up
  std::vector<vision::Measurement> meas;
  std::vector<std::size_t> ident, hold;  ///< sample indices, sorted
  int configurations = 0;                ///< among the usable images (calib::countConfigurations)
  calib::MethodSpec method;
  std::unique_ptr<calib::MeasurementModel> model;  ///< of the identification samples
  std::optional<sim::TrueArm> true_arm;            ///< a simulated dataset's plant
  sim::Arm calibrated;
};

/// The arm with world = the board and marker = the camera, the scene's base_T_board and flange_T_camera
/// known: the layout of an image calibration's DH errors.
sim::KinematicModel sceneModel(const sim::Dataset& d);
/// The corner model's fit as a fit of its kinematic model (geometry, both frames, the chain effects):
/// the distortion block left out.
calib::Fit cornerModelFit(const CornerEstimate& c);
/// What an image calibration estimated, as a fit of a kinematic model (what model.yaml holds): with
/// --effects the corner model's fit, with --estimate-frames the fit of geometry and both frames, else
/// the DH errors on sceneModel.
calib::Fit imageFit(const CalibrationRun& run, const CalibrateResult& r);
/// "a, b, c".
std::string joinWords(const std::vector<std::string>& words);
/// The parameters `which` by name, or "none".
std::string parameterList(const calib::ParameterClasses& classes, const std::vector<int>& which);
/// report.md of an image calibration; `figure_lines` are the figures' Markdown.
std::string calibrationReport(const CalibrationRun& run, const CalibrateResult& r, const std::string& figure_lines);
/// What an accepted image calibration writes into run.out: model.yaml (imageFit) with robot_calibrated.yaml,
/// the exports (workflow::writeModelAndExports), estimates.csv, and with estimated frames scene_frames.yaml
/// (model.yaml's frames as the scene's keys), with a fitted distortion camera_calibrated.yaml.
void writeCalibratedFiles(const CalibrationRun& run, CalibrateResult& r);
/// samples.csv: per-image errors against the measured poses, nominal and calibrated, outliers marked.
void writeSampleErrors(const CalibrationRun& run, const CalibrateResult& r);

}  // namespace orbcal::workflow::calibrate_detail
