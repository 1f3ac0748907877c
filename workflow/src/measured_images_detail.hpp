#pragma once
// What the image-description calibration's steps share (measured_images.cpp runs, measured_images_report.cpp
// writes); not part of the library's interface.
#include <string>

#include "orbcal/workflow/measured_images.hpp"

namespace orbcal::workflow::measured_images_detail {

/// frames.yaml: the two frames with their jackknife 1-sigma (format orbcal-hand-eye-1).
std::string framesYaml(const sim::ImageViews& data, const ImageCalibrateResult& r, const std::string& header);
/// views.csv: one row per row of the description.
std::string viewsCsv(const ImageCalibrateResult& r);
/// report.md.
std::string imageReport(const sim::ImageViews& data, const ImageCalibrateResult& r, const MeasuredCalibrateOptions& o, bool written);
/// The written frames' names by setup: {"flange_T_camera", "base_T_board"} or {"flange_T_board", "base_T_camera"}.
std::pair<std::string, std::string> frameNames(sim::HandEyeSetup setup);

}  // namespace orbcal::workflow::measured_images_detail
