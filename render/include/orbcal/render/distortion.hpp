#pragma once
// Lens distortion applied to a rendered image by an exact inverse mapping.
//
// OpenGL can only draw a pinhole image. For a camera with OpenCV distortion (k1, k2, p1, p2, k3) the
// renderer draws an undistorted "pinhole" camera, larger than the output when needed and with its own
// principal point, so that every output pixel's undistorted ray falls inside it; then for each output
// pixel (u, v) (pixel centres at integers) it looks up the pinhole image at
//   K_pinhole * undistort(K^-1 (u, v)),
// where undistort inverts sim::distortNormalized (the distortion sim::project applies) by Newton's
// method with its Jacobian, to ~1e-14 (normalised units).
// A point p_cam therefore lands at sim::project(camera, p_cam) in the output, i.e. where
// cv::projectPoints puts it.
#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "orbcal/sim/scene.hpp"

namespace orbcal::render {

/// Normalised undistorted coordinates x with sim::distortNormalized(k, x) = xd (OpenCV's model, k = k1 k2 p1 p2 k3).
/// False when Newton's method does not converge or lands where the model folds over (det J <= 0).
bool undistortNormalized(const std::array<double, 5>& k, const Eigen::Vector2d& xd, Eigen::Vector2d* x);

struct DistortionMap {
  sim::Camera pinhole;  ///< the camera OpenGL renders: no distortion
  cv::Mat map_x;        ///< CV_32FC1, output size: x in the pinhole image of each output pixel (-1: none)
  cv::Mat map_y;
};

/// The pinhole camera keeps fx, fy unless the undistorted field would need more than max_side_px
/// pixels along a side; then both focal lengths shrink by the same factor.
DistortionMap makeDistortionMap(const sim::Camera& camera, int max_side_px = 4096);

/// Output image (camera size) from the pinhole image: cv::remap, bicubic. (Bilinear remapping of 8-bit
/// images measured a systematic corner offset of up to 0.019 px; bicubic 0.005 px or less.)
cv::Mat applyDistortion(const DistortionMap& map, const cv::Mat& pinhole_image, double background = 0.0);

}  // namespace orbcal::render
