#include "orbcal/vision/corners.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

namespace orbcal::vision {

namespace {

// Inset of the sampled area inside each square, as a fraction of the square: keeps the samples
// clear of the blurred edges and of the corners' own detection error.
constexpr double kSquareInset = 0.25;
// Fewer pixels than this in a sampled square: too small to trust its mean.
constexpr int kMinSamplePixels = 4;
// Size of the block of corners that defines the local homography at each end (3 x 3 corners: local
// enough to follow lens distortion, overdetermined enough to average corner noise).
constexpr int kLocalBlock = 3;

std::string fmt(double v, int decimals = 1) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(decimals);
  s << v;
  return s.str();
}

// Mean grey level inside square (i, j) (board frame, in squares: x in [i-1, i], y in [j-1, j]),
// mapped by H (square units -> px); nullopt when it is not wholly inside the image.
std::optional<double> squareMean(const cv::Mat& gray, const cv::Matx33d& H, int i, int j) {
  const double x0 = i - 1 + kSquareInset, x1 = i - kSquareInset, y0 = j - 1 + kSquareInset, y1 = j - kSquareInset;
  const double xs[4] = {x0, x1, x1, x0}, ys[4] = {y0, y0, y1, y1};
  std::vector<cv::Point> poly;
  constexpr int kShift = 4;  // fillConvexPoly sub-pixel bits
  double umin = std::numeric_limits<double>::max(), vmin = umin, umax = -umin, vmax = -umin;
  std::vector<cv::Point2d> pts;
  for (int n = 0; n < 4; ++n) {
    const cv::Vec3d p = H * cv::Vec3d(xs[n], ys[n], 1.0);
    if (!(p[2] > 0.0) && !(p[2] < 0.0)) return std::nullopt;
    const cv::Point2d uv(p[0] / p[2], p[1] / p[2]);
    if (!(uv.x >= 0.0 && uv.y >= 0.0 && uv.x <= gray.cols - 1.0 && uv.y <= gray.rows - 1.0)) return std::nullopt;
    pts.push_back(uv);
    umin = std::min(umin, uv.x), umax = std::max(umax, uv.x), vmin = std::min(vmin, uv.y), vmax = std::max(vmax, uv.y);
  }
  const cv::Rect roi(static_cast<int>(std::floor(umin)), static_cast<int>(std::floor(vmin)),
                     static_cast<int>(std::floor(umax)) - static_cast<int>(std::floor(umin)) + 1,
                     static_cast<int>(std::floor(vmax)) - static_cast<int>(std::floor(vmin)) + 1);
  for (const auto& uv : pts) {
    poly.emplace_back(static_cast<int>(std::lround((uv.x - roi.x) * (1 << kShift))),
                      static_cast<int>(std::lround((uv.y - roi.y) * (1 << kShift))));
  }
  cv::Mat mask = cv::Mat::zeros(roi.size(), CV_8UC1);
  cv::fillConvexPoly(mask, poly, cv::Scalar(255), cv::LINE_8, kShift);
  if (cv::countNonZero(mask) < kMinSamplePixels) return std::nullopt;
  return cv::mean(gray(roi), mask)[0];
}

// Signed contrast (white minus black, expected colours) of the interior squares next to one end corner
// (orientationEvidence's doc comment says which), using the homography of the nearest kLocalBlock^2
// corners. Every square sampled is bounded by four of those corners: nothing is extrapolated.
std::optional<double> endContrast(const cv::Mat& gray, const sim::Board& board,
                                  const std::vector<Eigen::Vector2d>& corners, bool first_end) {
  const int bx = std::min(kLocalBlock, board.corners_x), by = std::min(kLocalBlock, board.corners_y);
  const int c0 = first_end ? 0 : board.corners_x - bx, r0 = first_end ? 0 : board.corners_y - by;
  std::vector<cv::Point2d> src, dst;
  for (int r = r0; r < r0 + by; ++r) {
    for (int c = c0; c < c0 + bx; ++c) {
      src.emplace_back(c, r);
      const Eigen::Vector2d& p = corners[r * board.corners_x + c];
      dst.emplace_back(p.x(), p.y());
    }
  }
  const cv::Mat Hm = cv::findHomography(src, dst, 0);
  if (Hm.empty()) return std::nullopt;
  const cv::Matx33d H(Hm);
  // Square (i, j) lies between corners (i - 1, j - 1) and (i, j); the block's corners c0..c0 + bx - 1
  // bound the squares i = c0 + 1 .. c0 + bx - 1 (and likewise for j): up to 2 x 2 interior squares.
  double white = 0.0, black = 0.0;
  int n_white = 0, n_black = 0;
  for (int j = r0 + 1; j < r0 + by; ++j) {
    for (int i = c0 + 1; i < c0 + bx; ++i) {
      const auto m = squareMean(gray, H, i, j);
      if (!m) return std::nullopt;
      if (sim::isBlackSquare(i, j)) {
        black += *m, ++n_black;
      } else {
        white += *m, ++n_white;
      }
    }
  }
  if (n_white == 0 || n_black == 0) return std::nullopt;  // a 2 x 2-corner board: one square only
  return white / n_white - black / n_black;
}

std::vector<Eigen::Vector2d> reversedOrder(const std::vector<Eigen::Vector2d>& v) { return {v.rbegin(), v.rend()}; }

}  // namespace

const char* toString(Detector d) { return d == Detector::kClassic ? "classic" : "sb"; }

Detector parseDetector(const std::string& name) {
  if (name == "classic") return Detector::kClassic;
  if (name == "sb") return Detector::kSectorBased;
  throw std::invalid_argument("parseDetector: expected 'classic' or 'sb', got '" + name + "'");
}

const char* toString(ImageStatus s) {
  switch (s) {
    case ImageStatus::kFound: return "found";
    case ImageStatus::kNotFound: return "not_found";
    case ImageStatus::kRejected: return "rejected";
    case ImageStatus::kUnreadable: return "unreadable";
  }
  return "?";
}

ImageStatus parseImageStatus(const std::string& word) {
  for (ImageStatus s : {ImageStatus::kFound, ImageStatus::kNotFound, ImageStatus::kRejected, ImageStatus::kUnreadable}) {
    if (word == toString(s)) return s;
  }
  throw std::invalid_argument("parseImageStatus: expected found, not_found, rejected or unreadable, got '" + word + "'");
}

bool isHalfTurnSymmetric(const sim::Board& board) { return (board.corners_x + board.corners_y) % 2 == 0; }

OrientationEvidence orientationEvidence(const cv::Mat& gray, const sim::Board& board,
                                        const std::vector<Eigen::Vector2d>& corners_px) {
  if (static_cast<int>(corners_px.size()) != board.numCorners()) {
    throw std::invalid_argument("orientationEvidence: expected " + std::to_string(board.numCorners()) + " corners, got " +
                                std::to_string(corners_px.size()));
  }
  OrientationEvidence ev;
  ev.end_contrast = {endContrast(gray, board, corners_px, true), endContrast(gray, board, corners_px, false)};
  double sum = 0.0;
  for (const auto& c : ev.end_contrast) {
    if (c) sum += *c, ++ev.ends_sampled;
  }
  if (ev.ends_sampled > 0) ev.signed_contrast = sum / ev.ends_sampled;
  // Both ends read from one board must agree: opposite signs mean one end's colours are not the
  // board's (a different pattern, an occluder, glare), so neither end can be trusted.
  if (ev.ends_sampled == 2) ev.consistent = (*ev.end_contrast[0] > 0.0) == (*ev.end_contrast[1] > 0.0);
  return ev;
}

CornerDetection CornerDetection::failed(ImageStatus status, std::string reason, std::string detail) {
  CornerDetection d;
  d.status = status;
  d.reason = std::move(reason);
  d.detail = std::move(detail);
  return d;
}

std::string subpixWindowText(const DetectorSettings& s) {
  const std::string opencv = "OpenCV's calibration tutorial: 11 px";
  if (s.fixed_subpix_half_window_px > 0) {
    return "corner refinement: cornerSubPix half window " + std::to_string(s.fixed_subpix_half_window_px) + " px (" + opencv + ")";
  }
  return "corner refinement: cornerSubPix half window min(" + std::to_string(s.max_subpix_half_window_px) +
         " px, 0.4 x the corner spacing) (" + opencv + "; --subpix-window 11 uses it)";
}

void refineCornersSubPix(const cv::Mat& gray, std::vector<cv::Point2f>& corners, double half_window_px, int max_half_window_px) {
  if (corners.empty()) return;
  const int half = std::clamp(static_cast<int>(half_window_px), 1, std::max(1, max_half_window_px));
  cv::cornerSubPix(gray, corners, cv::Size(half, half), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-4));
}

CornerDetection detectCorners(const cv::Mat& gray, const sim::Board& board, const DetectorSettings& settings) {
  if (gray.empty() || gray.type() != CV_8UC1) {
    throw std::invalid_argument("detectCorners: expected a non-empty CV_8UC1 image, got type " +
                                std::to_string(gray.type()) + (gray.empty() ? " (empty)" : ""));
  }
  if (board.corners_x < 2 || board.corners_y < 2) {
    throw std::invalid_argument("detectCorners: expected a board of at least 2 x 2 inner corners, got " +
                                std::to_string(board.corners_x) + " x " + std::to_string(board.corners_y));
  }
  const std::string pattern = std::to_string(board.corners_x) + "x" + std::to_string(board.corners_y);

  double lo = 0.0, hi = 0.0;
  cv::minMaxLoc(gray, &lo, &hi);
  if (hi - lo < settings.min_grey_spread) {
    return CornerDetection::failed(ImageStatus::kNotFound, "blank image",
                "grey levels span " + fmt(lo, 0) + ".." + fmt(hi, 0) + " (< " + fmt(settings.min_grey_spread, 0) + ")");
  }

  const cv::Size size(board.corners_x, board.corners_y);
  std::vector<cv::Point2f> found;
  bool ok = false;
  if (settings.detector == Detector::kClassic) {
    ok = cv::findChessboardCorners(gray, size, found,
                                   cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_FAST_CHECK);
  } else {
    ok = cv::findChessboardCornersSB(gray, size, found, cv::CALIB_CB_NORMALIZE_IMAGE);
  }
  if (!ok || static_cast<int>(found.size()) != board.numCorners()) {
    return CornerDetection::failed(ImageStatus::kNotFound, "no board found",
                std::string("no ") + pattern + " inner-corner chessboard found (" + toString(settings.detector) + ")");
  }

  if (settings.detector == Detector::kClassic) {
    double d_min = std::numeric_limits<double>::max();
    for (int r = 0; r < board.corners_y; ++r) {
      for (int c = 0; c < board.corners_x; ++c) {
        const cv::Point2f p = found[r * board.corners_x + c];
        if (c + 1 < board.corners_x) d_min = std::min(d_min, cv::norm(p - found[r * board.corners_x + c + 1]));
        if (r + 1 < board.corners_y) d_min = std::min(d_min, cv::norm(p - found[(r + 1) * board.corners_x + c]));
      }
    }
    const int fixed = settings.fixed_subpix_half_window_px;
    refineCornersSubPix(gray, found, fixed > 0 ? fixed : 0.4 * d_min, fixed > 0 ? fixed : settings.max_subpix_half_window_px);
  }

  CornerDetection d;
  d.corners_px.reserve(found.size());
  for (const auto& p : found) d.corners_px.emplace_back(p.x, p.y);

  // Handedness: seen from its printed face the board's x (along a row) and y (down a column) keep the
  // image's orientation. A mirrored order (rows read right to left) is turned into a proper one first.
  {
    const Eigen::Vector2d a = d.corners_px[board.corners_x - 1] - d.corners_px[0];
    const Eigen::Vector2d b = d.corners_px[(board.corners_y - 1) * board.corners_x] - d.corners_px[0];
    if (a.x() * b.y() - a.y() * b.x() < 0.0) {
      for (int r = 0; r < board.corners_y; ++r) {
        auto row = d.corners_px.begin() + r * board.corners_x;
        std::reverse(row, row + board.corners_x);
      }
    }
  }

  if (isHalfTurnSymmetric(board)) {
    if (settings.require_orientation) {
      return CornerDetection::failed(ImageStatus::kRejected, "orientation undecidable",
                  "a " + pattern + " board looks the same after a half turn (use an even-by-odd square count)");
    }
    d.status = ImageStatus::kFound;
    return d;
  }

  const OrientationEvidence ev = orientationEvidence(gray, board, d.corners_px);
  if (!ev.consistent) {
    const std::string why = "end-square contrast " + fmt(*ev.end_contrast[0]) + " at corner 0 but " +
                            fmt(*ev.end_contrast[1]) + " at the last corner (grey levels; the signs must agree)";
    if (settings.require_orientation) return CornerDetection::failed(ImageStatus::kRejected, "orientation evidence inconsistent", why);
    d.status = ImageStatus::kFound;
    d.detail = "orientation unknown: " + why;
    return d;
  }
  const bool decided = ev.ends_sampled > 0 && std::abs(ev.signed_contrast) >= settings.min_orientation_contrast;
  if (!decided) {
    const std::string why = ev.ends_sampled == 0 ? "the squares next to both end corners are not wholly in the image"
                                                 : "end-square contrast " + fmt(std::abs(ev.signed_contrast)) +
                                                       " grey levels < " + fmt(settings.min_orientation_contrast);
    if (settings.require_orientation) return CornerDetection::failed(ImageStatus::kRejected, "orientation undecidable", why);
    d.status = ImageStatus::kFound;
    d.detail = "orientation unknown: " + why;
    return d;
  }
  if (ev.signed_contrast < 0.0) {
    d.corners_px = reversedOrder(d.corners_px);
    d.reversed = true;
  }
  d.orientation_known = true;
  d.orientation_contrast = std::abs(ev.signed_contrast);
  d.status = ImageStatus::kFound;
  return d;
}

}  // namespace orbcal::vision
