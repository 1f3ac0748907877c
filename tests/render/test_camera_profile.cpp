// The camera profile's image part (applyCameraProfile) and its file: each model checked against its
// formula written out here, on synthetic images with a seeded random stream.
//
// Edges are measured the way the slanted-edge method does (ISO 12233): a straight edge 5 degrees off
// the pixel columns, every pixel's value against its signed distance to the edge, averaged in 0.1 px
// bins, gives the edge spread function 10x finer than the pixel grid.
#include <catch2/catch.hpp>
#include <cmath>
#include <fstream>
#include <opencv2/imgproc.hpp>

#include "orbcal/render/camera_profile.hpp"
#include "orbcal/sim/errors.hpp"
#include "test_util.hpp"

using namespace orbcal;

namespace {

constexpr std::uint64_t kSeed = 20261129;
constexpr double kZ1090 = 2.0 * 1.2815515655446004;  // 10-90% width of a Gaussian edge in sigmas (2 x the 90% quantile)

double Phi(double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }

sim::Camera camera(int w, int h, double cx, double cy) {
  sim::Camera c;
  c.width_px = w, c.height_px = h, c.cx_px = cx, c.cy_px = cy, c.fx_px = c.fy_px = 500;
  return c;
}

// A straight edge from lo to hi DN (a Gaussian edge of sigma0_px), 5 degrees off vertical, through the centre.
struct SlantedEdge {
  int w = 160, h = 160;
  double lo = 40, hi = 200, sigma0_px = 0.8;
  double cos_t = std::cos(5.0 * M_PI / 180.0), sin_t = std::sin(5.0 * M_PI / 180.0);
  double distance(int x, int y) const { return (x - 0.5 * w) * cos_t - (y - 0.5 * h) * sin_t; }
  cv::Mat image() const {
    cv::Mat img(h, w, CV_8UC1);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) img.at<unsigned char>(y, x) = cv::saturate_cast<unsigned char>(lo + (hi - lo) * Phi(distance(x, y) / sigma0_px));
    return img;
  }
  // (mean distance, mean value) per 0.1 px bin over |d| < 10 px, rows and columns 20 px from the border
  std::vector<std::pair<double, double>> spread(const cv::Mat& img) const {
    constexpr double kBin = 0.1, kHalf = 10.0;
    const int n = static_cast<int>(2 * kHalf / kBin);
    std::vector<double> sd(n, 0), sv(n, 0), cnt(n, 0);
    for (int y = 20; y < h - 20; ++y)
      for (int x = 20; x < w - 20; ++x) {
        const double d = distance(x, y);
        if (std::abs(d) >= kHalf) continue;
        const int b = static_cast<int>((d + kHalf) / kBin);
        sd[b] += d, sv[b] += img.at<unsigned char>(y, x), cnt[b] += 1;
      }
    std::vector<std::pair<double, double>> esf;
    for (int b = 0; b < n; ++b)
      if (cnt[b] > 0) esf.emplace_back(sd[b] / cnt[b], sv[b] / cnt[b]);
    return esf;
  }
  // Where the spread function first crosses lo + f (hi - lo), linearly between bins.
  double crossing(const std::vector<std::pair<double, double>>& esf, double f) const {
    const double level = lo + f * (hi - lo);
    for (std::size_t i = 1; i < esf.size(); ++i) {
      if (esf[i - 1].second < level && esf[i].second >= level) {
        const double t = (level - esf[i - 1].second) / (esf[i].second - esf[i - 1].second);
        return esf[i - 1].first + t * (esf[i].first - esf[i - 1].first);
      }
    }
    return NAN;
  }
  double width1090(const cv::Mat& img) const {
    const auto esf = spread(img);
    return crossing(esf, 0.9) - crossing(esf, 0.1);
  }
};

cv::Mat flat(int w, int h, double dn) { return cv::Mat(h, w, CV_8UC1, cv::Scalar(dn)); }

std::string writeText(const std::string& dir, const std::string& text) {
  const std::string path = dir + "/camera_profile.yaml";
  std::ofstream(path) << text;
  return path;
}

}  // namespace

TEST_CASE("tone curve: 0, 127.5 and 255 DN map to black, black + (white - black) 0.5^(1/gamma) and white",
          "[render][profile]") {
  render::ToneCurve t;
  t.black_dn = 39, t.white_dn = 201, t.gamma = 1.7;
  CHECK(render::toneCurve(t, 0.0) == Approx(39.0).margin(1e-12));
  CHECK(render::toneCurve(t, 127.5) == Approx(39.0 + 162.0 * std::pow(0.5, 1.0 / 1.7)).epsilon(1e-12));
  CHECK(render::toneCurve(t, 255.0) == Approx(201.0).epsilon(1e-12));
  render::CameraProfile p;
  p.tone = t;
  std::mt19937_64 rng(kSeed);
  const sim::Camera cam = camera(8, 8, 3.5, 3.5);
  for (double in : {0.0, 128.0, 255.0}) {
    const cv::Mat out = render::applyCameraProfile(flat(8, 8, in), cv::Mat(), p, cam, rng);
    const double expected = 39.0 + 162.0 * std::pow(in / 255.0, 1.0 / 1.7);
    CAPTURE(in, expected);
    CHECK(std::abs(out.at<unsigned char>(4, 4) - expected) <= 0.5 + 1e-6);  // rounded to 8 bits
  }
}

TEST_CASE("vignetting: white at half the radius (about the principal point) is the polynomial through the tone curve",
          "[render][profile]") {
  render::CameraProfile p;
  p.vignetting = {-0.2, -0.05, 0.01};
  p.tone = {20.0, 230.0, 1.7};
  // 400 x 300: half diagonal 250 px, so r = 0.5 lies 125 px from the principal point (off the image centre).
  const sim::Camera cam = camera(400, 300, 180.0, 140.0);
  std::mt19937_64 rng(kSeed);
  const cv::Mat out = render::applyCameraProfile(flat(400, 300, 200), cv::Mat(), p, cam, rng);
  const auto expected = [](double r) {
    const double f = 1.0 - 0.2 * r * r - 0.05 * std::pow(r, 4) + 0.01 * std::pow(r, 6);
    return 20.0 + 210.0 * std::pow(200.0 * f / 255.0, 1.0 / 1.7);
  };
  CAPTURE(expected(0.5), expected(0.0));
  CHECK(std::abs(out.at<unsigned char>(140, 305) - expected(0.5)) <= 0.5 + 1e-4);  // right of the principal point
  CHECK(std::abs(out.at<unsigned char>(140, 55) - expected(0.5)) <= 0.5 + 1e-4);   // left: same r, same level
  CHECK(std::abs(out.at<unsigned char>(15, 180) - expected(0.5)) <= 0.5 + 1e-4);   // above
  CHECK(std::abs(out.at<unsigned char>(140, 180) - expected(0.0)) <= 0.5 + 1e-4);  // at the principal point
  CHECK(std::abs(out.at<unsigned char>(0, 0) - expected(std::hypot(180.0, 140.0) / 250.0)) <= 0.5 + 1e-4);
  CHECK(expected(0.0) - expected(0.5) > 5.0);  // the fall-off is several DN: the checks above can tell
}

TEST_CASE("Poisson-Gaussian noise: a flat image's variance is a v + b (+ 1/12 from rounding) within its chi-square bound",
          "[render][profile]") {
  render::CameraProfile p;
  p.noise = {0.05, 0.8};
  const int n = 512 * 512;
  // (n - 1) s^2 / var is chi-square with n - 1 degrees of freedom: s^2 / var has mean 1 and standard
  // deviation sqrt(2 / (n - 1)) (0.28 %); 5 of those is the band (two-sided p < 1e-6).
  const double band = 5.0 * std::sqrt(2.0 / (n - 1));
  const sim::Camera cam = camera(512, 512, 255.5, 255.5);
  for (double v : {40.0, 200.0}) {
    std::mt19937_64 rng(kSeed);
    const cv::Mat out = render::applyCameraProfile(flat(512, 512, v), cv::Mat(), p, cam, rng);
    cv::Scalar mean, sd;
    cv::meanStdDev(out, mean, sd);
    const double var = 0.05 * v + 0.8 + 1.0 / 12.0;
    const double s2 = sd[0] * sd[0] * n / (n - 1.0);
    CAPTURE(v, s2, var, band);
    CHECK(std::abs(s2 / var - 1.0) < band);
    CHECK(std::abs(mean[0] - v) < 5.0 * std::sqrt(var / n));
  }
}

TEST_CASE("blur: a step edge's 10-90% width grows to 2.563 sqrt(sigma_edge^2 + blur_sigma^2)", "[render][profile]") {
  const SlantedEdge e;
  const sim::Camera cam = camera(e.w, e.h, 79.5, 79.5);
  std::mt19937_64 rng(kSeed);
  const double before = e.width1090(e.image());
  render::CameraProfile p;
  p.blur_sigma_px = 1.2;
  const double after = e.width1090(render::applyCameraProfile(e.image(), cv::Mat(), p, cam, rng));
  CAPTURE(before, after);
  // Tolerance 0.03 px: the spread function is sampled every 0.1 px and each bin averages ~10 pixels
  // quantised to 1 DN of a 160 DN edge (the 10% and 90% points move 0.005 px per DN of error).
  CHECK(before == Approx(kZ1090 * 0.8).margin(0.03));
  CHECK(after == Approx(kZ1090 * std::sqrt(0.8 * 0.8 + 1.2 * 1.2)).margin(0.03));
}

TEST_CASE("sharpening: a step edge's overshoot and undershoot are the unsharp mask's analytic values",
          "[render][profile]") {
  const SlantedEdge e;
  const sim::Camera cam = camera(e.w, e.h, 79.5, 79.5);
  render::CameraProfile p;
  p.sharpening = {0.8, 1.5};
  std::mt19937_64 rng(kSeed);
  const auto esf = e.spread(render::applyCameraProfile(e.image(), cv::Mat(), p, cam, rng));
  // out(d) = E(d) + k (E(d) - E_s(d)), E = Phi(d / s0), E_s = Phi(d / sqrt(s0^2 + s^2)), in units of the step
  const double s0 = 0.8, s1 = std::sqrt(0.8 * 0.8 + 1.5 * 1.5);
  double over = 0;
  for (double d = 0; d < 10; d += 1e-3) over = std::max(over, Phi(d / s0) + 0.8 * (Phi(d / s0) - Phi(d / s1)) - 1.0);
  double hi = -1e9, lo = 1e9;
  for (const auto& [d, v] : esf) hi = std::max(hi, v), lo = std::min(lo, v);
  const double measured_over = (hi - e.hi) / (e.hi - e.lo), measured_under = (e.lo - lo) / (e.hi - e.lo);
  CAPTURE(over, measured_over, measured_under);
  CHECK(over > 0.05);  // large enough to tell from no sharpening
  // 0.005 of the step (0.8 DN): bins of ~10 pixels each rounded to 1 DN; a 0.1 px bin lowers the peak by < 0.1%
  CHECK(measured_over == Approx(over).margin(0.005));
  CHECK(measured_under == Approx(over).margin(0.005));  // the mask is odd about the edge
}

TEST_CASE("background: uncovered pixels get the level and texture (std, correlation length), covered ones are kept",
          "[render][profile]") {
  const int w = 512, h = 512;
  cv::Mat covered(h, w, CV_8UC1, cv::Scalar(0));
  covered(cv::Rect(0, 0, 128, h)).setTo(255);
  covered(cv::Rect(128, 0, 1, h)).setTo(128);
  render::CameraProfile p;
  p.background.mean_dn = 60.0;
  p.background.texture_dn = 10.0;
  p.background.texture_scale_px = 4.0;
  std::mt19937_64 rng(kSeed);
  const cv::Mat out = render::applyCameraProfile(flat(w, h, 100), covered, p, camera(w, h, 255.5, 255.5), rng);
  CHECK(cv::countNonZero(out(cv::Rect(0, 0, 128, h)) != 100) == 0);
  const cv::Rect bg(160, 0, w - 160, h);
  cv::Mat f;
  out(bg).convertTo(f, CV_64F);
  cv::Scalar mean, sd;
  cv::meanStdDev(f, mean, sd);
  // Smoothing white noise by a Gaussian of sigma s gives the autocorrelation exp(-d^2 / (4 s^2)), whose
  // integral is 4 pi s^2: the region holds n_eff = area / (4 pi s^2) independent values (~1500 here).
  const double n_eff = bg.area() / (4.0 * M_PI * 16.0);
  CAPTURE(mean[0], sd[0], n_eff);
  CHECK(std::abs(mean[0] - 60.0) < 5.0 * 10.0 / std::sqrt(n_eff));
  CHECK(std::abs(sd[0] - std::sqrt(100.0 + 1.0 / 12.0)) < 5.0 * 10.0 / std::sqrt(2.0 * n_eff));
  // correlation at a lag of 2 s = 8 px: exp(-1) = 0.37 (white noise: 0)
  const cv::Mat a = f(cv::Rect(0, 0, f.cols - 8, f.rows)) - mean[0], b = f(cv::Rect(8, 0, f.cols - 8, f.rows)) - mean[0];
  const double corr = a.dot(b) / std::sqrt(a.dot(a) * b.dot(b));
  CAPTURE(corr);
  CHECK(corr == Approx(std::exp(-1.0)).margin(5.0 / std::sqrt(n_eff)));
  // half covered: the mix of the render and the background
  render::CameraProfile plain;
  plain.background.mean_dn = 60.0;
  const cv::Mat mixed = render::applyCameraProfile(flat(w, h, 100), covered, plain, camera(w, h, 255.5, 255.5), rng);
  CHECK(std::abs(mixed.at<unsigned char>(10, 128) - (128.0 / 255 * 100 + 127.0 / 255 * 60)) <= 0.5 + 1e-4);
  CHECK(mixed.at<unsigned char>(10, 300) == 60);
}

TEST_CASE("the identity profile returns the image unchanged and draws nothing from the stream", "[render][profile]") {
  cv::Mat img(64, 80, CV_8UC1);
  cv::randu(img, 0, 256);
  std::mt19937_64 rng(kSeed), untouched(kSeed);
  const render::CameraProfile p;
  REQUIRE(p.identity());
  const cv::Mat out = render::applyCameraProfile(img, cv::Mat(), p, camera(80, 64, 39.5, 31.5), rng);
  CHECK(cv::countNonZero(out != img) == 0);
  CHECK(rng() == untouched());
}

TEST_CASE("camera_profile.yaml: save then load gives the same profile", "[render][profile]") {
  const std::string dir = test::tempDir("camera-profile-io");
  render::CameraProfile p;
  p.tone = {39.25, 201.5, 1.7};
  p.vignetting = {-0.21, 0.03, -0.004};
  p.blur_sigma_px = 0.41;
  p.sharpening = {0.35, 1.2};
  p.noise = {0.013, 0.79};
  p.background.mean_dn = 96.0;
  p.background.texture_dn = 21.0;
  p.background.texture_scale_px = 6.5;
  p.board.scale_x = 1.0012, p.board.scale_y = 0.9991, p.board.bow_m = 0.0013;
  p.board.corner_displacement_m[3] = {1.1e-4, -0.7e-4};
  p.board.corner_displacement_m[17] = {-0.2e-4, 0.33e-4};
  render::saveCameraProfile(p, dir + "/p.yaml");
  const render::CameraProfile q = render::loadCameraProfile(dir + "/p.yaml");
  CHECK(q.source == dir + "/p.yaml");
  CHECK((q.tone.black_dn == p.tone.black_dn && q.tone.white_dn == p.tone.white_dn && q.tone.gamma == p.tone.gamma));
  CHECK((q.vignetting.a2 == p.vignetting.a2 && q.vignetting.a4 == p.vignetting.a4 && q.vignetting.a6 == p.vignetting.a6));
  CHECK(q.blur_sigma_px == p.blur_sigma_px);
  CHECK((q.sharpening.amount == p.sharpening.amount && q.sharpening.sigma_px == p.sharpening.sigma_px));
  CHECK((q.noise.a_dn == p.noise.a_dn && q.noise.b_dn2 == p.noise.b_dn2));
  REQUIRE(q.background.mean_dn);
  CHECK((*q.background.mean_dn == 96.0 && q.background.texture_dn == 21.0 && q.background.texture_scale_px == 6.5));
  CHECK((q.board.scale_x == p.board.scale_x && q.board.scale_y == p.board.scale_y));
  CHECK(q.board.bow_m == Approx(p.board.bow_m).epsilon(1e-14));  // through millimetres
  REQUIRE(q.board.corner_displacement_m.size() == 2);
  CHECK((q.board.corner_displacement_m.at(3) - p.board.corner_displacement_m.at(3)).norm() < 1e-18);
  CHECK((q.board.corner_displacement_m.at(17) - p.board.corner_displacement_m.at(17)).norm() < 1e-18);
  // the identity profile round-trips to the identity
  render::saveCameraProfile(render::CameraProfile{}, dir + "/id.yaml");
  CHECK(render::loadCameraProfile(dir + "/id.yaml").identity());
}

TEST_CASE("camera_profile.yaml: a bad value or a misspelt key is an InputError naming the file and the key",
          "[render][profile]") {
  const std::string dir = test::tempDir("camera-profile-bad");
  const auto error = [&](const std::string& text) -> std::string {
    const std::string path = writeText(dir, "format: orbcal-camera-profile-1\n" + text);
    try {
      render::loadCameraProfile(path);
    } catch (const sim::InputError& e) {
      return e.what();
    }
    return "no error";
  };
  const std::string file = dir + "/camera_profile.yaml";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"tone: {gama: 1.7}\n", "gama"},
      {"tone: {gamma: .nan}\n", "tone.gamma"},
      {"tone: {black_dn: 100, white_dn: 90}\n", "tone.white_dn"},
      {"noise: {a_dn: -1}\n", "noise.a_dn"},
      {"blur_sigma_px: 1e308\n", "blur_sigma_px"},
      {"board: {scale_x: 1.5}\n", "board.scale_x"},
      {"vignetting: {a2: -1.5}\n", "vignetting"},
      {"board: {corner_displacements: [{id: 2, dx_mm: 0.1, dy_mm: 0}, {id: 2, dx_mm: 0, dy_mm: 0}]}\n", "id"},
      {"background: {texture_dn: 5}\n", "background"},
  };
  for (const auto& [text, key] : cases) {
    const std::string what = error(text);
    CAPTURE(text, what);
    CHECK(what.find(file) != std::string::npos);
    CHECK(what.find(key) != std::string::npos);
  }
  const std::string wrong = writeText(dir, "format: orbcal-camera-profile-2\n");
  CHECK_THROWS_WITH(render::loadCameraProfile(wrong), Catch::Contains("format"));
}
