#include "orbcal/vision/synthetic.hpp"

#include <opencv2/imgproc.hpp>

namespace orbcal::vision {

namespace {
constexpr int kEdgeSegments = 8;  // polygon edges are split so that lens distortion bends them
constexpr int kShift = 4;         // fillPoly sub-pixel bits
}  // namespace

cv::Mat drawSyntheticBoard(const sim::Camera& camera, const sim::Board& board, const Eigen::Isometry3d& camera_T_board,
                           const SyntheticImageSettings& st) {
  const int s = std::max(1, st.supersample);
  cv::Mat big(camera.height_px * s, camera.width_px * s, CV_8UC1, cv::Scalar(st.background));
  const auto polygon = [&](double x0, double y0, double x1, double y1) {
    std::vector<cv::Point> pts;
    const double xs[4] = {x0, x1, x1, x0}, ys[4] = {y0, y0, y1, y1};
    for (int e = 0; e < 4; ++e) {
      for (int n = 0; n < kEdgeSegments; ++n) {
        const double t = static_cast<double>(n) / kEdgeSegments;
        const Eigen::Vector3d P(xs[e] + t * (xs[(e + 1) % 4] - xs[e]), ys[e] + t * (ys[(e + 1) % 4] - ys[e]), 0.0);
        const Eigen::Vector3d p = camera_T_board * P;
        if (p.z() <= 0.0) return std::vector<cv::Point>{};
        const Eigen::Vector2d uv = sim::project(camera, p);
        const double u = s * (uv.x() + 0.5) - 0.5, v = s * (uv.y() + 0.5) - 0.5;
        pts.emplace_back(cvRound(u * (1 << kShift)), cvRound(v * (1 << kShift)));
      }
    }
    return pts;
  };
  const double q = board.square_m, m = board.margin_m;
  const auto fill = [&](const std::vector<cv::Point>& pts, int grey) {
    if (pts.empty()) return;
    const std::vector<std::vector<cv::Point>> polys{pts};
    cv::fillPoly(big, polys, cv::Scalar(grey), cv::LINE_8, kShift);
  };
  fill(polygon(-q - m, -q - m, board.corners_x * q + m, board.corners_y * q + m), st.white);
  for (int j = 0; j <= board.corners_y; ++j) {
    for (int i = 0; i <= board.corners_x; ++i) {
      if (sim::isBlackSquare(i, j)) fill(polygon((i - 1) * q, (j - 1) * q, i * q, j * q), st.black);
    }
  }
  cv::Mat img;
  cv::resize(big, img, cv::Size(camera.width_px, camera.height_px), 0, 0, cv::INTER_AREA);
  if (st.noise_sigma > 0.0) {
    cv::RNG rng(st.seed);
    cv::Mat noise(img.size(), CV_32F), f;
    rng.fill(noise, cv::RNG::NORMAL, 0.0, st.noise_sigma);
    img.convertTo(f, CV_32F);
    f += noise;
    f.convertTo(img, CV_8U);  // saturating
  }
  return img;
}

}  // namespace orbcal::vision
