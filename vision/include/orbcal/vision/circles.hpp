#pragma once
// Circle grids (sim::BoardType::kCircles): dark circles on white, found by cv::findCirclesGrid
// (CALIB_CB_SYMMETRIC_GRID or CALIB_CB_ASYMMETRIC_GRID) with a cv::SimpleBlobDetector set for dark blobs
// whose area lies between 10 px^2 and the image's area over twice the circle count (a board filling the
// image); where its grid finder fails (in rendered views: a symmetric grid whose rows stand closer to the
// image's vertical, about half the views), again with CALIB_CB_CLUSTERING. The centres are the blobs' centroids, in OpenCV's order: row by row, as sim::cornerInBoard
// numbers them, or that order after a half turn of the board (findCirclesGrid orders by the image: which
// end it starts from depends on how the board is turned in the image). A mirrored order (the board's
// rows read right to left, which no rigid pose of the printed face gives) is reversed into a proper one.
//
// Orientation: a grid that is the same after a half turn (sim::halfTurnSymmetric: every symmetric grid,
// an asymmetric one of an even number of rows) has orientation_known false: one image cannot tell its
// corner k from numCorners() - 1 - k; a set of views with the flange poses can
// (calib::resolveHalfTurns). An asymmetric grid of an odd number of rows has one order.
//
// The centroid of a circle's image is the centre of the ellipse it projects to, not the projection of
// the circle's centre: under perspective they differ by about f r^2 sin(2 tilt) / (2 Z^2) px (r the
// radius, Z the distance, tilt between the board's normal and the line of sight). ellipseCentreBias
// gives it exactly for a pinhole; vision::measureImage removes it (detected centres minus the bias the
// view's own pose predicts, then the pose re-solved).
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "orbcal/sim/scene.hpp"
#include "orbcal/vision/corners.hpp"

namespace orbcal::vision {

/// Detects a circle grid (board.type == kCircles; std::invalid_argument otherwise, or unless gray is a
/// non-empty CV_8UC1 image): every centre, ordered (file comment).
[[nodiscard]] CornerDetection detectCircles(const cv::Mat& gray, const sim::Board& board);

/// The image of circle k's centroid minus the projection of its centre (px), for a pinhole camera
/// (`camera`'s distortion ignored: the bias is a property of the perspective map) at camera_T_board:
/// the centre of the ellipse the circle projects to (the pole of the line at infinity of the image
/// conic) minus the projected centre.
Eigen::Vector2d ellipseCentreBias(const sim::Camera& camera, const sim::Board& board, const Eigen::Isometry3d& camera_T_board, int k);

}  // namespace orbcal::vision
