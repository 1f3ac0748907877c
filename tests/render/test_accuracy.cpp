// Rendered corners against cv::projectPoints of the true corners: the renderer's geometric accuracy.
#include <catch2/catch.hpp>
#include <cstdio>
#include <cstdlib>

#include "orbcal/render/renderer.hpp"
#include "orbcal/render/settings.hpp"
#include "orbcal/sim/io.hpp"
#include "render_test_util.hpp"

using namespace orbcal;

namespace {
constexpr double kMaxBiasPx = 0.02;  // mean detected-corner offset per axis
constexpr double kMaxRmsPx = 0.1;    // RMS of detected - true
// The default anti-aliasing (the analytic board filter, no MSAA) must keep the corners the
// benchmark asks for (0.05 px against cv::projectPoints over its 250 dataset views); on these test views
// it measured 0.051 px without and 0.049 px with distortion, so 0.06 px is a tightened bar (from 0.1).
constexpr double kMaxDefaultRmsPx = 0.06;
// MSAA on top of the board filter may improve the RMS by at most this factor: otherwise dropping MSAA
// from the defaults would have cost accuracy.
constexpr double kMaxMsaaGain = 1.1;
// With lens distortion the image is remapped bicubically: the reviewer measured a bias of (0.001, 0.002) px
// with bicubic and (-0.009, +0.0135) px with bilinear remapping, so 0.005 px keeps a margin over bicubic
// and catches a return to bilinear.
constexpr double kMaxDistortionBiasPx = 0.005;
// Without MSAA and without the analytic board filter, edges are point-sampled: the notes measured an
// RMS of 0.198 px against 0.073 px with MSAA 4. Requiring the no-AA RMS to exceed the MSAA RMS by this
// factor shows that MSAA is what brings the RMS under kMaxRmsPx (a broken MSAA path would give ~1).
constexpr double kMinNoAaRmsRatio = 1.5;
constexpr double kImageMarginPx = 15.0;
constexpr int kMinViews = 20;

struct View {
  double distance_m, tilt_deg, azimuth_deg, roll_deg;
};

bool wholeBoardInside(const sim::Scene& scene, const Eigen::Isometry3d& camera_T_board) {
  std::vector<Eigen::Vector3d> pts = sim::boardCorners(scene.board);
  for (const Eigen::Vector3d& p : sim::boardOutline(scene.board)) pts.push_back(p);  // with the margin
  for (const Eigen::Vector3d& p : pts) {
    const Eigen::Vector3d pc = camera_T_board * p;
    if (pc.z() <= 0) return false;
    const Eigen::Vector2d uv = sim::project(scene.camera, pc);
    if (uv.x() < kImageMarginPx || uv.y() < kImageMarginPx || uv.x() > scene.camera.width_px - 1 - kImageMarginPx ||
        uv.y() > scene.camera.height_px - 1 - kImageMarginPx) {
      return false;
    }
  }
  return true;
}

struct Accuracy {
  int views = 0;
  double bias_u = 0, bias_v = 0, rms = 0, max_err = 0;
};

Accuracy measure(const sim::Scene& scene, const render::RenderSettings& settings) {
  render::BoardRenderer renderer(scene, settings);
  REQUIRE(renderer.msaaSamples() == settings.options.msaa_samples);  // llvmpipe allows 4
  Accuracy a;
  double su = 0, sv = 0, s2 = 0;
  int n = 0, k = 0;
  for (double tilt : {0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0}) {
    for (double distance : {1.5, 1.8, 2.2, 2.6}) {
      ++k;
      const Eigen::Isometry3d camera_T_board =
          test::lookAtBoard(scene.board, distance, tilt, 53.0 * k, -30.0 + 17.0 * (k % 5));
      if (!wholeBoardInside(scene, camera_T_board)) continue;
      const cv::Mat img = renderer.renderClean(camera_T_board);
      const std::vector<cv::Point2d> truth = test::trueCorners(scene, camera_T_board);
      const auto found = test::detectCorners(img, scene.board, truth);
      CAPTURE(tilt, distance);
      REQUIRE(found);
      for (std::size_t i = 0; i < truth.size(); ++i) {
        const cv::Point2d d = (*found)[i] - truth[i];
        su += d.x, sv += d.y, s2 += d.dot(d);
        a.max_err = std::max(a.max_err, std::sqrt(d.dot(d)));
        ++n;
      }
      ++a.views;
      if (std::getenv("ORBCAL_TEST_VERBOSE")) {
        double e2 = 0, eu = 0, ev = 0;
        for (std::size_t i = 0; i < truth.size(); ++i) {
          const cv::Point2d d = (*found)[i] - truth[i];
          e2 += d.dot(d), eu += d.x, ev += d.y;
        }
        const double m = static_cast<double>(truth.size());
        std::printf("  view tilt %4.0f deg, %.1f m: bias (%+.3f, %+.3f) px, RMS %.3f px\n", tilt, distance, eu / m, ev / m,
                    std::sqrt(e2 / m));
      }
    }
  }
  a.bias_u = su / n, a.bias_v = sv / n, a.rms = std::sqrt(s2 / n);
  return a;
}

sim::Scene testScene() {
  sim::Scene scene = sim::loadScene(sim::kDefaultScene);
  scene.camera.cx_px = 700.3;  // well off-centre: catches a missing y flip of cy or half-pixel shift
  scene.camera.cy_px = 470.7;
  return scene;
}

void print(const char* what, const Accuracy& a) {
  std::printf("render accuracy, %s: %d views, bias (%+.4f, %+.4f) px, RMS %.4f px, max %.4f px\n", what, a.views,
              a.bias_u, a.bias_v, a.rms, a.max_err);
}

render::RenderSettings antiAliasing(int msaa_samples, int supersample, bool board_filter) {
  render::RenderSettings settings = render::loadRenderSettings(sim::kDefaultScene);
  settings.options.msaa_samples = msaa_samples;
  settings.options.supersample = supersample;
  settings.options.board_filter = board_filter;
  return settings;
}
}  // namespace

TEST_CASE("rendered corners match cv::projectPoints (default anti-aliasing: the board filter, off-centre principal point)",
          "[render][accuracy]") {
  const sim::Scene scene = testScene();
  const render::RenderSettings settings = render::loadRenderSettings(sim::kDefaultScene);
  const Accuracy a = measure(scene, settings);
  std::printf("render accuracy, no distortion, MSAA %d: %d views, bias (%+.4f, %+.4f) px, RMS %.4f px, max %.4f px\n",
              settings.options.msaa_samples, a.views, a.bias_u, a.bias_v, a.rms, a.max_err);
  REQUIRE(a.views >= kMinViews);
  CHECK(std::abs(a.bias_u) < kMaxBiasPx);
  CHECK(std::abs(a.bias_v) < kMaxBiasPx);
  CHECK(a.rms < kMaxRmsPx);
  CHECK(a.rms < kMaxDefaultRmsPx);
}

TEST_CASE("with the board filter, MSAA 4 on top gains (almost) nothing: the defaults can leave it off",
          "[render][accuracy][msaa]") {
  const sim::Scene scene = testScene();
  const Accuracy msaa = measure(scene, antiAliasing(4, 1, true));
  const Accuracy none = measure(scene, antiAliasing(0, 1, true));
  print("MSAA 4 + board filter", msaa);
  print("board filter alone", none);
  REQUIRE(none.views == msaa.views);  // the same views
  REQUIRE(none.views >= kMinViews);
  CHECK(none.rms < kMaxMsaaGain * msaa.rms);
  CHECK(std::abs(none.bias_u) < kMaxBiasPx);
  CHECK(std::abs(none.bias_v) < kMaxBiasPx);
}

TEST_CASE("rendered corners match cv::projectPoints with lens distortion", "[render][accuracy][distortion]") {
  sim::Scene scene = testScene();
  scene.camera.distortion = {-0.2, 0.08, 0.0008, -0.0006, -0.01};

  const render::RenderSettings settings = render::loadRenderSettings(sim::kDefaultScene);
  const Accuracy a = measure(scene, settings);
  std::printf("render accuracy, distortion on, MSAA %d: %d views, bias (%+.4f, %+.4f) px, RMS %.4f px, max %.4f px\n",
              settings.options.msaa_samples, a.views, a.bias_u, a.bias_v, a.rms, a.max_err);
  REQUIRE(a.views >= kMinViews);
  CHECK(std::abs(a.bias_u) < kMaxBiasPx);
  CHECK(std::abs(a.bias_v) < kMaxBiasPx);
  CHECK(std::abs(a.bias_u) < kMaxDistortionBiasPx);
  CHECK(std::abs(a.bias_v) < kMaxDistortionBiasPx);
  CHECK(a.rms < kMaxRmsPx);
  CHECK(a.rms < kMaxDefaultRmsPx);
}

TEST_CASE("supersampling alone (2x, no MSAA, no board filter) keeps corners in place", "[render][accuracy][supersample]") {
  // Rendering at 2x needs the principal point scaled as s(c + 0.5) - 0.5; the naive c s would put
  // every corner (s - 1) / (2 s) = 0.25 px off, far outside kMaxBiasPx. Only supersampling smooths
  // the edges here, so this checks its geometry on its own.
  const sim::Scene scene = testScene();
  const Accuracy a = measure(scene, antiAliasing(0, 2, false));
  print("supersample 2, no MSAA, no board filter", a);
  REQUIRE(a.views >= kMinViews);
  CHECK(std::abs(a.bias_u) < kMaxBiasPx);
  CHECK(std::abs(a.bias_v) < kMaxBiasPx);
  CHECK(a.rms < kMaxRmsPx);
}

TEST_CASE("MSAA alone (board filter off) brings the RMS under the bar, without any anti-aliasing it is worse",
          "[render][accuracy][msaa]") {
  // The default settings also filter the board analytically, which alone smooths the pattern's edges:
  // with it on, the MSAA test above would pass with MSAA off too. Here the board filter is off.
  const sim::Scene scene = testScene();
  const Accuracy msaa = measure(scene, antiAliasing(4, 1, false));
  const Accuracy none = measure(scene, antiAliasing(0, 1, false));
  print("MSAA 4, no board filter", msaa);
  print("no MSAA, no board filter", none);
  REQUIRE(msaa.views >= kMinViews);
  REQUIRE(none.views == msaa.views);  // the same views
  CHECK(std::abs(msaa.bias_u) < kMaxBiasPx);
  CHECK(std::abs(msaa.bias_v) < kMaxBiasPx);
  CHECK(msaa.rms < kMaxRmsPx);
  CHECK(none.rms > kMinNoAaRmsRatio * msaa.rms);
}

TEST_CASE("square colouring follows sim::isBlackSquare: the square at (-s,-s)..(0,0) is black", "[render][board]") {
  // The default scene's albedos are 0.05 (black) and 0.85 (white): under its lighting, 40 and 100
  // grey levels tell the two apart with room on either side.
  constexpr int kMaxBlackGrey = 40, kMinWhiteGrey = 100;
  const sim::Scene scene = testScene();
  render::BoardRenderer renderer(scene, render::loadRenderSettings(sim::kDefaultScene));
  const Eigen::Isometry3d camera_T_board = test::lookAtBoard(scene.board, 2.0, 0.0, 0.0, 20.0);
  const cv::Mat img = renderer.renderClean(camera_T_board);
  const double s = scene.board.square_m;
  const auto grey = [&](double x, double y) {
    const Eigen::Vector2d uv = sim::project(scene.camera, camera_T_board * Eigen::Vector3d(x, y, 0));
    return static_cast<int>(img.at<unsigned char>(static_cast<int>(std::lround(uv.y())), static_cast<int>(std::lround(uv.x()))));
  };
  const int black = grey(-0.5 * s, -0.5 * s), white = grey(0.5 * s, -0.5 * s);
  CAPTURE(black, white);
  CHECK(black < kMaxBlackGrey);
  CHECK(white > kMinWhiteGrey);
  CHECK(grey(0.5 * s, 0.5 * s) < kMaxBlackGrey);                                    // (2, 2)
  CHECK(grey(-0.5 * s - scene.board.margin_m * 0.5 - s * 0.5, 0.5 * s) > kMinWhiteGrey);  // margin is white
  // Every square's centre against the contract (square (i, j) covers x in [(i-1)s, i s], y likewise).
  for (int j = 0; j <= scene.board.corners_y; ++j) {
    for (int i = 0; i <= scene.board.corners_x; ++i) {
      const int g = grey((i - 0.5) * s, (j - 0.5) * s);
      CAPTURE(i, j, g);
      if (sim::isBlackSquare(i, j)) {
        CHECK(g < kMaxBlackGrey);
      } else {
        CHECK(g > kMinWhiteGrey);
      }
    }
  }
}
