// The camera profile fitted from real views against their rendered twins (workflow/twin.hpp).
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "orbcal/render/degrade.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/workflow/twin.hpp"
#include "twin_detail.hpp"

namespace orbcal::workflow {

namespace twin_detail {

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

constexpr int kToneStep = 4;

TwinStatistic statistic(const TwinComparison& c, const std::string& key) {
  for (const TwinStatistic& s : c.statistics) {
    if (s.key == key) return s;
  }
  return TwinStatistic{};
}  // every 4th pixel: tens of thousands of pairs per view

vision::BoardImage boardImage(const RealView& v) {
  vision::BoardImage b;
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
    const auto p = vision::tonePairs(camera, board, boardImage(views[k]), rendered[k], kToneStep);
    pairs.insert(pairs.end(), p.begin(), p.end());
  }
  constexpr double kMaxWhiteDn = 1000.0;  // camera_profile.yaml's bound on the response at full input
  const vision::ToneFit t = vision::fitToneCurve(pairs, kMaxWhiteDn);
  return {std::max(0.0, t.black), t.white, t.gamma};
}

/// Mean over the real views of their clean twins' edges as drawn through the geometry the corners show
/// (the baseline blur and sharpening are fitted against).
vision::Estimate referenceEdges(const TwinComparison& c, double vision::EdgeStats::*member) {
  std::vector<double> x;
  for (const ViewStats& s : c.per_view[0]) x.push_back(s.reference_edges.*member);
  return vision::meanOverViews(x);
}

/// The radial fall-off (c2) of the twins' flat samples with the vignetting `vg` and the tone curve applied
/// (the profile's deterministic part: the flat samples lie inside squares, where blur changes nothing).
double profiledFalloff(const std::vector<std::vector<vision::FlatSample>>& twins, const render::ToneCurve& tone, const render::Vignetting& vg) {
  std::vector<std::vector<vision::FlatSample>> out = twins;
  for (auto& view : out) {
    for (vision::FlatSample& f : view) f.value = std::min(255.0, render::toneCurve(tone, f.value * render::vignettingFactor(vg, f.r)));  // 8 bits
  }
  return vision::radialFalloff(out).c2;
}

/// The lens's fall-off, fitted on the statistic itself: a2 (with a4 = a2^2 / 2, exp(c2 r^2)'s series)
/// such that the twins' flat samples, vignetted and put through the tone curve, fall off as the real
/// ones do (secant steps from the first-order guess: the real fall-off less the twins', carried from DN
/// to radiance through the tone curve's slope at the white level, gamma v / (v - black)). The real
/// fall-off is reproduced whether or not it differs significantly from the twins' (not significant, it
/// is not named). Blur, sharpening and noise leave the flat samples' fall-off alone: on the Doosan set
/// the whole profile applied to every twin gave a c2 within 1e-4 of this model's.
render::Vignetting fitVignetting(const TwinComparison& c, const render::ToneCurve& tone, double white_dn) {
  std::vector<std::vector<vision::FlatSample>> flat[2];
  for (int kind = 0; kind < 2; ++kind) {
    for (const ViewStats& s : c.per_view[kind]) flat[kind].push_back(s.flat);
  }
  const vision::Falloff real = vision::radialFalloff(flat[0]), twin = vision::radialFalloff(flat[1]);
  render::Vignetting vg;
  if (!std::isfinite(real.c2) || !std::isfinite(twin.c2) || !(white_dn > tone.black_dn)) return vg;
  const auto with = [](double a2) { return render::Vignetting{a2, 0.5 * a2 * a2, 0.0}; };
  const auto miss = [&](double a2) { return profiledFalloff(flat[1], tone, with(a2)) - real.c2; };
  double a = 0.0, fa = miss(a);
  double b = tone.gamma * white_dn / (white_dn - tone.black_dn) * (real.c2 - twin.c2), fb = miss(b);
  constexpr int kSteps = 6;
  for (int k = 0; k < kSteps && std::abs(fb) > 1e-6 && fb != fa; ++k) {
    const double next = b - fb * (b - a) / (fb - fa);
    a = b;
    fa = fb;
    b = std::clamp(next, -2.0, 2.0);
    fb = miss(b);
  }
  vg = with(b);
  constexpr double kMinGain = 0.2;  // a fall-off beyond this within the image is not a lens's
  if (!std::isfinite(b) || render::vignettingFactor(vg, 1.0) < kMinGain) vg = {};
  return vg;
}

/// Each view's corner residuals (px, by id) with its pose refitted under `model`.
std::map<int, Eigen::Vector2d> residualsUnder(const ViewStats& s, const vision::CornerModel& model) {
  const Eigen::VectorXd r = vision::refittedResiduals({s.corners_seen}, model);
  std::map<int, Eigen::Vector2d> out;
  for (std::size_t n = 0; n < s.corners_seen.ids.size(); ++n) out[s.corners_seen.ids[n]] = r.segment<2>(2 * static_cast<Eigen::Index>(n));
  return out;
}

/// The repeatable corner displacement in the board plane (real's less the render's own), and the print's
/// scale along x and y relative to each other (a uniform scale moves no corner about a view's own pose).
/// The real residuals are taken under the profile's geometry `p` (its lens and bow: what they explain is
/// not a displacement of the print), the twins' under the stated camera and a flat board.
render::BoardPrint fitBoardPrint(const sim::Camera& camera, const sim::Board& board, const TwinComparison& c,
                                 const std::vector<RealView>& views, const render::CameraProfile& p) {
  const Eigen::VectorXd geometry[2] = {twin_detail::geometryOf(p), Eigen::Vector4d::Zero()};
  std::map<int, std::vector<Eigen::Vector2d>> shifts[2];
  for (int kind = 0; kind < 2; ++kind) {
    const vision::CornerModel model = twin_detail::geometryModel(camera, board, geometry[kind]);
    for (std::size_t k = 0; k < views.size(); ++k) {
      const ViewStats& s = c.per_view[kind][k];
      if (!s.found) continue;
      for (const auto& [id, r] : residualsUnder(s, model)) {
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
  render::BoardPrint print = p.board;
  print.corner_displacement_m.clear();
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
  print.scale_x *= 1.0 + ex;
  print.scale_y *= 1.0 + ey;
  for (const auto& [id, d] : field) {
    const Eigen::Vector2d p = sim::cornerInBoard(board, id).head<2>() - centre;
    print.corner_displacement_m[id] = d - Eigen::Vector2d(ex * p.x(), ey * p.y());
  }
  return print;
}

/// The edge and noise parts corrected by what the profile gives when applied: up to kLoopViews twins
/// profiled, their edge width, overshoot and noise against the real ones of the same views, the targets
/// moved by the difference and the parts fitted again (twice): the Gaussian edge model and the noise
/// after a tone curve are approximations; the loop closes what they leave.
void closeTheLoop(const sim::Camera& camera, const sim::Board& board, const TwinComparison& c, const std::vector<RealView>& views,
                  const std::vector<cv::Mat>& rendered, render::CameraProfile& p) {
  constexpr std::size_t kLoopViews = 8;
  constexpr int kRounds = 2;
  const vision::Estimate base_w = referenceEdges(c, &vision::EdgeStats::width_px), base_o = referenceEdges(c, &vision::EdgeStats::overshoot);
  if (!base_w.valid() || !base_o.valid()) return;
  std::vector<std::size_t> loop;
  for (std::size_t k = 0; k < views.size(); k += std::max<std::size_t>(1, views.size() / kLoopViews)) loop.push_back(k);
  // the real statistics of the loop's views
  std::vector<double> rw, ro, rb, rwh;
  for (std::size_t k : loop) {
    const ViewStats& s = c.per_view[0][k];
    rw.push_back(s.edges.width_px);
    ro.push_back(s.edges.overshoot);
    rb.push_back(s.noise.black_sd);
    rwh.push_back(s.noise.white_sd);
  }
  const auto mean = [](const std::vector<double>& x) { return vision::meanOverViews(x); };
  const vision::Estimate real_w = mean(rw), real_o = mean(ro), real_nb = mean(rb), real_nw = mean(rwh);
  if (!real_w.valid() || !real_o.valid()) return;
  double target_w = real_w.value, target_o = real_o.value - base_o.value;
  std::mt19937_64 rng(1);
  for (int round = 0; round < kRounds; ++round) {
    std::vector<double> w, o, sd_b, sd_w;
    for (std::size_t k : loop) {
      vision::BoardImage v = boardImage(views[k]);
      v.gray = render::applyCameraProfile(rendered[k], vision::boardHullMask(camera, board, v.camera_T_board, 0.0), p, camera, rng);
      const vision::EdgeStats e = vision::edgeStats(camera, board, v);
      const vision::NoiseLevels n = vision::noiseLevels(vision::flatSamples(camera, board, v));
      w.push_back(e.width_px);
      o.push_back(e.overshoot);
      sd_b.push_back(n.black_sd);
      sd_w.push_back(n.white_sd);
    }
    const vision::Estimate pw = mean(w), po = mean(o), pb = mean(sd_b), pwh = mean(sd_w);
    if (pw.valid() && po.valid()) {
      target_w += real_w.value - pw.value;
      target_o += real_o.value - po.value;
      std::tie(p.blur_sigma_px, p.sharpening.amount) =
          twin_detail::blurAndSharpening(base_w.value, std::max(0.5, target_w), target_o, p.sharpening.sigma_px);
    }
    if (real_nb.valid() && real_nw.valid() && pb.valid() && pwh.valid() && pb.value > 0 && pwh.value > 0) {
      // the variance's ratio, real over profiled, averaged over black and white
      const double ratio = 0.5 * (std::pow(real_nb.value / pb.value, 2) + std::pow(real_nw.value / pwh.value, 2));
      p.noise.a_dn *= ratio;
      p.noise.b_dn2 *= ratio;
    }
  }
}

}  // namespace

render::CameraProfile fitCameraProfile(const sim::Camera& camera, const sim::Board& board, const TwinComparison& c,
                                       const std::vector<RealView>& views, const std::vector<cv::Mat>& rendered) {
  render::CameraProfile p;
  p.source = "fitted by orbcal twin";
  if (views.empty()) return p;
  // blur and sharpening from the edges; the tone on renders blurred alike, the fall-off through its slope,
  // then the tone again on vignetted renders
  const TwinStatistic width = statistic(c, "edge_width_px"), over = statistic(c, "edge_overshoot");
  const vision::Estimate base_w = referenceEdges(c, &vision::EdgeStats::width_px), base_o = referenceEdges(c, &vision::EdgeStats::overshoot);
  if (width.real.valid() && base_w.valid()) {
    const double overshoot = over.real.valid() && base_o.valid() ? over.real.value - base_o.value : 0.0;
    std::tie(p.blur_sigma_px, p.sharpening.amount) = twin_detail::blurAndSharpening(base_w.value, width.real.value, overshoot, p.sharpening.sigma_px);
  }
  std::vector<cv::Mat> blurred;
  for (const cv::Mat& r : rendered) {
    blurred.push_back(r.clone());
    render::gaussianBlur(blurred.back(), p.blur_sigma_px);
  }
  // pixels are paired where the geometry the corners show puts the pattern (views and rendered are drawn so)
  const sim::Camera pixels = render::profiledCamera(camera, twin_detail::shownGeometry(c));
  p.tone = fitTone(pixels, board, views, blurred);
  const TwinStatistic white = statistic(c, "white_dn");
  p.vignetting = fitVignetting(c, p.tone, white.real.valid() ? white.real.value : p.tone.white_dn);
  std::vector<cv::Mat> lit;
  for (const cv::Mat& r : blurred) lit.push_back(vignetted(r, camera, p.vignetting));
  p.tone = fitTone(pixels, board, views, lit);
  p.vignetting = fitVignetting(c, p.tone, white.real.valid() ? white.real.value : p.tone.white_dn);  // again, with the final tone
  // noise: the real Poisson-Gaussian variance less the render's own
  std::vector<vision::NoiseLevels> nr, nt;
  for (const ViewStats& s : c.per_view[0]) nr.push_back(s.noise);
  for (const ViewStats& s : c.per_view[1]) nt.push_back(s.noise);
  const vision::PoissonGaussian real = vision::fitPoissonGaussian(nr), twin = vision::fitPoissonGaussian(nt);
  p.noise.a_dn = std::max(0.0, real.a - twin.a);
  p.noise.b_dn2 = std::max(0.0, real.b - twin.b);
  closeTheLoop(pixels, board, c, views, rendered, p);
  const TwinStatistic bg = statistic(c, "background_dn"), bg_sd = statistic(c, "background_sd_dn");
  if (bg.real.valid()) p.background.mean_dn = bg.real.value;
  if (bg_sd.real.valid()) p.background.texture_dn = bg_sd.real.value;
  // the geometry (lens, bow, print scale) where the real corners show it beyond the twins' own
  const render::CameraProfile shown = twin_detail::shownGeometry(c);
  p.lens = shown.lens;
  p.board = shown.board;
  p.board = fitBoardPrint(camera, board, c, views, p);
  return p;
}

}  // namespace orbcal::workflow

namespace orbcal::workflow {

std::vector<NamedEffect> namedEffects(const TwinComparison& c) {
  // Practical thresholds: below these an effect changes no statistic by more than its spread over views
  // on the shared sets, and a clean render's fit stays below them.
  constexpr double kMinA2 = 0.05, kMinGamma = 0.05, kMinLevelDn = 3.0, kMinBlurPx = 0.2, kMinSharpening = 0.1;
  constexpr double kMinNoiseDn = 0.5, kMinScale = 0.002, kMinDisplacementMm = 0.05, kMinBackgroundDn = 5.0;
  constexpr double kMinLensShiftPx = 0.5, kMinBowMm = 0.5;
  const auto sig = [&](const std::string& key) { return statistic(c, key).significant; };
  const render::CameraProfile& p = c.fitted;
  std::vector<NamedEffect> out;
  const auto name = [&](bool shown, const char* n, double size, const char* unit, const char* stat) {
    if (shown) out.push_back({n, size, unit, stat});
  };
  name(sig("vignetting_half") && std::abs(p.vignetting.a2) > kMinA2, "vignetting", p.vignetting.a2, "a2", "vignetting_half");
  name(sig("tone_gamma") && std::abs(p.tone.gamma - 1.0) > kMinGamma, "tone curve", p.tone.gamma, "gamma", "tone_gamma");
  const TwinStatistic black = statistic(c, "black_dn"), white = statistic(c, "white_dn");
  name(black.significant && std::abs(black.real.value - black.rendered.value) > kMinLevelDn, "black level", black.real.value - black.rendered.value,
       "DN", "black_dn");
  name(white.significant && std::abs(white.real.value - white.rendered.value) > kMinLevelDn, "white level", white.real.value - white.rendered.value,
       "DN", "white_dn");
  name(sig("edge_width_px") && p.blur_sigma_px > kMinBlurPx, "blur", p.blur_sigma_px, "px sigma", "edge_width_px");
  name(sig("edge_overshoot") && p.sharpening.amount > kMinSharpening, "sharpening", p.sharpening.amount, "unsharp gain", "edge_overshoot");
  const double mid_sd = std::sqrt(p.noise.a_dn * 128.0 + p.noise.b_dn2);
  name((sig("noise_black_dn") || sig("noise_white_dn")) && mid_sd > kMinNoiseDn, "noise", mid_sd, "DN at 128", "noise_white_dn");
  const double ratio = p.board.scale_x / p.board.scale_y - 1.0;
  name(sig("corner_scatter_px") && std::abs(ratio) > kMinScale, "print scale", ratio, "x/y scale ratio - 1", "corner_scatter_px");
  double ss = 0.0;
  for (const auto& [id, d] : p.board.corner_displacement_m) ss += d.squaredNorm();
  const double rms_mm = p.board.corner_displacement_m.empty() ? 0.0 : 1e3 * std::sqrt(ss / p.board.corner_displacement_m.size());
  name(sig("corner_repeatable_share") && sig("corner_scatter_px") && rms_mm > kMinDisplacementMm, "corner displacement", rms_mm, "mm RMS",
       "corner_repeatable_share");
  const double lens_px = render::lensShiftAtImageCorner(c.camera, p.lens);
  name(sig("lens_shift_px") && lens_px > kMinLensShiftPx, "lens distortion", lens_px, "px at the image corner", "lens_shift_px");
  if (!out.empty() && out.back().name == "lens distortion") {
    out.back().detail = "the stated intrinsics miss a radial distortion of k1 = " + sim::formatNumber("%.4g", p.lens.k1) +
                        ", k2 = " + sim::formatNumber("%.4g", p.lens.k2) + " (normalised coordinates)";
  }
  name(sig("bow_mm") && std::abs(p.board.bow_m) * 1e3 > kMinBowMm, "bow", p.board.bow_m * 1e3, "mm sagitta at the half diagonal", "bow_mm");
  const TwinStatistic bg = statistic(c, "background_dn");
  name(bg.significant && std::abs(bg.real.value - bg.rendered.value) > kMinBackgroundDn, "background", bg.real.value - bg.rendered.value, "DN",
       "background_dn");
  return out;
}

}  // namespace orbcal::workflow
