#pragma once
// What an image of a board says about the camera that took it, one function per statistic, for
// comparing real images with their rendered twins (workflow/twin.hpp). Every statistic is measured where
// the board's pose puts the pattern: flat square interiors away from the edges (levels, noise,
// vignetting), profiles across the squares' edges (edge width, overshoot), the detected corners against
// the pose (scatter) and the pixels outside the board's hull (background). Pixels set in a view's
// `ignored` mask (what a capture tool drew) are never used.
//
// Models: Poisson-Gaussian noise, variance = a * level + b (Foi, Trimeche, Katkovnik and Egiazarian
// 2008); a gamma response with black and white ends (Grossberg and Nayar 2004); radial fall-off
// 1 + c2 r^2 about the principal point, r in half image diagonals (Goldman 2010); edge spread
// profiles of slanted edges binned at a quarter pixel (ISO 12233's slanted-edge method).
#include <Eigen/Geometry>
#include <limits>
#include <map>
#include <opencv2/core.hpp>
#include <vector>

#include "orbcal/sim/scene.hpp"

namespace orbcal::vision {

/// One image of the board and where the board is in it.
struct BoardImage {
  cv::Mat gray;      ///< CV_8UC1, the camera's size
  cv::Mat ignored;   ///< CV_8UC1, non-zero: not used; empty: nothing ignored
  Eigen::Isometry3d camera_T_board = Eigen::Isometry3d::Identity();  ///< orbcal's board frame
  std::vector<int> ids;                      ///< detected inner corners
  std::vector<Eigen::Vector2d> corners_px;   ///< where (one per id)
  int markers = 0;                           ///< ArUco markers decoded
};

/// A value with its 1-sigma uncertainty (a standard error) and how many items it is made of.
struct Estimate {
  double value = std::numeric_limits<double>::quiet_NaN();
  double sigma = std::numeric_limits<double>::quiet_NaN();
  int n = 0;
  bool valid() const { return n > 0 && value == value; }
};

/// Mean over views and its standard error (sample standard deviation / sqrt(n); 0 for one view). NaNs skipped.
Estimate meanOverViews(const std::vector<double>& per_view);
/// Whether two estimates differ by more than 2 sigma of the difference (their uncertainties combined);
/// false where either is invalid.
bool differsSignificantly(const Estimate& a, const Estimate& b);

/// Distance of `px` to the principal point over the image's half diagonal (the camera profile's r).
double normalizedRadius(const sim::Camera& camera, const Eigen::Vector2d& px);
/// Pixel of board point p_board (m) under camera_T_board.
Eigen::Vector2d projectBoardPoint(const sim::Camera& camera, const Eigen::Isometry3d& camera_T_board,
                                  const Eigen::Vector3d& p_board);

// ---- corners -------------------------------------------------------------------------------------
/// Detected minus projected corner (px), by corner id, under the view's pose.
std::map<int, Eigen::Vector2d> cornerResiduals(const sim::Camera& camera, const sim::Board& board, const BoardImage& view);
/// RMS length of the residuals (px): the corners' scatter about the fitted pose.
double cornerScatterPx(const std::map<int, Eigen::Vector2d>& residuals);
/// The part of the corner residuals that repeats per corner id across views.
struct RepeatablePart {
  std::map<int, Eigen::Vector2d> mean_px;  ///< per id seen in at least 3 views
  /// Share of the residuals' mean square that the per-id means explain, each id's squared mean less its
  /// noise (variance / count), so that pure noise gives about 0.
  double share = 0.0;
};
RepeatablePart repeatableCornerPart(const std::vector<std::map<int, Eigen::Vector2d>>& residuals_per_view);
/// Displacement in the board plane (m) that moves corner `id`'s image by `residual_px` under the view's
/// pose (the inverse of the projection's 2 x 2 Jacobian in board x, y).
Eigen::Vector2d boardPlaneShift(const sim::Camera& camera, const sim::Board& board, const Eigen::Isometry3d& camera_T_board,
                                int id, const Eigen::Vector2d& residual_px);

// ---- flat square interiors -----------------------------------------------------------------------
/// One pixel inside a square, at least kFlatInsetPx from every edge of its square (and of its marker).
struct FlatSample {
  int u = 0, v = 0;
  double value = 0.0;     ///< DN
  double detail = 0.0;    ///< value - mean of its 4 neighbours (DN): noise, 1.25 times its variance
  double r = 0.0;         ///< normalizedRadius
  bool white = false;
};
inline constexpr double kFlatInsetPx = 2.5;
std::vector<FlatSample> flatSamples(const sim::Camera& camera, const sim::Board& board, const BoardImage& view);
/// Robust levels: medians of the black and of the white samples (DN); NaN without samples.
struct Levels {
  double black = std::numeric_limits<double>::quiet_NaN(), white = std::numeric_limits<double>::quiet_NaN();
};
Levels blackWhiteLevels(const std::vector<FlatSample>& samples);
/// Pixel noise (standard deviation, DN) of the black and of the white samples (their details' variance
/// over 1.25, the largest 1 % left out: specks and dust).
struct NoiseLevels {
  double black_sd = std::numeric_limits<double>::quiet_NaN(), white_sd = std::numeric_limits<double>::quiet_NaN();
  double black_level = 0.0, white_level = 0.0;
};
NoiseLevels noiseLevels(const std::vector<FlatSample>& samples);
/// Poisson-Gaussian fit var = a * level + b over (level, sd) pairs, a and b not negative (least squares).
struct PoissonGaussian {
  double a = 0.0, b = 0.0;
};
PoissonGaussian fitPoissonGaussian(const std::vector<NoiseLevels>& views);
/// Radial fall-off of the white level over views sharing one lens: log value = log k_view + c2 r^2
/// (least squares, a gain per view), and the relative level at half radius exp(c2 / 4) - 1 with its
/// jackknife sigma over the views. `samples` per view (white ones used). r^2 alone: telling r^4 apart
/// needs views across the whole image, and the light on the board takes it where they are not.
struct Falloff {
  double c2 = 0.0;
  Estimate at_half;  ///< relative change of the white level at r = 0.5 (-0.06: 6 % darker)
};
Falloff radialFalloff(const std::vector<std::vector<FlatSample>>& samples);

// ---- tone ----------------------------------------------------------------------------------------
/// out = black + (white - black) (in / 255)^(1 / gamma), fitted to (in, out) pairs (DN, `in` rounded to
/// 8-bit levels) by least squares
/// (gamma on a log grid then refined; black and white linear for each gamma).
struct ToneFit {
  double black = 0.0, white = 255.0, gamma = 1.0, rms = 0.0;
};
/// `max_white`: the white end is held at it where the free fit goes beyond (an 8-bit camera profile's
/// white is at most 255 DN).
ToneFit fitToneCurve(const std::vector<Eigen::Vector2d>& in_out, double max_white = std::numeric_limits<double>::infinity());
/// (rendered, real) pixel pairs over the board's squares (every `step`-th pixel), ignored pixels left out.
std::vector<Eigen::Vector2d> tonePairs(const sim::Camera& camera, const sim::Board& board, const BoardImage& real,
                                       const cv::Mat& rendered, int step = 2);

// ---- edges ---------------------------------------------------------------------------------------
/// Medians over the edges between neighbouring inner corners of: the 10-90 % width of the edge spread
/// profile (px, pixel centres binned by their distance to the edge the pose puts there), the overshoot
/// on the white side and the undershoot on the black side (fractions of the step).
struct EdgeStats {
  double width_px = std::numeric_limits<double>::quiet_NaN();
  double overshoot = std::numeric_limits<double>::quiet_NaN(), undershoot = std::numeric_limits<double>::quiet_NaN();
  int edges = 0;
};
EdgeStats edgeStats(const sim::Camera& camera, const sim::Board& board, const BoardImage& view);

// ---- background ----------------------------------------------------------------------------------
/// Mean and standard deviation (DN) of the pixels outside the board's hull grown by a square.
struct BackgroundStats {
  double mean = std::numeric_limits<double>::quiet_NaN(), sd = std::numeric_limits<double>::quiet_NaN();
  int pixels = 0;
};
BackgroundStats backgroundStats(const sim::Camera& camera, const sim::Board& board, const BoardImage& view);
/// CV_8UC1 of the image's size: 255 inside the board's outline (margin included) grown by `grow_m` on
/// every side (backgroundStats grows it by a square: the sheet's edge and its shadow are not background).
cv::Mat boardHullMask(const sim::Camera& camera, const sim::Board& board, const Eigen::Isometry3d& camera_T_board, double grow_m);

}  // namespace orbcal::vision
