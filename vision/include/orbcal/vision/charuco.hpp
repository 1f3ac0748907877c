#pragma once
// ChArUco boards (OpenCV's aruco module, Debian's libopencv-contrib-dev): the ArUco markers are found
// (cv::aruco::detectMarkers), the chessboard corners between them interpolated and refined
// (cv::aruco::interpolateCornersCharuco, OpenCV 4.6's API), each with its identity. The identity of
// ChArUco corner k is the board's inner corner k (sim::charucoMarkers says why), so the pose needs no
// orientation check and no full view of the board: vision::estimateBoardPose(camera, board, px, ids).
#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "orbcal/sim/scene.hpp"
#include "orbcal/vision/corners.hpp"

namespace orbcal::vision {

struct CharucoDetection {
  ImageStatus status = ImageStatus::kNotFound;
  std::string reason, detail;           ///< as CornerDetection's
  std::vector<int> ids;                 ///< inner corner identities (sim::cornerInBoard), ascending
  std::vector<Eigen::Vector2d> corners_px;  ///< one per id (px, OpenCV's pixel convention)
  int markers = 0;                      ///< ArUco markers of this board found
  std::vector<int> marker_ids;          ///< their ids, as found
  std::vector<std::vector<cv::Point2f>> marker_corners;  ///< their 4 corners each (px), as cv::aruco::detectMarkers gives them
  bool found() const { return status == ImageStatus::kFound; }
};

/// Detects a ChArUco board (board.type == kCharuco; std::invalid_argument otherwise, or unless gray
/// is a non-empty CV_8UC1 image). `camera` (optional) lets the corner interpolation use the lens
/// model (OpenCV's approximate-calibration path) instead of local homographies. Found when at least
/// min_corners corners, not all on one row or column, were interpolated.
[[nodiscard]] CharucoDetection detectCharuco(const cv::Mat& gray, const sim::Board& board,
                                             const sim::Camera* camera = nullptr, int min_corners = 6);

}  // namespace orbcal::vision
