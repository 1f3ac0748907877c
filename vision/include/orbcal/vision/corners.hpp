#pragma once
// Chessboard inner corners from a grey image, in the order of sim::cornerInBoard (k = r * corners_x + c),
// with an orientation that cannot flip.
//
// Why the order needs fixing: the detectors return the corners row by row, but which end of the board
// they start from is theirs to choose (SB reversed the order in 14 of 50 rendered frames; the classic
// detector forces the first row to the top, which breaks for camera roll beyond 90 deg; see
// docs/rendering-notes.md, pitfall 6). orbcal's board has an even-by-odd square count
// ((corners_x + 1) x (corners_y + 1), e.g. 10 x 7) coloured so that square (i, j), covering
// x in [(i-1)s, i s], y in [(j-1)s, j s] of the board frame, is BLACK when i + j is even. The square
// diagonally outside corner 0 is therefore black and, after a half turn, the corresponding square is
// white. detectCorners samples the 2 x 2 squares around each end corner through a local homography and
// reverses the list when their colours say the detector started from the wrong end.
//
// A board whose corners_x + corners_y is even (odd-by-odd squares) looks the same after a half turn:
// its orientation cannot be decided from the image (status kRejected when required).
//
// A printed board coloured the other way round (first outer square white) is read with its board
// frame turned by a half turn about z: consistently, but the scene's base_T_board must say so.
#include <Eigen/Core>
#include <opencv2/core.hpp>
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

struct CornerDetection {
  ImageStatus status = ImageStatus::kNotFound;
  std::string reason;  ///< short fixed phrase (counted in summaries); empty when found
  std::string detail;  ///< specifics (numbers) for a human
  /// Inner corners (px, OpenCV convention: pixel centres at integers), k as in sim::cornerInBoard.
  std::vector<Eigen::Vector2d> corners_px;
  bool reversed = false;              ///< the detector's order was reversed to fix the orientation
  bool orientation_known = false;     ///< false only when require_orientation is off and undecidable
  double orientation_contrast = 0.0;  ///< grey levels, white minus black squares, after any reversal
  bool found() const { return status == ImageStatus::kFound; }
};

/// Detects the board's inner corners. Throws std::invalid_argument unless gray is a non-empty
/// CV_8UC1 image or the board has at least 2 x 2 corners. Every other outcome is a status.
[[nodiscard]] CornerDetection detectCorners(const cv::Mat& gray, const sim::Board& board,
                                            const DetectorSettings& settings = {});

/// The orientation check on its own (used by detectCorners): the signed contrast (white minus black,
/// grey levels) of the squares around the end corners, read in the order given. Positive: the order
/// agrees with the board's colouring; negative: it is reversed. std::nullopt when no end's squares
/// lie wholly inside the image. Throws std::invalid_argument when corners_px has the wrong size.
struct OrientationEvidence {
  double signed_contrast = 0.0;  ///< mean over the ends that could be sampled
  int ends_sampled = 0;          ///< 0, 1 or 2
};
OrientationEvidence orientationEvidence(const cv::Mat& gray, const sim::Board& board,
                                        const std::vector<Eigen::Vector2d>& corners_px);

/// True when the board's colouring is the same after a half turn (corners_x + corners_y even).
bool isHalfTurnSymmetric(const sim::Board& board);

/// Colour of square (i, j) of the board (see the file comment): true for black.
inline bool isBlackSquare(int i, int j) { return (i + j) % 2 == 0; }

}  // namespace orbcal::vision
