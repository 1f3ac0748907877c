#pragma once
// Lens distortion applied to a rendered image by an exact inverse mapping.
//
// OpenGL can only draw a pinhole image. For a camera with OpenCV distortion (k1, k2, p1, p2, k3) the
// renderer draws an undistorted "pinhole" camera, larger than the output when needed and with its own
// principal point, so that every output pixel's undistorted ray falls inside it; then for each output
// pixel (u, v) (pixel centres at integers) it looks up the pinhole image at
//   K_pinhole * undistort(K^-1 (u, v)),
// where undistort inverts sim::distortNormalized (the distortion sim::project applies) by Newton's
// method with its Jacobian, to ~1e-14 (normalised units): from the ray of the pixel to the left, or,
// with two valid pixels to the left, as one Newton step from their linear extrapolation when that step
// is under 1e-5 (the result then within ~1e-10, ~1e-7 px; tests/render compares the whole map with
// Newton's method from scratch: float rounding, 6e-5 px, is all that differs).
// A point p_cam therefore lands at sim::project(camera, p_cam) in the output, i.e. where
// cv::projectPoints puts it.
#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <vector>

#include "orbcal/sim/scene.hpp"

namespace orbcal::render {

/// Normalised undistorted coordinates x with sim::distortNormalized(k, x) = xd (OpenCV's model, k = k1 k2 p1 p2 k3).
/// False when Newton's method does not converge or lands where the model folds over (det J <= 0).
/// Newton's method starts from `start` when given (e.g. a neighbouring pixel's ray), else from xd.
bool undistortNormalized(const std::array<double, 5>& k, const Eigen::Vector2d& xd, Eigen::Vector2d* x,
                         const Eigen::Vector2d* start = nullptr);

struct DistortionMap {
  sim::Camera pinhole;  ///< the camera OpenGL renders: no distortion
  cv::Mat map_x;        ///< CV_32FC1, output size: x in the pinhole image of each output pixel (-1: none)
  cv::Mat map_y;
  /// map_x, map_y in OpenCV's fixed point (cv::convertMaps, CV_16SC2 + CV_16UC1): what cv::remap turns
  /// float maps into on every call, done once (the same pixels, faster).
  cv::Mat map_fixed, map_fraction;
  /// For each tile_px x tile_px tile of the output (row-major, the last row and column of tiles cut by the
  /// image edge): the pinhole pixels its bicubic lookups can read (empty: none, every pixel maps to -1).
  int tile_px = 16;
  int tiles_x = 0, tiles_y = 0;
  std::vector<cv::Rect> tile_reads;
  std::vector<unsigned char> tile_maps_none;  ///< per tile: 1 when some pixel of it maps to -1 (none)
};

/// The pinhole camera keeps fx, fy unless the undistorted field would need more than max_side_px
/// pixels along a side; then both focal lengths shrink by the same factor.
DistortionMap makeDistortionMap(const sim::Camera& camera, int max_side_px = 4096);

/// Output image (camera size) from the pinhole image: cv::remap, bicubic. (Bilinear remapping of 8-bit
/// images measured a systematic corner offset of up to 0.019 px; bicubic 0.005 px or less.)
/// `background` (grey level) fills the pixels that map outside the pinhole image (-1).
cv::Mat applyDistortion(const DistortionMap& map, const cv::Mat& pinhole_image, double background = 0.0);

/// The output pixels whose lookups can read a pinhole pixel inside `pinhole_rect`: per row of tiles, the
/// span from the first to the last tile that can (none when no tile of the row can). Every output pixel
/// outside these strips reads only pinhole pixels outside `pinhole_rect`, or none.
std::vector<cv::Rect> outputStripsReading(const DistortionMap& map, const cv::Rect& pinhole_rect);

/// applyDistortion when the pinhole image is `background` (a grey level, 0..255) everywhere outside
/// `pinhole_rect`: only outputStripsReading(map, pinhole_rect) can differ from `background`. Bicubic
/// weights sum to one in OpenCV's fixed point, so a lookup whose 4 x 4 pixels hold one grey level gives
/// that level: the strips' tiles whose lookups all do are filled with it, then each such pixel of the
/// other tiles, and only the remaining lookups (about a tenth of the strips for a board) go through one
/// cv::remap. The same pixels as applyDistortion; tests/render checks it.
cv::Mat applyDistortion(const DistortionMap& map, const cv::Mat& pinhole_image, int background, const cv::Rect& pinhole_rect);

}  // namespace orbcal::render
