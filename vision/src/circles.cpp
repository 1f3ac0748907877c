#include "orbcal/vision/circles.hpp"

#include <algorithm>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <stdexcept>
#include <string>

namespace orbcal::vision {

namespace {

constexpr double kMinBlobAreaPx = 10.0;  ///< a circle smaller than ~3.6 px across is not measured to a tenth of a pixel
constexpr double kMinGreySpread = 16.0;  ///< as DetectorSettings::min_grey_spread: a blank image

/// z of (first row's direction) x (first column's direction) in the image: positive when the board's
/// x and y keep the image's orientation (its printed face seen), negative for a mirrored order.
double handedness(const std::vector<Eigen::Vector2d>& px, const sim::Board& board) {
  const Eigen::Vector2d a = px[static_cast<std::size_t>(board.corners_x - 1)] - px[0];
  const Eigen::Vector2d b = px[static_cast<std::size_t>((board.corners_y - 1) * board.corners_x)] - px[0];
  return a.x() * b.y() - a.y() * b.x();
}

/// The mirror image of the order: a symmetric grid's rows read the other way; an asymmetric grid's rows
/// in the other order (the mirror across its middle row maps it onto itself when the rows are odd in number).
std::vector<Eigen::Vector2d> mirrored(const std::vector<Eigen::Vector2d>& px, const sim::Board& board) {
  std::vector<Eigen::Vector2d> out(px.size());
  for (int r = 0; r < board.corners_y; ++r) {
    for (int c = 0; c < board.corners_x; ++c) {
      const int from = board.asymmetric ? (board.corners_y - 1 - r) * board.corners_x + c : r * board.corners_x + board.corners_x - 1 - c;
      out[static_cast<std::size_t>(r * board.corners_x + c)] = px[static_cast<std::size_t>(from)];
    }
  }
  return out;
}

}  // namespace

CornerDetection detectCircles(const cv::Mat& gray, const sim::Board& board) {
  if (gray.empty() || gray.type() != CV_8UC1) throw std::invalid_argument("detectCircles: expected a non-empty CV_8UC1 image");
  if (board.type != sim::BoardType::kCircles) throw std::invalid_argument("detectCircles: not a circle grid");
  const std::string pattern = std::to_string(board.corners_x) + "x" + std::to_string(board.corners_y) +
                              (board.asymmetric ? " asymmetric" : " symmetric");
  double lo = 0.0, hi = 0.0;
  cv::minMaxLoc(gray, &lo, &hi);
  if (hi - lo < kMinGreySpread) return CornerDetection::failed(ImageStatus::kNotFound, "blank image", "grey levels span less than 16");

  cv::SimpleBlobDetector::Params params;
  params.filterByColor = true;
  params.blobColor = 0;  // dark circles on white
  params.filterByArea = true;
  params.minArea = static_cast<float>(kMinBlobAreaPx);
  params.maxArea = static_cast<float>(static_cast<double>(gray.total()) / (2.0 * board.numCorners()));
  const cv::Ptr<cv::FeatureDetector> blobs = cv::SimpleBlobDetector::create(params);
  std::vector<cv::Point2f> found;
  const int flags = board.asymmetric ? cv::CALIB_CB_ASYMMETRIC_GRID : cv::CALIB_CB_SYMMETRIC_GRID;
  const cv::Size size(board.corners_x, board.corners_y);
  // The grid finder fails on a symmetric grid whose rows stand closer to the image's vertical; the clustering one
  // (more robust to perspective, more sensitive to clutter) then finds it.
  const bool ok = cv::findCirclesGrid(gray, size, found, flags, blobs) ||
                  cv::findCirclesGrid(gray, size, found, flags | cv::CALIB_CB_CLUSTERING, blobs);
  if (!ok || static_cast<int>(found.size()) != board.numCorners()) {
    return CornerDetection::failed(ImageStatus::kNotFound, "no board found", "no " + pattern + " circle grid found (findCirclesGrid)");
  }
  CornerDetection d;
  for (const cv::Point2f& p : found) d.corners_px.emplace_back(p.x, p.y);
  if (handedness(d.corners_px, board) < 0.0) {
    d.corners_px = mirrored(d.corners_px, board);
    if (handedness(d.corners_px, board) < 0.0) {
      return CornerDetection::failed(ImageStatus::kRejected, "mirrored order", "findCirclesGrid's order of the " + pattern + " grid is mirrored");
    }
  }
  d.orientation_known = !sim::halfTurnSymmetric(board);
  d.status = ImageStatus::kFound;
  return d;
}

Eigen::Vector2d ellipseCentreBias(const sim::Camera& camera, const sim::Board& board, const Eigen::Isometry3d& camera_T_board, int k) {
  const Eigen::Vector3d c = sim::cornerInBoard(board, k);
  const double r = 0.5 * board.diameter_m;
  Eigen::Matrix3d K;
  K << camera.fx_px, 0, camera.cx_px, 0, camera.fy_px, camera.cy_px, 0, 0, 1;
  Eigen::Matrix3d H;  // board plane (x, y, 1) -> pixel (homogeneous)
  H << camera_T_board.linear().col(0), camera_T_board.linear().col(1), camera_T_board.translation();
  H = K * H;
  // The circle's dual conic, C^-1 of C = [I, -c; -c^T, |c|^2 - r^2]: the image conic's dual is H C^-1 H^T, and the
  // ellipse's centre the pole of the line at infinity, H C^-1 H^T (0, 0, 1).
  Eigen::Matrix3d C;
  C << 1, 0, -c.x(), 0, 1, -c.y(), -c.x(), -c.y(), c.x() * c.x() + c.y() * c.y() - r * r;
  const Eigen::Vector3d e = H * C.inverse() * H.transpose() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d p = H * Eigen::Vector3d(c.x(), c.y(), 1.0);
  return e.hnormalized() - p.hnormalized();
}

}  // namespace orbcal::vision
