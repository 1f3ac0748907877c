// Image degradations (degrade.hpp) and exposure: each measured against its model with a seeded RNG.
//
// Statistics used for the tolerances: the sample standard deviation of n independent normal values has
// a standard error of sigma / sqrt(2 n); the sample mean one of sigma / sqrt(n). Every band below is
// kSigmas standard errors wide, so a correct implementation fails with probability < 1e-6 (and, the
// RNG being seeded, the same way on every run), while a wrong model (e.g. std of the signal instead of
// its square root, or a blur with the wrong sigma) is off by many times the band.
#include <catch2/catch.hpp>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>

#include "orbcal/render/degrade.hpp"
#include "orbcal/render/renderer.hpp"
#include "orbcal/render/settings.hpp"
#include "orbcal/sim/io.hpp"
#include "render_test_util.hpp"

using namespace orbcal;

namespace {
constexpr int kSidePx = 512;         // flat test images: n = 262144 pixels
constexpr double kSigmas = 5.0;      // width of each band in standard errors (two-sided p < 6e-7)
constexpr double kQuantVar = 1.0 / 12.0;  // rounding to integer DN adds the variance of U(-0.5, 0.5)
                                          // (Sheppard's correction; accurate for a noise std above ~0.5 DN)
constexpr std::uint64_t kSeed = 20240611;

cv::Mat flat(double dn) { return cv::Mat(kSidePx, kSidePx, CV_8UC1, cv::Scalar(dn)); }

struct Stats {
  double mean = 0, std = 0;
  int n = 0;
};

Stats stats(const cv::Mat& img, const cv::Rect& roi) {
  cv::Scalar mean, std;
  cv::meanStdDev(img(roi), mean, std);
  return {mean[0], std[0], roi.area()};
}

const cv::Rect kAll(0, 0, kSidePx, kSidePx);
}  // namespace

TEST_CASE("read noise of sigma N DN gives a measured std of sqrt(N^2 + 1/12) over a flat region", "[render][degrade]") {
  for (double read_dn : {1.0, 2.0, 5.0}) {
    render::Degradations d;
    d.read_noise_dn = read_dn;
    std::mt19937_64 rng(kSeed);
    const cv::Mat out = render::applyDegradations(flat(128), d, rng);
    REQUIRE(out.type() == CV_8UC1);
    const Stats s = stats(out, kAll);
    const double expected_std = std::sqrt(read_dn * read_dn + kQuantVar);
    const double se_std = expected_std / std::sqrt(2.0 * s.n), se_mean = expected_std / std::sqrt(s.n);
    CAPTURE(read_dn, s.mean, s.std, expected_std, se_std);
    CHECK(std::abs(s.std - expected_std) < kSigmas * se_std);
    CHECK(std::abs(s.mean - 128.0) < kSigmas * se_mean);  // zero-mean noise: no offset
  }
}

TEST_CASE("shot noise: std in DN is sqrt(signal / (electrons per DN)), so it grows as the square root of the signal",
          "[render][degrade]") {
  render::Degradations d;
  d.full_well_e = 2550.0;  // 10 electrons per DN
  const double e_per_dn = d.full_well_e / 255.0;
  double var_low = 0, var_high = 0;
  constexpr double kLowDn = 40.0, kHighDn = 160.0;  // std 2 and 4 DN: far from 0 and 255 (no clipping)
  for (double signal : {kLowDn, kHighDn}) {
    std::mt19937_64 rng(kSeed);
    const Stats s = stats(render::applyDegradations(flat(signal), d, rng), kAll);
    const double expected_var = signal / e_per_dn;  // Poisson: var(e) = e, in DN: e / e_per_dn^2
    const double expected_std = std::sqrt(expected_var + kQuantVar);
    const double se_std = expected_std / std::sqrt(2.0 * s.n);
    CAPTURE(signal, s.mean, s.std, expected_std, se_std);
    CHECK(std::abs(s.std - expected_std) < kSigmas * se_std);
    CHECK(std::abs(s.mean - signal) < kSigmas * expected_std / std::sqrt(s.n));
    (signal == kLowDn ? var_low : var_high) = s.std * s.std - kQuantVar;
  }
  // 4x the signal: 4x the variance (2x the std). The ratio of two variance estimates has a relative
  // standard error of sqrt(2/n + 2/n) ~ 0.4 % (x 1.1 for the 1/12 DN^2 subtracted from each, which
  // raises their relative error by up to 2 %); a linear model (std proportional to the signal) gives 16.
  const double ratio = var_high / var_low;
  const double rel_se = 1.1 * std::sqrt(4.0 / (kSidePx * kSidePx));
  CAPTURE(ratio, rel_se);
  CHECK(std::abs(ratio / (kHighDn / kLowDn) - 1.0) < kSigmas * rel_se);
}

TEST_CASE("defocus blur of sigma b reduces the std of white noise by the kernel's sum of squares", "[render][degrade]") {
  // Input: independent N(128, 20) pixels. A separable Gaussian kernel with 1-D taps k_i maps white
  // noise of variance v to variance v (sum k_i^2)^2, i.e. the std scales by sum k_i^2 (about
  // 1 / (2 sqrt(pi) b): 0.28 at b = 1, 0.14 at b = 2). A blur of the wrong sigma misses by far more than the band.
  std::mt19937_64 rng(kSeed);
  std::normal_distribution<double> noise(128.0, 20.0);
  cv::Mat in(kSidePx, kSidePx, CV_8UC1);
  for (int r = 0; r < in.rows; ++r)
    for (int c = 0; c < in.cols; ++c) in.at<unsigned char>(r, c) = cv::saturate_cast<unsigned char>(noise(rng));
  for (double b : {1.0, 2.0}) {
    render::Degradations d;
    d.defocus_sigma_px = b;
    const int half = static_cast<int>(std::ceil(4.0 * b));  // the kernel degrade.cpp uses (+-4 sigma)
    const cv::Mat k = cv::getGaussianKernel(2 * half + 1, b, CV_64F);
    const double sum_sq = k.dot(k);
    std::mt19937_64 unused(kSeed);
    const cv::Mat out = render::applyDegradations(in, d, unused);
    const cv::Rect interior(half, half, kSidePx - 2 * half, kSidePx - 2 * half);  // away from the replicated border
    const Stats s_in = stats(in, interior), s_out = stats(out, interior);
    const double expected_std = std::sqrt(s_in.std * s_in.std * sum_sq * sum_sq + kQuantVar);
    // Blurred pixels are correlated over ~2 b: about n / (4 pi b^2) independent values, so the std's
    // relative standard error is ~ sqrt(4 pi b^2 / (2 n)) (1.1 % at b = 2 for this image size).
    const double rel_se = std::sqrt(4.0 * 3.14159265358979 * b * b / (2.0 * s_out.n));
    CAPTURE(b, s_in.std, s_out.std, expected_std, rel_se);
    CHECK(std::abs(s_out.std / expected_std - 1.0) < kSigmas * rel_se);
    CHECK(std::abs(s_out.mean - s_in.mean) < 0.5);  // a normalised kernel keeps the mean (rounding: < 0.5 DN)
  }
}

TEST_CASE("exposure scales the rendered radiance: half the exposure, half the mean", "[render][degrade][exposure]") {
  // Deterministic (no noise): exposure multiplies the radiance before the 8-bit conversion, so each
  // pixel of the half-exposure image is round(R / 2) against round(R) of the full one: they differ from
  // half by at most 0.5 + 0.25 DN, and so do the means. kExposureTolDn adds 0.25 DN for GL's conversion.
  constexpr double kExposureTolDn = 1.0;
  const sim::Scene scene = sim::loadScene(sim::kDefaultScene);
  render::RenderSettings full = render::loadRenderSettings(sim::kDefaultScene);
  render::RenderSettings half = full;
  half.degradations.exposure = 0.5;
  const Eigen::Isometry3d camera_T_board = test::lookAtBoard(scene.board, 2.0, 20.0, 30.0, 10.0);
  const cv::Mat a = test::renderCleanWith(scene, full, camera_T_board);
  const cv::Mat b = test::renderCleanWith(scene, half, camera_T_board);
  double max_full = 0;
  cv::minMaxLoc(a, nullptr, &max_full);
  REQUIRE(max_full < 255);  // nothing saturated at exposure 1, so the scaling is linear
  const double mean_full = cv::mean(a)[0], mean_half = cv::mean(b)[0];
  CAPTURE(mean_full, mean_half);
  REQUIRE(mean_full > 20);  // the board fills a good part of the image
  CHECK(std::abs(mean_half - 0.5 * mean_full) < kExposureTolDn);
}
