// The camera profile fitted from real views against their rendered twins (workflow/twin.hpp).
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "orbcal/workflow/twin.hpp"
#include "twin_detail.hpp"

namespace orbcal::workflow {

namespace twin_detail {

cv::Mat profiledTwin(render::BoardRenderer& renderer, const sim::Scene& scene, const Eigen::Isometry3d& pose, const cv::Mat& clean,
                     const render::CameraProfile& profile, std::mt19937_64& rng) {
  (void)renderer;
  const cv::Mat covered = vision::boardHullMask(scene.camera, scene.board, pose, 0.0);
  return render::applyCameraProfile(clean, covered, profile, scene.camera, rng);
}

namespace {

constexpr double kGaussian1090 = 2.5631;  // 10-90 % width of a Gaussian edge over its sigma

double phi(double x, double sigma) { return 0.5 * (1.0 + std::erf(x / (sigma * std::sqrt(2.0)))); }

/// 10-90 % width and overshoot of a Gaussian edge of sigma `sigma_px` sharpened by gain k (mask sigma s).
std::pair<double, double> sharpenedEdge(double sigma_px, double k, double s) {
  constexpr double kStep = 0.02, kReach = 6.0;
  const double sm = std::sqrt(sigma_px * sigma_px + s * s);
  double lo = 0.0, hi = 0.0, peak = 0.0;
  bool have_lo = false, have_hi = false;
  for (double x = 0.0; x < kReach; x += kStep) {  // the profile is odd about its middle: walk outward both ways
    const double up = phi(x, sigma_px) + k * (phi(x, sigma_px) - phi(x, sm));
    const double down = phi(-x, sigma_px) + k * (phi(-x, sigma_px) - phi(-x, sm));
    if (!have_hi && up >= 0.9) {
      hi = x;
      have_hi = true;
    }
    if (!have_lo && down <= 0.1) {
      lo = -x;
      have_lo = true;
    }
    peak = std::max(peak, up - 1.0);
  }
  return {hi - lo, peak};
}

}  // namespace

std::pair<double, double> blurAndSharpening(double rendered_width_px, double width_px, double overshoot, double mask_sigma_px) {
  if (!(rendered_width_px > 0.0) || !(width_px > 0.0)) return {0.0, 0.0};
  const double sigma0 = rendered_width_px / kGaussian1090;
  constexpr double kWidthScale = 0.02, kOvershootScale = 0.005;  // a 2 % width error weighs as 0.5 % of overshoot
  double best = std::numeric_limits<double>::infinity();
  std::pair<double, double> arg{0.0, 0.0};
  for (double blur = 0.0; blur <= 3.0; blur += 0.05) {
    for (double k = 0.0; k <= 3.0; k += 0.05) {
      const auto [w, o] = sharpenedEdge(std::hypot(sigma0, blur), k, mask_sigma_px);
      const double cost = std::pow((w - width_px) / (kWidthScale * width_px), 2) + std::pow((o - std::max(0.0, overshoot)) / kOvershootScale, 2);
      if (cost < best) {
        best = cost;
        arg = {blur, k};
      }
    }
  }
  return arg;
}

}  // namespace twin_detail

namespace {

constexpr int kToneStep = 4;  // every 4th pixel: tens of thousands of pairs per view

vision::BoardView boardView(const RealView& v) {
  vision::BoardView b;
  b.gray = v.gray;
  b.ignored = v.ignored;
  b.camera_T_board = v.detection.measurement.camera_T_board;
  return b;
}

/// The rendered images with the radial gain 1 + a2 r^2 + a4 r^4 + a6 r^6 applied.
cv::Mat vignetted(const cv::Mat& img, const sim::Camera& camera, const render::Vignetting& vg) {
  cv::Mat out(img.size(), CV_8UC1);
  for (int v = 0; v < img.rows; ++v) {
    for (int u = 0; u < img.cols; ++u) {
      const double r2 = std::pow(vision::normalizedRadius(camera, Eigen::Vector2d(u, v)), 2);
      out.at<uchar>(v, u) = cv::saturate_cast<uchar>(img.at<uchar>(v, u) * (1.0 + r2 * (vg.a2 + r2 * (vg.a4 + r2 * vg.a6))));
    }
  }
  return out;
}

render::ToneCurve fitTone(const sim::Camera& camera, const sim::Board& board, const std::vector<RealView>& views,
                          const std::vector<cv::Mat>& rendered) {
  std::vector<Eigen::Vector2d> pairs;
  for (std::size_t k = 0; k < views.size(); ++k) {
    const auto p = vision::tonePairs(camera, board, boardView(views[k]), rendered[k], kToneStep);
    pairs.insert(pairs.end(), p.begin(), p.end());
  }
  const vision::ToneFit t = vision::fitToneCurve(pairs);
  return {t.black, t.white, t.gamma};
}

/// Radial gain of the real images' linearised white (through the tone curve's inverse) over the
/// rendered white at the same pixels: the lens's fall-off less the render's lighting.
render::Vignetting fitVignetting(const sim::Camera& camera, const TwinComparison& c, const std::vector<cv::Mat>& rendered,
                                 const render::ToneCurve& tone) {
  std::vector<std::vector<vision::FlatSample>> ratio;
  for (std::size_t k = 0; k < rendered.size(); ++k) {
    std::vector<vision::FlatSample> r;
    for (vision::FlatSample f : c.per_view[0][k].flat) {
      const double in = rendered[k].at<uchar>(f.v, f.u), x = (f.value - tone.black_dn) / (tone.white_dn - tone.black_dn);
      if (!f.white || in < 1.0 || x <= 0.0) continue;
      f.value = 255.0 * std::pow(x, tone.gamma) / in * 100.0;  // any constant: the fit has a gain per view
      r.push_back(f);
    }
    ratio.push_back(std::move(r));
  }
  const vision::Falloff f = vision::radialFalloff(ratio);
  render::Vignetting vg;
  if (!std::isfinite(f.c2)) return vg;
  vg.a2 = f.c2;  // exp(c2 r^2 + c4 r^4) = 1 + c2 r^2 + (c4 + c2^2 / 2) r^4 + ...
  vg.a4 = f.c4 + 0.5 * f.c2 * f.c2;
  return vg;
}

/// The repeatable corner displacement in the board plane (real's less the render's own), and the print's
/// scale along x and y relative to each other (a uniform scale moves no corner about a view's own pose).
render::BoardPrint fitBoardPrint(const sim::Camera& camera, const sim::Board& board, const TwinComparison& c,
                                 const std::vector<RealView>& views) {
  std::map<int, std::vector<Eigen::Vector2d>> shifts[2];
  for (int kind = 0; kind < 2; ++kind) {
    for (std::size_t k = 0; k < views.size(); ++k) {
      const ViewStats& s = c.per_view[kind][k];
      if (!s.found) continue;
      for (const auto& [id, r] : s.residuals) {
        shifts[kind][id].push_back(vision::boardPlaneShift(camera, board, views[k].detection.measurement.camera_T_board, id, r));
      }
    }
  }
  const auto mean = [](const std::vector<Eigen::Vector2d>& v) {
    Eigen::Vector2d m = Eigen::Vector2d::Zero();
    for (const auto& x : v) m += x;
    return v.empty() ? m : Eigen::Vector2d(m / static_cast<double>(v.size()));
  };
  constexpr std::size_t kMinViews = 3;
  std::map<int, Eigen::Vector2d> field;
  for (const auto& [id, v] : shifts[0]) {
    if (v.size() >= kMinViews) field[id] = mean(v) - mean(shifts[1][id]);
  }
  render::BoardPrint print;
  if (field.size() < 4) return print;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  for (const auto& [id, d] : field) centre += sim::cornerInBoard(board, id).head<2>();
  centre /= static_cast<double>(field.size());
  double sxx = 0, sxd = 0, syy = 0, syd = 0;
  for (const auto& [id, d] : field) {
    const Eigen::Vector2d p = sim::cornerInBoard(board, id).head<2>() - centre;
    sxx += p.x() * p.x();
    sxd += p.x() * d.x();
    syy += p.y() * p.y();
    syd += p.y() * d.y();
  }
  const double ex = sxx > 0 ? sxd / sxx : 0.0, ey = syy > 0 ? syd / syy : 0.0;
  print.scale_x = 1.0 + ex;
  print.scale_y = 1.0 + ey;
  for (const auto& [id, d] : field) {
    const Eigen::Vector2d p = sim::cornerInBoard(board, id).head<2>() - centre;
    print.corner_displacement_m[id] = d - Eigen::Vector2d(ex * p.x(), ey * p.y());
  }
  return print;
}

}  // namespace

render::CameraProfile fitCameraProfile(const sim::Camera& camera, const sim::Board& board, const TwinComparison& c,
                                       const std::vector<RealView>& views, const std::vector<cv::Mat>& rendered) {
  render::CameraProfile p;
  p.source = "fitted by orbcal twin";
  if (views.empty()) return p;
  // tone without vignetting, the fall-off through its inverse, then the tone again on vignetted renders
  p.tone = fitTone(camera, board, views, rendered);
  p.vignetting = fitVignetting(camera, c, rendered, p.tone);
  std::vector<cv::Mat> lit;
  for (const cv::Mat& r : rendered) lit.push_back(vignetted(r, camera, p.vignetting));
  p.tone = fitTone(camera, board, views, lit);
  // noise: the real Poisson-Gaussian variance less the render's own
  std::vector<vision::NoiseLevels> nr, nt;
  for (const ViewStats& s : c.per_view[0]) nr.push_back(s.noise);
  for (const ViewStats& s : c.per_view[1]) nt.push_back(s.noise);
  const vision::PoissonGaussian real = vision::fitPoissonGaussian(nr), twin = vision::fitPoissonGaussian(nt);
  p.noise.a_dn = std::max(0.0, real.a - twin.a);
  p.noise.b_dn2 = std::max(0.0, real.b - twin.b);
  // blur and sharpening from the edges
  const auto stat = [&](const std::string& key) {
    for (const TwinStatistic& s : c.statistics) {
      if (s.key == key) return s;
    }
    return TwinStatistic{};
  };
  const TwinStatistic width = stat("edge_width_px"), over = stat("edge_overshoot");
  if (width.real.valid() && width.rendered.valid()) {
    const double overshoot = over.real.valid() && over.rendered.valid() ? over.real.value - over.rendered.value : 0.0;
    std::tie(p.blur_sigma_px, p.sharpening.amount) =
        twin_detail::blurAndSharpening(width.rendered.value, width.real.value, overshoot, p.sharpening.sigma_px);
  }
  const TwinStatistic bg = stat("background_dn"), bg_sd = stat("background_sd_dn");
  if (bg.real.valid()) p.background.mean_dn = bg.real.value;
  if (bg_sd.real.valid()) p.background.texture_dn = bg_sd.real.value;
  p.board = fitBoardPrint(camera, board, c, views);
  return p;
}

}  // namespace orbcal::workflow
