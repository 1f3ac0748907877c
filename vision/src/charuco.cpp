#include "orbcal/vision/charuco.hpp"

#include <algorithm>
#include <limits>
#include <numeric>
#include <opencv2/aruco/charuco.hpp>
#include <set>
#include <stdexcept>

namespace orbcal::vision {

namespace {
constexpr int kMaxSubPixHalfWindowPx = 5;  // DetectorSettings::max_subpix_half_window_px's default
}  // namespace

CharucoDetection detectCharuco(const cv::Mat& gray, const sim::Board& board, const sim::Camera* camera, int min_corners) {
  if (gray.empty() || gray.type() != CV_8UC1) throw std::invalid_argument("detectCharuco: expected a CV_8UC1 image");
  sim::ArucoDictionaryInfo info;
  if (board.type != sim::BoardType::kCharuco || !sim::arucoDictionary(board.dictionary, &info)) {
    throw std::invalid_argument("detectCharuco: not a ChArUco board with a known dictionary");
  }
  const cv::Ptr<cv::aruco::Dictionary> dictionary =
      cv::aruco::getPredefinedDictionary(static_cast<cv::aruco::PREDEFINED_DICTIONARY_NAME>(info.cv_id));
  const cv::Ptr<cv::aruco::CharucoBoard> cv_board =
      cv::aruco::CharucoBoard::create(board.corners_x + 1, board.corners_y + 1, static_cast<float>(board.square_m),
                                      static_cast<float>(board.marker_m), dictionary);
  CharucoDetection d;
  std::vector<std::vector<cv::Point2f>> marker_corners, rejected;
  std::vector<int> marker_ids;
  const cv::Ptr<cv::aruco::DetectorParameters> params = cv::aruco::DetectorParameters::create();
  cv::aruco::detectMarkers(gray, dictionary, marker_corners, marker_ids, params, rejected);
  // Markers of this board only (a dictionary holds more ids than the board uses).
  const int board_markers = static_cast<int>(cv_board->ids.size());
  std::vector<std::vector<cv::Point2f>> kept_corners;
  std::vector<int> kept_ids;
  for (std::size_t m = 0; m < marker_ids.size(); ++m) {
    if (marker_ids[m] < board_markers) {
      kept_ids.push_back(marker_ids[m]);
      kept_corners.push_back(marker_corners[m]);
    }
  }
  d.markers = static_cast<int>(kept_ids.size());
  d.marker_ids = kept_ids;
  d.marker_corners = kept_corners;
  if (kept_ids.empty()) {
    d.reason = "no board found";
    d.detail = "no ArUco marker of the board's " + board.dictionary + " ids 0.." + std::to_string(board_markers - 1);
    return d;
  }
  std::vector<cv::Point2f> corners;
  std::vector<int> ids;
  if (camera) {
    const cv::Matx33d K(camera->fx_px, 0, camera->cx_px, 0, camera->fy_px, camera->cy_px, 0, 0, 1);
    const cv::Mat dist(1, 5, CV_64F, const_cast<double*>(camera->distortion.data()));
    cv::aruco::interpolateCornersCharuco(kept_corners, kept_ids, gray, cv_board, corners, ids, K, dist.clone());
  } else {
    cv::aruco::interpolateCornersCharuco(kept_corners, kept_ids, gray, cv_board, corners, ids);
  }
  // OpenCV 4.6 refines with windows that left its corners ~0.7 px off on rendered boards (docs, ChArUco):
  // refine again as the chessboard detector does, the window kept off the neighbouring corners (0.4 of
  // their spacing) and off the markers (inset (square - marker) / 2 from the square's edges).
  if (!ids.empty()) {
    double d_min = std::numeric_limits<double>::max();
    for (std::size_t a = 0; a < ids.size(); ++a) {
      for (std::size_t b = 0; b < ids.size(); ++b) {
        const bool right = ids[b] == ids[a] + 1 && ids[a] % board.corners_x + 1 < board.corners_x;
        if (right || ids[b] == ids[a] + board.corners_x) d_min = std::min(d_min, static_cast<double>(cv::norm(corners[a] - corners[b])));
      }
    }
    if (d_min == std::numeric_limits<double>::max()) d_min = 0.0;
    const double inset = 0.5 * (board.square_m - board.marker_m) / board.square_m;
    refineCornersSubPix(gray, corners, std::min(0.4, 0.9 * inset) * d_min, kMaxSubPixHalfWindowPx);
  }
  std::vector<std::size_t> order(ids.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return ids[a] < ids[b]; });
  std::set<int> rows, cols;
  for (const std::size_t o : order) {
    d.ids.push_back(ids[o]);
    d.corners_px.emplace_back(corners[o].x, corners[o].y);
    rows.insert(ids[o] / board.corners_x);
    cols.insert(ids[o] % board.corners_x);
  }
  if (static_cast<int>(d.ids.size()) < min_corners || rows.size() < 2 || cols.size() < 2) {
    d.reason = "too few ChArUco corners";
    d.detail = std::to_string(d.ids.size()) + " corners from " + std::to_string(d.markers) + " markers (need " +
               std::to_string(min_corners) + ", on 2 rows and 2 columns at least)";
    return d;
  }
  d.status = ImageStatus::kFound;
  return d;
}

}  // namespace orbcal::vision
