// The renderer's camera model against OpenCV's: the GL projection, supersampling, the inverse distortion.
#include <catch2/catch.hpp>
#include <random>

#include "orbcal/render/distortion.hpp"
#include "orbcal/render/renderer.hpp"
#include "orbcal/sim/scene.hpp"

using namespace orbcal;

namespace {
constexpr double kProjectionTolPx = 1e-9;  // double arithmetic on ~1e3 px values
constexpr double kInverseTolPx = 1e-8;     // Newton stops at 1e-14 normalised (~1e-11 px)

/// Pixel (OpenCV convention) where GL puts p_cam: clip -> NDC -> window, row flip, half-pixel shift.
Eigen::Vector2d glPixel(const sim::Camera& c, const Eigen::Vector3d& p_cam) {
  const Eigen::Matrix4d P = render::glProjection(c, 0.02, 2000.0);
  const Eigen::Vector4d eye(p_cam.x(), -p_cam.y(), -p_cam.z(), 1.0);
  const Eigen::Vector4d clip = P * eye;
  const double xw = (clip.x() / clip.w() + 1.0) * 0.5 * c.width_px;
  const double yw = (clip.y() / clip.w() + 1.0) * 0.5 * c.height_px;
  return {xw - 0.5, c.height_px - yw - 0.5};
}
}  // namespace

TEST_CASE("GL projection equals OpenCV's pinhole model with an off-centre principal point", "[render][projection]") {
  sim::Camera c;
  c.width_px = 1280, c.height_px = 1024, c.fx_px = 1400, c.fy_px = 1380, c.cx_px = 700.3, c.cy_px = 470.7;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> xy(-1.0, 1.0), z(0.5, 5.0);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d p(xy(rng), xy(rng), z(rng));
    const Eigen::Vector2d gl = glPixel(c, p), cv = sim::project(c, p);
    CAPTURE(p.transpose(), gl.transpose(), cv.transpose());
    REQUIRE((gl - cv).norm() < kProjectionTolPx);
  }
}

TEST_CASE("supersampling scales the principal point as s(c+0.5)-0.5", "[render][projection]") {
  sim::Camera c;
  c.cx_px = 643.3, c.cy_px = 508.9;
  for (int s : {2, 3, 4}) {
    const sim::Camera big = render::scaledCamera(c, s);
    // A point at pixel (u, v) of the small image covers big pixels whose centres average to s(u+0.5)-0.5.
    const Eigen::Vector3d p(0.12, -0.07, 1.9);
    const Eigen::Vector2d small = sim::project(c, p), large = sim::project(big, p);
    REQUIRE((large - (s * (small.array() + 0.5) - 0.5).matrix()).norm() < kProjectionTolPx);
    REQUIRE(big.width_px == s * c.width_px);
  }
}

TEST_CASE("the distortion map equals the exact inverse at every pixel, with its shortcuts", "[render][distortion]") {
  // makeDistortionMap starts each pixel's Newton's method from its neighbours' rays and accepts a single
  // step from their extrapolation when that step is small. Against Newton's method from xd itself (to
  // 1e-14) at every pixel of the image: the same pixels have a ray, and the float map differs by no more
  // than its own rounding (float at ~2000 px: 6e-5 px) plus the shortcut's ~1e-7 px.
  sim::Camera c;
  c.cx_px = 643.3, c.cy_px = 508.9;
  for (const std::array<double, 5>& k : {std::array<double, 5>{-0.2, 0.08, 0.0008, -0.0006, -0.01},
                                         std::array<double, 5>{0.15, -0.05, -0.002, 0.001, 0.01}}) {
    c.distortion = k;
    const render::DistortionMap map = render::makeDistortionMap(c);
    CAPTURE(k[0]);
    double worst_px = 0;
    int mismatched = 0;
    for (int v = 0; v < c.height_px; ++v) {
      for (int u = 0; u < c.width_px; ++u) {
        Eigen::Vector2d x;
        const bool ok = render::undistortNormalized(k, Eigen::Vector2d((u - c.cx_px) / c.fx_px, (v - c.cy_px) / c.fy_px), &x);
        const float mx = map.map_x.at<float>(v, u), my = map.map_y.at<float>(v, u);
        if (ok != (mx >= 0.f)) {
          ++mismatched;
          continue;
        }
        if (!ok) continue;
        worst_px = std::max({worst_px, std::abs(mx - (map.pinhole.fx_px * x.x() + map.pinhole.cx_px)),
                             std::abs(my - (map.pinhole.fy_px * x.y() + map.pinhole.cy_px))});
      }
    }
    CHECK(mismatched == 0);
    CHECK(worst_px < 1.5e-4);
  }
}

TEST_CASE("the inverse distortion map sends each output pixel to its undistorted ray", "[render][distortion]") {
  sim::Camera c;
  c.cx_px = 643.3, c.cy_px = 508.9;
  for (const std::array<double, 5>& k : {std::array<double, 5>{-0.25, 0.12, 0.001, -0.0015, -0.02},
                                         std::array<double, 5>{0.15, -0.05, -0.002, 0.001, 0.01}}) {
    c.distortion = k;
    const render::DistortionMap map = render::makeDistortionMap(c);
    CAPTURE(k[0], map.pinhole.width_px, map.pinhole.height_px);
    REQUIRE(!map.pinhole.hasDistortion());
    int checked = 0;
    for (int v = 0; v < c.height_px; v += 37) {
      for (int u = 0; u < c.width_px; u += 41) {
        const float mx = map.map_x.at<float>(v, u), my = map.map_y.at<float>(v, u);
        REQUIRE(mx >= 0.f);  // every output pixel is covered by the pinhole image
        REQUIRE(my >= 0.f);
        REQUIRE(mx <= map.pinhole.width_px - 1);
        REQUIRE(my <= map.pinhole.height_px - 1);
        // The ray through pinhole pixel (mx, my), projected with the distorted camera, lands on (u, v).
        const Eigen::Vector3d ray((mx - map.pinhole.cx_px) / map.pinhole.fx_px, (my - map.pinhole.cy_px) / map.pinhole.fy_px, 1);
        const Eigen::Vector2d uv = sim::project(c, ray);
        // float storage of the map limits this to ~1e-4 px
        REQUIRE((uv - Eigen::Vector2d(u, v)).norm() < 2e-3);
        Eigen::Vector2d x;
        const Eigen::Vector2d xd((u - c.cx_px) / c.fx_px, (v - c.cy_px) / c.fy_px);
        REQUIRE(render::undistortNormalized(k, xd, &x));
        REQUIRE((sim::project(c, Eigen::Vector3d(x.x(), x.y(), 1.0)) - Eigen::Vector2d(u, v)).norm() < kInverseTolPx);
        ++checked;
      }
    }
    REQUIRE(checked > 500);
  }
}
