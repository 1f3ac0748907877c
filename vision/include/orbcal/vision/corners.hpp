#pragma once
// Chessboard inner corners from a grey image, in the order of sim::cornerInBoard (k = r * corners_x + c),
// with an orientation that cannot flip.
//
// Why the order needs fixing: the detectors return the corners row by row, but which end of the board
// they start from is theirs to choose, so the order they return may be reversed. On orbcal's 9 x 6 inner
// corners the classic detector kept the board order in 200 rendered views and SB reversed it in every
// one; on an 8 x 6 board the rendering notes (../shared/docs/rendering-notes.md, pitfall 6) saw SB
// reverse it in 14 of 50 frames and the classic detector force the first row to the top, which breaks
// for camera roll beyond 90 deg. detectCorners therefore fixes the order up itself, whatever the
// detector did. orbcal's board has an even-by-odd square count ((corners_x + 1) x (corners_y + 1),
// e.g. 10 x 7), coloured as sim::isBlackSquare says: square (i, j), covering x in [(i-1)s, i s],
// y in [(j-1)s, j s] of the board frame, is BLACK when i + j is even. Square (1, 1), between inner
// corners 0, 1, corners_x and corners_x + 1, is therefore black, while the square at that place after
// a half turn, (corners_x - 1, corners_y - 1), is white (black iff corners_x + corners_y is even).
// detectCorners samples the interior squares (bounded by four detected corners, so never outside the
// detected area) at both ends of the list through a local homography and reverses the list when their
// colours say the detector started from the wrong end; ends that disagree make the orientation
// inconsistent.
//
// A board whose corners_x + corners_y is even (odd-by-odd squares) looks the same after a half turn:
// its orientation cannot be decided from the image (status kRejected when required).
//
// A printed board coloured the other way round (first outer square white) is read with its board
// frame turned by a half turn about z: consistently, but the scene's base_T_board must say so.
#include <Eigen/Core>
#include <array>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "orbcal/sim/scene.hpp"

namespace orbcal::vision {

enum class Detector {
  kClassic,      ///< cv::findChessboardCorners + cv::cornerSubPix (default: 5-9 ms at 1280x1024)
  kSectorBased,  ///< cv::findChessboardCornersSB (sub-pixel by itself; ~250 ms at 1280x1024)
};
const char* toString(Detector d);
/// "classic" or "sb"; throws std::invalid_argument naming the accepted values otherwise.
Detector parseDetector(const std::string& name);

/// What happened to one image. Every image gets one, with a reason unless kFound.
enum class ImageStatus {
  kFound,       ///< board found, corners ordered (and, in a measurement, the pose estimated)
  kNotFound,    ///< no board of the expected size in the image
  kRejected,    ///< a board was found but failed a check (orientation, image size, reprojection RMS)
  kUnreadable,  ///< missing file or an image that cannot be decoded
};
/// "found", "not_found", "rejected", "unreadable".
const char* toString(ImageStatus s);
/// Inverse of toString; std::nullopt-free: throws std::invalid_argument on an unknown word.
ImageStatus parseImageStatus(const std::string& word);

struct DetectorSettings {
  Detector detector = Detector::kClassic;
  /// cornerSubPix half window, upper bound. 5 (an 11 x 11 window) is what the rendering notes
  /// measured (0.073 px RMS vs ground truth); it is shrunk to 0.4 x the smallest corner spacing so
  /// that the window never reaches the next corner on small boards.
  int max_subpix_half_window_px = 5;
  /// > 0: cornerSubPix with exactly this half window instead (the classic detector), as OpenCV's
  /// calibration sample and tutorial do with 11 (a 23 x 23 window), whatever the corner spacing.
  int fixed_subpix_half_window_px = 0;
  /// An image whose grey levels span less than this is blank (all black, all white, lens cap):
  /// reported as not found without running the detector. 8-bit grey levels.
  double min_grey_spread = 16.0;
  /// Mean grey-level difference between the white and the black squares around the end corners
  /// below which the orientation is undecidable. Printed boards give > 80; 20 leaves room for
  /// dark, low-contrast images while staying far above sensor noise averaged over hundreds of pixels.
  double min_orientation_contrast = 20.0;
  /// When false, an undecidable orientation keeps the detector's order instead of rejecting the
  /// image. Camera intrinsics do not need the orientation (a half-turned board is still a plane).
  bool require_orientation = true;
};

/// The corner refinement `settings` use, one line for the user, and how it differs from OpenCV's
/// calibration tutorial (a fixed 11 px half window): "corner refinement: cornerSubPix half window
/// min(5 px, 0.4 x the corner spacing) (OpenCV's calibration tutorial: 11 px; --subpix-window 11)".
std::string subpixWindowText(const DetectorSettings& settings);

struct CornerDetection {
  ImageStatus status = ImageStatus::kNotFound;
  std::string reason;  ///< short fixed phrase (counted in summaries); empty when found
  std::string detail;  ///< specifics (numbers) for a human
  /// Inner corners (px, OpenCV convention: pixel centres at integers), k as in sim::cornerInBoard.
  std::vector<Eigen::Vector2d> corners_px;
  bool reversed = false;              ///< the detector's order was reversed to fix the orientation
  bool orientation_known = false;     ///< false only when require_orientation is off and the
                                      ///< orientation is undecidable or inconsistent
  double orientation_contrast = 0.0;  ///< grey levels, white minus black squares, after any reversal
  bool found() const { return status == ImageStatus::kFound; }
  /// A detection that failed with `status` (not kFound), its reason and detail: every detector's one way to say so.
  static CornerDetection failed(ImageStatus status, std::string reason, std::string detail);
};

/// Detects the board's inner corners. Throws std::invalid_argument unless gray is a non-empty
/// CV_8UC1 image and the board has at least 2 x 2 corners. Every other outcome is a status: an
/// orientation that is undecidable or inconsistent is kRejected when require_orientation is on;
/// otherwise the detector's order is kept, orientation_known is false and detail says why.
[[nodiscard]] CornerDetection detectCorners(const cv::Mat& gray, const sim::Board& board,
                                            const DetectorSettings& settings = {});

/// The orientation check on its own (used by detectCorners): at each end of the list, the signed
/// contrast (mean of the white minus mean of the black squares, grey levels, colours as expected for
/// the order given) of the interior squares next to the end corner: squares i in {1, 2}, j in {1, 2}
/// at the first end and i in {corners_x - 2, corners_x - 1}, j in {corners_y - 2, corners_y - 1} at the
/// last (clipped to the interior squares 1..corners_x - 1, 1..corners_y - 1), each bounded by detected
/// corners. Positive: the order agrees with the board's colouring; negative: it is reversed. An end
/// whose sampled squares are not wholly inside the image (or too small) is not sampled. Throws
/// std::invalid_argument when corners_px has the wrong size.
struct OrientationEvidence {
  double signed_contrast = 0.0;  ///< mean over the ends sampled (0 when none; meaningless unless consistent)
  int ends_sampled = 0;          ///< 0, 1 or 2
  bool consistent = true;        ///< false when both ends were sampled and their signs disagree
  std::array<std::optional<double>, 2> end_contrast;  ///< first end (corner 0), last end; nullopt: not sampled
};
OrientationEvidence orientationEvidence(const cv::Mat& gray, const sim::Board& board,
                                        const std::vector<Eigen::Vector2d>& corners_px);

/// cv::cornerSubPix on `corners` with a half window of half_window_px clamped to [1, max_half_window_px]
/// (the caller keeps the window off the neighbouring corners and any marker).
void refineCornersSubPix(const cv::Mat& gray, std::vector<cv::Point2f>& corners, double half_window_px,
                         int max_half_window_px);

/// True when the board's colouring is the same after a half turn (corners_x + corners_y even).
bool isHalfTurnSymmetric(const sim::Board& board);

}  // namespace orbcal::vision
