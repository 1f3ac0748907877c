#pragma once
// What the image-description calibration's steps share (measured_images.cpp runs, measured_images_report.cpp
// writes); not part of the library's interface.
#include <string>

#include "orbcal/workflow/measured_images.hpp"

namespace orbcal::workflow::measured_images_detail {

/// The views' fitted and held-out residuals (per used view; used[i]: the row of view i) and their RMS.
void setResiduals(const std::vector<calib::ViewResidual>& fitted, const std::vector<calib::ViewResidual>& heldout,
                  const std::vector<std::size_t>& used, ImageCalibrateResult& r);
/// The frames as written (the board's in the description's convention), their jackknife 1-sigma from
/// `refits`, and the refusals where a 1-sigma exceeds 5 mm or 0.5 deg.
void setFrames(const sim::ImageViews& data, const calib::HandEyeFrames& frames, const std::vector<calib::HandEyeFrames>& refits,
               ImageCalibrateResult& r);
/// With joint readings: the robot level asked for, or with auto chosen (ImageCalibrateResult::level),
/// fitted on the corners and judged against the frames level (calib/corner_levels.hpp); the frames,
/// residuals and refusals of `r` become the level's. `views`: the used views (used[i]: the row of view i).
void robotLevel(const sim::ImageViews& data, const std::vector<calib::HandEyeView>& views, const std::vector<std::size_t>& used,
                const calib::Level& level, ImageCalibrateResult& r);
/// "level offsets (as asked)", "level full (chosen by cross-validation: held-out mm residual frames 55.4, ...)", "level frames".
std::string levelSentence(const ImageCalibrateResult& r);
/// The robot level's section of report.md ("" at the frames level without joint readings).
std::string robotLevelSection(const sim::ImageViews& data, const ImageCalibrateResult& r);
/// frames.yaml: the two frames with their jackknife 1-sigma (format orbcal-hand-eye-1).
std::string framesYaml(const sim::ImageViews& data, const ImageCalibrateResult& r, const std::string& header);
/// views.csv: one row per row of the description.
std::string viewsCsv(const ImageCalibrateResult& r);
/// report.md.
std::string imageReport(const sim::ImageViews& data, const ImageCalibrateResult& r, const MeasuredCalibrateOptions& o, bool written);
/// The written frames' names by setup: {"flange_T_camera", "base_T_board"} or {"flange_T_board", "base_T_camera"}.
std::pair<std::string, std::string> frameNames(sim::HandEyeSetup setup);

}  // namespace orbcal::workflow::measured_images_detail
