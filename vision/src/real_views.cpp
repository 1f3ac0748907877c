#include "orbcal/vision/real_views.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/photo.hpp>
#include <limits>
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <optional>
#include <set>
#include <stdexcept>

#include "orbcal/sim/image_files.hpp"
#include "orbcal/vision/charuco.hpp"

namespace orbcal::vision {

namespace {

constexpr int kMinChannelExcess = 40;  ///< a drawn colour: one channel above both others by more than this (of 255)
constexpr double kInpaintRadiusPx = 3.0;
constexpr int kEdgePx = 8;             ///< corners predicted closer than this to the image's edge are not refined
constexpr double kMaxCornerMovePx = 2.0;  ///< a refined corner further than this from its prediction is not the corner
constexpr int kMinSeedMarkers = 3;     ///< markers for a seed pose when too few corners were interpolated
constexpr int kMinCorners = 6;         ///< as vision::estimateBoardPose needs

bool anyRule(const sim::ImageMask& mask, const std::string& view_mask) {
  return mask.ignore_coloured || !mask.mask_file.empty() || !mask.rectangles.empty() || !view_mask.empty();
}

void addMaskFile(cv::Mat& ignored, const std::string& path) {
  const cv::Mat m = sim::readImage(path, cv::IMREAD_GRAYSCALE);
  if (m.empty()) throw std::invalid_argument(path + ": cannot read the mask image");
  if (m.size() != ignored.size()) {
    throw std::invalid_argument(path + ": the mask is " + std::to_string(m.cols) + "x" + std::to_string(m.rows) + " px, the image " +
                                std::to_string(ignored.cols) + "x" + std::to_string(ignored.rows));
  }
  cv::Mat nonzero;
  cv::compare(m, 0, nonzero, cv::CMP_GT);
  ignored |= nonzero;
}

/// The board's markers whose centre `m`'s pose puts inside the image, and not among `found`.
std::vector<int> lostMarkers(const Measurement& m, const sim::Camera& camera, const sim::Board& board, const std::vector<int>& found) {
  const std::set<int> decoded(found.begin(), found.end());
  std::vector<int> lost;
  for (const sim::CharucoMarker& marker : sim::charucoMarkers(board)) {
    const Eigen::Vector3d centre = marker.top_left + Eigen::Vector3d(0.5 * board.marker_m, 0.5 * board.marker_m, 0.0);
    const Eigen::Vector3d p = m.camera_T_board * centre;
    if (p.z() <= 0.0 || decoded.count(marker.id)) continue;
    const Eigen::Vector2d uv = sim::project(camera, p);
    if (uv.x() >= 0 && uv.y() >= 0 && uv.x() < camera.width_px && uv.y() < camera.height_px) lost.push_back(marker.id);
  }
  return lost;
}

/// The pose of the decoded markers (at least kMinSeedMarkers), in orbcal's board frame; nullopt otherwise.
std::optional<Eigen::Isometry3d> markerPose(const CharucoDetection& det, const sim::Camera& camera, const sim::Board& board) {
  if (static_cast<int>(det.marker_ids.size()) < kMinSeedMarkers) return std::nullopt;
  sim::ArucoDictionaryInfo info;
  sim::arucoDictionary(board.dictionary, &info);
  const cv::Ptr<cv::aruco::CharucoBoard> cv_board = cv::aruco::CharucoBoard::create(
      board.corners_x + 1, board.corners_y + 1, static_cast<float>(board.square_m), static_cast<float>(board.marker_m),
      cv::aruco::getPredefinedDictionary(static_cast<cv::aruco::PREDEFINED_DICTIONARY_NAME>(info.cv_id)));
  const cv::Matx33d K(camera.fx_px, 0, camera.cx_px, 0, camera.fy_px, camera.cy_px, 0, 0, 1);
  const cv::Mat dist(1, 5, CV_64F, const_cast<double*>(camera.distortion.data()));
  cv::Vec3d rvec, tvec;
  const cv::Ptr<cv::aruco::Board> as_board = cv_board;
  if (cv::aruco::estimatePoseBoard(det.marker_corners, det.marker_ids, as_board, K, dist.clone(), rvec, tvec) <= 0) return std::nullopt;
  cv::Matx33d R;
  cv::Rodrigues(rvec, R);
  Eigen::Isometry3d camera_T_cvboard = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) camera_T_cvboard.linear()(i, j) = R(i, j);
    camera_T_cvboard.translation()[i] = tvec[i];
  }
  if (camera_T_cvboard.translation().z() <= 0.0) return std::nullopt;
  return camera_T_cvboard * sim::printedFromBoard(board, sim::BoardFrameConvention::kOpenCv);  // OpenCV's frame = orbcal's + (s, s)
}

/// Every inner corner `camera_T_board` puts inside the image, refined and gated (file comment of the header).
void refinePredicted(const cv::Mat& gray, const sim::Camera& camera, const sim::Board& board, const Eigen::Isometry3d& camera_T_board,
                     std::vector<Eigen::Vector2d>& px, std::vector<int>& ids) {
  const std::vector<Eigen::Vector2d> predicted = projectBoard(camera, board, camera_T_board);
  double d_min = std::numeric_limits<double>::max();
  std::vector<cv::Point2f> corners;
  std::vector<int> which;
  for (int k = 0; k < board.numCorners(); ++k) {
    const Eigen::Vector2d& p = predicted[static_cast<std::size_t>(k)];
    if ((camera_T_board * sim::cornerInBoard(board, k)).z() <= 0.0) continue;
    if (p.x() < kEdgePx || p.y() < kEdgePx || p.x() > gray.cols - kEdgePx || p.y() > gray.rows - kEdgePx) continue;
    if (k % board.corners_x + 1 < board.corners_x) d_min = std::min(d_min, (predicted[static_cast<std::size_t>(k + 1)] - p).norm());
    if (k + board.corners_x < board.numCorners()) d_min = std::min(d_min, (predicted[static_cast<std::size_t>(k + board.corners_x)] - p).norm());
    corners.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
    which.push_back(k);
  }
  px.clear();
  ids.clear();
  if (corners.empty()) return;
  const double inset = 0.5 * (board.square_m - board.marker_m) / board.square_m;
  const std::vector<cv::Point2f> before = corners;
  refineCornersSubPix(gray, corners, std::min(0.4, 0.9 * inset) * d_min, 5);
  for (std::size_t n = 0; n < corners.size(); ++n) {
    if (cv::norm(corners[n] - before[n]) < kMaxCornerMovePx) {
      px.emplace_back(corners[n].x, corners[n].y);
      ids.push_back(which[n]);
    }
  }
}

/// Whether the image's squares are coloured as the pose says: sampled in the white ring between a square's
/// edge and its marker (ChArUco) or at the square's centre (chessboard), the white squares must be brighter
/// than the black ones by kMinContrast grey levels on average. A pose shifted by one square (a misread marker
/// seeding it: every chessboard corner looks alike) swaps them.
bool colouringAgrees(const cv::Mat& gray, const sim::Camera& camera, const sim::Board& board, const Eigen::Isometry3d& camera_T_board) {
  constexpr double kMinContrast = 20.0;
  const double s = board.square_m;
  const double off = board.type == sim::BoardType::kCharuco ? 0.5 * s - 0.25 * (s - board.marker_m) : 0.0;
  double sum[2] = {0.0, 0.0};
  int count[2] = {0, 0};
  for (int i = 0; i <= board.corners_x; ++i) {
    for (int j = 0; j <= board.corners_y; ++j) {
      const Eigen::Vector3d centre((i - 0.5) * s, (j - 0.5) * s, 0.0);
      const int black = sim::isBlackSquare(i, j) ? 1 : 0;
      for (const Eigen::Vector3d& d : {Eigen::Vector3d(off, 0, 0), Eigen::Vector3d(-off, 0, 0), Eigen::Vector3d(0, off, 0), Eigen::Vector3d(0, -off, 0)}) {
        const Eigen::Vector3d p = camera_T_board * (centre + d);
        if (p.z() <= 0.0) continue;
        const Eigen::Vector2d uv = sim::project(camera, p);
        const int u = static_cast<int>(std::lround(uv.x())), v = static_cast<int>(std::lround(uv.y()));
        if (u < 0 || v < 0 || u >= gray.cols || v >= gray.rows) continue;
        sum[black] += gray.at<unsigned char>(v, u);
        ++count[black];
      }
    }
  }
  return count[0] > 0 && count[1] > 0 && sum[0] / count[0] - sum[1] / count[1] >= kMinContrast;
}

/// The board measured at every corner a seed pose predicts (two rounds); not found when fewer than
/// kMinCorners survive, the corners lie on one row or column, or the pose's RMS exceeds the settings'.
Measurement completedMeasurement(const cv::Mat& gray, const sim::Camera& camera, const sim::Board& board, Eigen::Isometry3d seed,
                                 const MeasureSettings& settings) {
  Measurement m;
  m.status = ImageStatus::kNotFound;
  m.reason = "too few corners where the markers' pose puts them";
  for (int round = 0; round < 2; ++round) {
    std::vector<Eigen::Vector2d> px;
    std::vector<int> ids;
    refinePredicted(gray, camera, board, seed, px, ids);
    std::set<int> rows, cols;
    for (int id : ids) {
      rows.insert(id / board.corners_x);
      cols.insert(id % board.corners_x);
    }
    if (static_cast<int>(ids.size()) < kMinCorners || rows.size() < 2 || cols.size() < 2) return m;
    const BoardPose pose = estimateBoardPose(camera, board, px, ids);
    if (!pose.ok || !(pose.rms_px <= settings.max_rms_px)) return m;
    if (!colouringAgrees(gray, camera, board, pose.camera_T_board)) {
      m.reason = "the squares' colouring contradicts the markers' pose (a marker misread?)";
      return m;
    }
    seed = pose.camera_T_board;
    m.status = ImageStatus::kFound;
    m.reason.clear();
    m.num_corners = static_cast<int>(ids.size());
    m.rms_px = pose.rms_px;
    m.camera_T_board = pose.camera_T_board;
    m.covariance = pose.covariance_camera;
    m.corners_px = px;
    m.corner_ids = ids;
  }
  return m;
}

}  // namespace

cv::Mat ignoredPixels(const cv::Mat& bgr, const sim::ImageMask& mask, const std::string& view_mask) {
  cv::Mat ignored = cv::Mat::zeros(bgr.size(), CV_8UC1);
  if (mask.ignore_coloured && bgr.channels() == 3) {
    cv::Mat ch[3];
    cv::split(bgr, ch);
    for (int c = 0; c < 3; ++c) {
      cv::Mat others, excess, drawn;
      cv::max(ch[(c + 1) % 3], ch[(c + 2) % 3], others);
      cv::subtract(ch[c], others, excess);  // saturates at 0
      cv::compare(excess, kMinChannelExcess, drawn, cv::CMP_GT);
      ignored |= drawn;
    }
  }
  for (const auto& r : mask.rectangles) {
    const cv::Rect rect = cv::Rect(r[0], r[1], r[2] - r[0], r[3] - r[1]) & cv::Rect(0, 0, bgr.cols, bgr.rows);
    if (rect.area() > 0) ignored(rect).setTo(255);
  }
  if (!mask.mask_file.empty()) addMaskFile(ignored, mask.mask_file);
  if (!view_mask.empty()) addMaskFile(ignored, view_mask);
  return ignored;
}

cv::Mat fillIgnored(const cv::Mat& image, const cv::Mat& ignored) {
  if (ignored.empty() || cv::countNonZero(ignored) == 0) return image;
  cv::Mat filled;
  cv::inpaint(image, ignored, filled, kInpaintRadiusPx, cv::INPAINT_TELEA);
  return filled;
}

ViewMeasurement measureGray(const cv::Mat& gray, const sim::Camera& camera, const sim::Board& board, const MeasureSettings& settings) {
  ViewMeasurement v;
  Measurement& m = v.measurement;
  sim::Scene scene;
  scene.camera = camera;
  scene.board = board;
  m = measureImage(gray, scene, sim::Arm{}, Eigen::VectorXd(), settings);
  if (board.type == sim::BoardType::kCharuco && gray.cols == camera.width_px && gray.rows == camera.height_px) {
    const CharucoDetection det = detectCharuco(gray, board, &camera);
    const std::optional<Eigen::Isometry3d> seed = m.found() ? std::optional<Eigen::Isometry3d>(m.camera_T_board) : markerPose(det, camera, board);
    if (seed) {
      const Measurement completed = completedMeasurement(gray, camera, board, *seed, settings);
      if (completed.found() && completed.num_corners > m.num_corners) m = completed;
    }
    if (m.found()) v.lost_markers = lostMarkers(m, camera, board, det.marker_ids);
    v.markers = det.markers;
  }
  return v;
}

ViewMeasurement measureView(const std::string& path, const sim::Camera& camera, const sim::Board& board,
                            const sim::ImageMask& mask, const std::string& view_mask, const MeasureSettings& settings) {
  ViewMeasurement v;
  Measurement& m = v.measurement;
  m.image = path;
  cv::Mat gray = readGrayImage(path, &m.reason, &m.detail);
  if (gray.empty()) {
    m.status = ImageStatus::kUnreadable;
    return v;
  }
  if (anyRule(mask, view_mask)) {
    const cv::Mat colour = sim::readImage(path, cv::IMREAD_COLOR);
    const cv::Mat ignored = ignoredPixels(colour, mask, view_mask);
    v.ignored_px = cv::countNonZero(ignored);
    if (v.ignored_px > 0) cv::cvtColor(fillIgnored(colour, ignored), gray, cv::COLOR_BGR2GRAY);
  }
  const int ignored_px = v.ignored_px;
  v = measureGray(gray, camera, board, settings);
  v.ignored_px = ignored_px;
  v.measurement.image = path;
  return v;
}

}  // namespace orbcal::vision
