// Image statistics (vision/image_stats.hpp) on drawn boards whose levels, tone, vignetting, noise, blur,
// sharpening, background and corner displacements are set by construction.
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <random>

#include "orbcal/vision/image_stats.hpp"
#include "orbcal/vision/synthetic.hpp"
#include "vision_test_util.hpp"

using namespace orbcal;

namespace {

sim::Camera testCamera() {
  sim::Camera c;
  c.width_px = 640;
  c.height_px = 480;
  c.fx_px = c.fy_px = 600.0;
  c.cx_px = 319.5;
  c.cy_px = 239.5;
  return c;
}

sim::Board testBoard() {
  sim::Board b;
  b.corners_x = 9;
  b.corners_y = 6;
  b.square_m = 0.03;
  b.margin_m = 0.02;
  return b;
}

/// A view 0.5 m from the board, rolled 8 deg (slanted edges), shifted sideways by (dx, dy) m.
Eigen::Isometry3d testPose(double dx = 0.0, double dy = 0.0, double tilt = 0.1) {
  Eigen::Isometry3d T = test::lookAtBoard(testBoard(), 0.5, tilt, -0.5 * tilt, 8.0 * sim::kDegToRad);
  T.translation() += Eigen::Vector3d(dx, dy, 0.0);
  return T;
}

/// What a camera makes of a linear image x in [0, 1] (black square 0, white 1): vignetting 1 + a2 r^2,
/// blur sigma, unsharp mask k (sigma 1 px), tone black + (white - black) x^(1 / gamma), noise of
/// variance a * level + b, rounding. The background (drawn at `bg` of 255) passes through the same.
struct Effects {
  double a2 = 0.0, blur = 0.0, sharpen = 0.0, black = 0.0, white = 255.0, gamma = 1.0, noise_a = 0.0, noise_b = 0.0;
};

cv::Mat drawLinear(const Eigen::Isometry3d& T, int bg = 90) {
  vision::SyntheticImageSettings st;
  st.black = 0;
  st.white = 255;
  st.background = bg;
  cv::Mat img = vision::drawSyntheticBoard(testCamera(), testBoard(), T, st), x;
  img.convertTo(x, CV_64F, 1.0 / 255.0);
  return x;
}

cv::Mat camera(const cv::Mat& linear, const Effects& e, std::uint64_t seed) {
  const sim::Camera c = testCamera();
  cv::Mat x = linear.clone();
  for (int v = 0; v < x.rows; ++v) {
    for (int u = 0; u < x.cols; ++u) {
      const double r = vision::normalizedRadius(c, Eigen::Vector2d(u, v));
      x.at<double>(v, u) *= 1.0 + e.a2 * r * r;
    }
  }
  if (e.blur > 0) cv::GaussianBlur(x, x, cv::Size(0, 0), e.blur);
  if (e.sharpen > 0) {
    cv::Mat s;
    cv::GaussianBlur(x, s, cv::Size(0, 0), 1.0);
    x = x + e.sharpen * (x - s);
  }
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  cv::Mat out(x.size(), CV_8UC1);
  for (int v = 0; v < x.rows; ++v) {
    for (int u = 0; u < x.cols; ++u) {
      const double xv = x.at<double>(v, u);  // sign kept: an undershoot below black stays one
      const double level = e.black + (e.white - e.black) * std::copysign(std::pow(std::abs(xv), 1.0 / e.gamma), xv);
      const double sd = std::sqrt(e.noise_a * std::max(0.0, level) + e.noise_b);
      out.at<uchar>(v, u) = cv::saturate_cast<uchar>(std::lround(level + sd * n01(rng)));
    }
  }
  return out;
}

vision::BoardImage view(const cv::Mat& gray, const Eigen::Isometry3d& T) {
  vision::BoardImage v;
  v.gray = gray;
  v.camera_T_board = T;
  return v;
}

}  // namespace

TEST_CASE("black and white levels are the flat squares' medians", "[vision][image-stats]") {
  const Eigen::Isometry3d T = testPose();
  const cv::Mat img = camera(drawLinear(T), {0, 0, 0, 30, 200, 1, 0, 1.0}, 1);
  const auto samples = vision::flatSamples(testCamera(), testBoard(), view(img, T));
  REQUIRE(samples.size() > 10000);
  const vision::Levels l = vision::blackWhiteLevels(samples);
  CHECK(l.black == Approx(30).margin(0.5));  // noise 1 DN: the median of thousands is within a level
  CHECK(l.white == Approx(200).margin(0.5));
  // an ignored half of the image is not sampled
  vision::BoardImage half = view(img, T);
  half.ignored = cv::Mat::zeros(img.size(), CV_8UC1);
  half.ignored.colRange(0, 320).setTo(255);
  int left = 0;
  const auto kept = vision::flatSamples(testCamera(), testBoard(), half);
  for (const auto& f : kept) left += f.u < 322 ? 1 : 0;  // the mask grown by 2 px
  CHECK(left == 0);
  CHECK(kept.size() > 3000);
}

TEST_CASE("noise against intensity recovers a Poisson-Gaussian variance", "[vision][image-stats]") {
  const Eigen::Isometry3d T = testPose();
  const Effects e{0, 0, 0, 30, 200, 1, 0.05, 1.0};  // variance 2.5 DN^2 at black, 11 at white
  const cv::Mat img = camera(drawLinear(T), e, 2);
  const vision::NoiseLevels n = vision::noiseLevels(vision::flatSamples(testCamera(), testBoard(), view(img, T)));
  // 5 %: the estimator's sampling error over ~10^4 pixels is ~1 %, rounding adds 1/12 DN^2 (<2 % here)
  CHECK(n.black_sd == Approx(std::sqrt(2.5)).epsilon(0.05));
  CHECK(n.white_sd == Approx(std::sqrt(11.0)).epsilon(0.05));
  const vision::PoissonGaussian pg = vision::fitPoissonGaussian({n});
  CHECK(pg.a == Approx(0.05).margin(0.01));
  CHECK(pg.b == Approx(1.0).margin(0.4));
  // a clean image: no noise
  const vision::NoiseLevels clean = vision::noiseLevels(vision::flatSamples(testCamera(), testBoard(), view(camera(drawLinear(T), {0, 0, 0, 30, 200}, 3), T)));
  CHECK(clean.white_sd < 0.1);
}

TEST_CASE("the tone curve is fitted from rendered-real pixel pairs", "[vision][image-stats]") {
  const Eigen::Isometry3d T = testPose();
  cv::Mat lin = drawLinear(T);
  cv::GaussianBlur(lin, lin, cv::Size(0, 0), 1.5);  // intermediate levels along the edges
  const cv::Mat rendered = camera(lin, {}, 4), real = camera(lin, {0, 0, 0, 40, 205, 1.7, 0, 0.5}, 5);
  const vision::ToneFit fit = vision::fitToneCurve(vision::tonePairs(testCamera(), testBoard(), view(real, T), rendered));
  CHECK(fit.gamma == Approx(1.7).epsilon(0.03));
  CHECK(fit.black == Approx(40).margin(1.5));
  CHECK(fit.white == Approx(205).margin(1.5));
  const vision::ToneFit identity = vision::fitToneCurve(vision::tonePairs(testCamera(), testBoard(), view(rendered, T), rendered));
  CHECK(identity.gamma == Approx(1.0).epsilon(0.01));
}

TEST_CASE("vignetting at half radius from views across the image", "[vision][image-stats]") {
  const Effects e{-0.25, 0, 0, 0, 220, 1, 0, 0.5};  // 1 - 0.25 r^2: -6.25 % at r = 0.5
  std::vector<std::vector<vision::FlatSample>> views, flat;
  for (const auto& [dx, dy] : {std::pair{-0.12, -0.08}, {0.12, 0.08}, {0.0, 0.0}, {0.12, -0.08}, {-0.12, 0.08}}) {
    const Eigen::Isometry3d T = testPose(dx, dy);
    const cv::Mat lin = drawLinear(T);
    views.push_back(vision::flatSamples(testCamera(), testBoard(), view(camera(lin, e, 6), T)));
    flat.push_back(vision::flatSamples(testCamera(), testBoard(), view(camera(lin, {0, 0, 0, 0, 220, 1, 0, 0.5}, 7), T)));
  }
  const vision::Falloff f = vision::radialFalloff(views);
  CHECK(f.at_half.value == Approx(-0.0625).margin(0.006));  // a tenth of the effect
  CHECK(f.at_half.sigma < 0.01);
  CHECK(std::abs(vision::radialFalloff(flat).at_half.value) < 0.005);
}

TEST_CASE("edge width and overshoot from slanted-edge profiles", "[vision][image-stats]") {
  const Eigen::Isometry3d T = testPose();
  const cv::Mat lin = drawLinear(T);
  // 4x supersampled pixels add a 1 px box (variance 1/12 px^2) to the Gaussian; 10-90 % of a Gaussian
  // edge spans 2.563 sigma
  constexpr double kGaussian1090 = 2.5631;
  const double blur = 1.2, expected = kGaussian1090 * std::sqrt(blur * blur + 1.0 / 12.0);
  const vision::EdgeStats blurred = vision::edgeStats(testCamera(), testBoard(), view(camera(lin, {0, blur, 0, 20, 220}, 8), T));
  REQUIRE(blurred.edges > 40);
  CHECK(blurred.width_px == Approx(expected).epsilon(0.05));
  CHECK(blurred.overshoot < 0.01);
  const vision::EdgeStats wider = vision::edgeStats(testCamera(), testBoard(), view(camera(lin, {0, 2.0, 0, 20, 220}, 9), T));
  CHECK(wider.width_px == Approx(kGaussian1090 * std::sqrt(4.0 + 1.0 / 12.0)).epsilon(0.05));
  // an unsharp mask of gain 0.5: its 1-D overshoot on this edge, computed here by convolution
  const auto gauss = [](double x, double s) { return 0.5 * (1.0 + std::erf(x / (s * std::sqrt(2.0)))); };
  const double st = std::sqrt(blur * blur + 1.0 / 12.0), sm = std::sqrt(st * st + 1.0);
  double peak = 0.0;
  for (double x = 0.0; x < 6.0; x += 0.01) peak = std::max(peak, gauss(x, st) + 0.5 * (gauss(x, st) - gauss(x, sm)) - 1.0);
  const vision::EdgeStats sharp = vision::edgeStats(testCamera(), testBoard(), view(camera(lin, {0, blur, 0.5, 20, 220}, 10), T));
  CHECK(sharp.overshoot == Approx(peak).margin(0.015));
  CHECK(sharp.undershoot == Approx(peak).margin(0.015));
  CHECK(sharp.width_px < blurred.width_px);
}

TEST_CASE("background outside the board's hull", "[vision][image-stats]") {
  const Eigen::Isometry3d T = testPose();
  const cv::Mat img = camera(drawLinear(T, 90), {0, 0, 0, 0, 255, 1, 0, 9.0}, 11);  // 90 DN, sd 3
  const vision::BackgroundStats b = vision::backgroundStats(testCamera(), testBoard(), view(img, T));
  REQUIRE(b.pixels > 10000);
  CHECK(b.mean == Approx(90).margin(0.3));
  CHECK(b.sd == Approx(3.0).epsilon(0.05));
}

TEST_CASE("corner scatter and its repeatable part per corner id", "[vision][image-stats]") {
  const sim::Camera cam = testCamera();
  const sim::Board board = testBoard();
  std::mt19937_64 rng(12);
  std::normal_distribution<double> fixed(0.0, 0.3), noise(0.0, 0.2);
  std::vector<Eigen::Vector2d> displacement(board.numCorners());
  for (auto& d : displacement) d = {fixed(rng), fixed(rng)};
  std::vector<std::map<int, Eigen::Vector2d>> residuals;
  double scatter_ms = 0.0;
  constexpr int kViews = 12;
  for (int k = 0; k < kViews; ++k) {
    vision::BoardImage v;
    v.camera_T_board = testPose(0.01 * k, 0.0);
    for (int id = 0; id < board.numCorners(); ++id) {
      v.ids.push_back(id);
      v.corners_px.push_back(vision::projectBoardPoint(cam, v.camera_T_board, sim::cornerInBoard(board, id)) + displacement[id] +
                             Eigen::Vector2d(noise(rng), noise(rng)));
    }
    residuals.push_back(vision::cornerResiduals(cam, board, v));
    const double s = vision::cornerScatterPx(residuals.back());
    scatter_ms += s * s / kViews;
  }
  // E|d|^2 = 2 * 0.09, E|n|^2 = 2 * 0.04: scatter sqrt(0.26), repeatable share 0.18 / 0.26
  CHECK(std::sqrt(scatter_ms) == Approx(std::sqrt(0.26)).epsilon(0.1));
  const vision::RepeatablePart rep = vision::repeatableCornerPart(residuals);
  CHECK(rep.share == Approx(0.18 / 0.26).margin(0.08));
  CHECK((rep.mean_px.at(7) - displacement[7]).norm() < 0.2);  // 0.2 px noise over 12 views: sd 0.06 per axis
  // pure noise repeats nothing
  std::vector<std::map<int, Eigen::Vector2d>> pure(kViews);
  for (auto& m : pure) {
    for (int id = 0; id < board.numCorners(); ++id) m[id] = {noise(rng), noise(rng)};
  }
  CHECK(vision::repeatableCornerPart(pure).share < 0.05);
  // a 1 mm shift of a corner in the board plane is recovered from its pixel displacement
  const Eigen::Isometry3d T = testPose();
  const Eigen::Vector3d p = sim::cornerInBoard(board, 20);
  const Eigen::Vector2d px = vision::projectBoardPoint(cam, T, p + Eigen::Vector3d(1e-3, -0.5e-3, 0)) - vision::projectBoardPoint(cam, T, p);
  const Eigen::Vector2d shift = vision::boardPlaneShift(cam, board, T, 20, px);
  CHECK(shift.x() == Approx(1e-3).epsilon(0.01));
  CHECK(shift.y() == Approx(-0.5e-3).epsilon(0.01));
}

TEST_CASE("estimates over views and their significance", "[vision][image-stats]") {
  const vision::Estimate e = vision::meanOverViews({1.0, 2.0, 3.0, std::nan("")});
  CHECK(e.n == 3);
  CHECK(e.value == Approx(2.0));
  CHECK(e.sigma == Approx(1.0 / std::sqrt(3.0)));  // sample sd 1 over sqrt(3)
  vision::Estimate a{1.0, 0.1, 5}, b{1.5, 0.1, 5}, c{1.2, 0.1, 5};
  CHECK(vision::differsSignificantly(a, b));   // 0.5 > 2 * 0.141
  CHECK_FALSE(vision::differsSignificantly(a, c));  // 0.2 < 0.283
}

TEST_CASE("a tone curve whose white lies beyond 255 is fitted with white held at the bound", "[vision][image-stats]") {
  std::vector<Eigen::Vector2d> pairs;
  for (int in = 0; in <= 230; ++in) pairs.emplace_back(in, 20.0 + (255.0 - 20.0) * std::pow(in / 230.0, 1.0 / 1.5));  // 255 at in = 230
  const vision::ToneFit free = vision::fitToneCurve(pairs);
  CHECK(free.white > 255.0);
  CHECK(free.gamma == Approx(1.5).epsilon(1e-3));  // unheld, the curve is recovered
  const vision::ToneFit held = vision::fitToneCurve(pairs, 255.0);
  CHECK(held.white == Approx(255.0).margin(1e-9));
  // the best curve with white 255, found independently by a grid over black and gamma
  double best = std::numeric_limits<double>::infinity();
  for (double black = 0.0; black <= 60.0; black += 0.25) {
    for (double gamma = 0.8; gamma <= 3.0; gamma += 0.005) {
      double sse = 0.0;
      for (const auto& p : pairs) sse += std::pow(black + (255.0 - black) * std::pow(p.x() / 255.0, 1.0 / gamma) - p.y(), 2);
      best = std::min(best, std::sqrt(sse / pairs.size()));
    }
  }
  CHECK(held.rms <= best + 1e-6);   // no worse than the grid's best
  CHECK(held.rms > best - 0.05);    // and the grid's step leaves it that close
}
