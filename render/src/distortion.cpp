#include "orbcal/render/distortion.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

namespace orbcal::render {

namespace {
constexpr int kMaxNewtonIterations = 50;
constexpr double kNewtonTol = 1e-14;  // normalised units: ~1e-11 px at f = 1400 px
constexpr int kBorderPx = 2;          // around the used area of the pinhole image: bicubic lookups read 4 x 4 pixels (-1..+2)
}  // namespace

bool undistortNormalized(const std::array<double, 5>& k, const Eigen::Vector2d& xd, Eigen::Vector2d* out) {
  Eigen::Vector2d x = xd;
  for (int it = 0; it < kMaxNewtonIterations; ++it) {
    Eigen::Matrix2d J;
    const Eigen::Vector2d f = sim::distortNormalized(k, x, &J) - xd;
    const double det = J.determinant();
    if (!(det > 0.0)) return false;
    if (std::abs(f.x()) < kNewtonTol && std::abs(f.y()) < kNewtonTol) {
      *out = x;
      return true;
    }
    x -= Eigen::Vector2d(J(1, 1) * f.x() - J(0, 1) * f.y(), J(0, 0) * f.y() - J(1, 0) * f.x()) / det;
    if (!std::isfinite(x.x()) || !std::isfinite(x.y())) return false;
  }
  return false;
}

DistortionMap makeDistortionMap(const sim::Camera& camera, int max_side_px) {
  const int W = camera.width_px, H = camera.height_px;
  cv::Mat nx(H, W, CV_64FC1), ny(H, W, CV_64FC1);
  cv::Mat valid(H, W, CV_8UC1, cv::Scalar(0));
  double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      const Eigen::Vector2d xd((u - camera.cx_px) / camera.fx_px, (v - camera.cy_px) / camera.fy_px);
      Eigen::Vector2d x;
      if (!undistortNormalized(camera.distortion, xd, &x)) continue;
      nx.at<double>(v, u) = x.x();
      ny.at<double>(v, u) = x.y();
      valid.at<unsigned char>(v, u) = 1;
      xmin = std::min(xmin, x.x());
      xmax = std::max(xmax, x.x());
      ymin = std::min(ymin, x.y());
      ymax = std::max(ymax, x.y());
    }
  }
  DistortionMap m;
  m.pinhole = camera;
  m.pinhole.distortion = {0, 0, 0, 0, 0};
  if (xmin > xmax) {  // nothing invertible: keep the camera, map everything to background
    m.map_x = cv::Mat(H, W, CV_32FC1, cv::Scalar(-1));
    m.map_y = cv::Mat(H, W, CV_32FC1, cv::Scalar(-1));
    return m;
  }
  double scale = 1.0;
  const double need_w = camera.fx_px * (xmax - xmin) + 2 * kBorderPx + 1;
  const double need_h = camera.fy_px * (ymax - ymin) + 2 * kBorderPx + 1;
  scale = std::min({1.0, (max_side_px - 1.0) / need_w, (max_side_px - 1.0) / need_h});
  m.pinhole.fx_px = camera.fx_px * scale;
  m.pinhole.fy_px = camera.fy_px * scale;
  m.pinhole.cx_px = kBorderPx - m.pinhole.fx_px * xmin;
  m.pinhole.cy_px = kBorderPx - m.pinhole.fy_px * ymin;
  m.pinhole.width_px = static_cast<int>(std::ceil(m.pinhole.fx_px * xmax + m.pinhole.cx_px)) + kBorderPx + 1;
  m.pinhole.height_px = static_cast<int>(std::ceil(m.pinhole.fy_px * ymax + m.pinhole.cy_px)) + kBorderPx + 1;
  m.map_x.create(H, W, CV_32FC1);
  m.map_y.create(H, W, CV_32FC1);
  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      const bool ok = valid.at<unsigned char>(v, u) != 0;
      m.map_x.at<float>(v, u) = ok ? static_cast<float>(m.pinhole.fx_px * nx.at<double>(v, u) + m.pinhole.cx_px) : -1.f;
      m.map_y.at<float>(v, u) = ok ? static_cast<float>(m.pinhole.fy_px * ny.at<double>(v, u) + m.pinhole.cy_px) : -1.f;
    }
  }
  return m;
}

cv::Mat applyDistortion(const DistortionMap& map, const cv::Mat& pinhole_image, double background) {
  cv::Mat out;
  cv::remap(pinhole_image, out, map.map_x, map.map_y, cv::INTER_CUBIC, cv::BORDER_CONSTANT, cv::Scalar::all(background));
  return out;
}

}  // namespace orbcal::render
