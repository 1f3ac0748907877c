#pragma once
// Real photographs of a board, as capture tools save them: what to ignore in them (the detections,
// labels and axes a tool drew into the frame, a mask, rectangles), the board's pose in each, and which
// of the board's markers the pose says were in view but could not be decoded.
//
// Ignored pixels are filled from their surroundings (cv::inpaint, Telea 2004) before detection, so a
// drawn outline or label no longer splits a marker's border or a square's edge; what it covered is
// not recovered (a label over a marker's bits leaves that marker undecodable: it is reported as lost).
// "Clear colour": one channel above both others by more than 40 of 255 (a printed board is grey: black
// ink and white paper stay within a few levels across channels); the mask is not grown, since a grown
// mask over a marker's border fills it grey and the marker no longer decodes.
//
// ChArUco boards: markers hidden under drawings leave too few interpolated corners, so every inner corner
// is then measured where a pose puts it: the pose of the interpolated corners, or where fewer than 6 were
// interpolated the pose of at least 3 decoded markers (cv::aruco::estimatePoseBoard), predicts every
// corner more than 8 px inside the image; each is refined in the image (cornerSubPix, the window kept off
// the neighbouring corners and the markers) and kept where it moved less than 2 px; the pose is re-solved
// from those and the prediction repeated once. The view's measurement is the one with more corners.
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "orbcal/sim/image_views.hpp"
#include "orbcal/vision/measurement.hpp"

namespace orbcal::vision {

/// 255 where `bgr` (CV_8UC3) is to be ignored: `mask`'s rules and `view_mask` (a file; non-zero pixels
/// ignored; empty: none). A mask file that cannot be read, or of another size than the image:
/// std::invalid_argument naming it.
cv::Mat ignoredPixels(const cv::Mat& bgr, const sim::ImageMask& mask, const std::string& view_mask);

struct ViewMeasurement {
  Measurement measurement;         ///< the board pose (camera_T_board; covariance of the camera pose, pose.hpp's e_c)
  int ignored_px = 0;              ///< pixels filled before detection
  std::vector<int> lost_markers;   ///< ChArUco: markers whose centre the pose puts inside the image, not decoded
  int markers = 0;                 ///< ChArUco: markers of the board decoded
};

/// `image` with its `ignored` pixels (non-zero) filled from their surroundings (Telea 2004), as
/// measureView fills them before detection; `image` itself where nothing is ignored.
cv::Mat fillIgnored(const cv::Mat& image, const cv::Mat& ignored);

/// The board's pose in a grey image (CV_8UC1) with nothing to ignore: measureView after reading and filling.
ViewMeasurement measureGray(const cv::Mat& gray, const sim::Camera& camera, const sim::Board& board, const MeasureSettings& settings);

/// Reads `path` (colour or grey), fills the ignored pixels and measures the board's pose
/// (vision::measureImage with camera and board; no arm). A file that cannot be read is kUnreadable.
ViewMeasurement measureView(const std::string& path, const sim::Camera& camera, const sim::Board& board,
                            const sim::ImageMask& mask, const std::string& view_mask, const MeasureSettings& settings);

}  // namespace orbcal::vision
