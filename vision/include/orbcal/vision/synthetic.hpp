#pragma once
// An ideal board drawn with OpenCV polygons, for unit tests and the benchmark: not a renderer (no
// lighting, no optics beyond the camera model). Squares coloured by sim::isBlackSquare; pixel centres at
// integers (OpenCV); 4x supersampling with the exact intrinsics scaling s (c + 0.5) - 0.5.
#include <cstdint>
#include <opencv2/core.hpp>

#include "orbcal/sim/scene.hpp"

namespace orbcal::vision {

struct SyntheticImageSettings {
  int background = 90;        ///< grey level around the board
  int black = 25, white = 230;
  int supersample = 4;        ///< drawn at this factor, then area-averaged
  double noise_sigma = 0.0;   ///< additive Gaussian grey-level noise
  std::uint64_t seed = 1;     ///< noise seed
};

/// CV_8UC1 image of camera.width_px x camera.height_px.
cv::Mat drawSyntheticBoard(const sim::Camera& camera, const sim::Board& board, const Eigen::Isometry3d& camera_T_board,
                           const SyntheticImageSettings& settings = {});

}  // namespace orbcal::vision
