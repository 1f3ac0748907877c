// Real views beside their rendered twins, statistic by statistic (workflow/twin.hpp).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <opencv2/imgproc.hpp>

#include "orbcal/render/degrade.hpp"
#include "orbcal/render/renderer.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/workflow/twin.hpp"
#include "twin_detail.hpp"

namespace orbcal::workflow {

namespace {

enum Kind { kReal = 0, kRendered = 1, kProfiled = 2 };

/// A real lens and print leave up to ~1.3 px PnP RMS (measured_images.cpp: 2 px still rejects a wrong detection).
constexpr double kMaxViewRmsPx = 2.0;
/// Tone pairs per view: every 3rd pixel of the board (tens of thousands: enough for three parameters).
constexpr int kToneStep = 3;

vision::MeasureSettings measureSettings() {
  vision::MeasureSettings s;
  s.max_rms_px = kMaxViewRmsPx;
  return s;
}

/// The clean twin blurred to the edge width of the image it is paired with (Gaussian edges: the extra sigma
/// is sqrt(w^2 - w_clean^2) / 2.563), so that the tone curve's pixel pairs along the edges compare like
/// with like: a blur alone bends the pairs of a sharp and a blurred edge into a false curve.
cv::Mat toneReference(const cv::Mat& clean, double clean_width_px, double width_px) {
  constexpr double kGaussian1090 = 2.5631;
  if (!(clean_width_px > 0.0) || !(width_px > clean_width_px)) return clean;
  cv::Mat blurred = clean.clone();
  render::gaussianBlur(blurred, std::sqrt(width_px * width_px - clean_width_px * clean_width_px) / kGaussian1090);
  return blurred;
}

/// The corner statistics of a view's detection: residuals about its own pose under the stated camera.
ViewStats cornerStats(const sim::Camera& camera, const sim::Board& board, const vision::ViewMeasurement& det) {
  ViewStats s;
  s.found = det.measurement.found();
  s.markers = det.markers;
  if (s.found) {
    vision::BoardImage own;
    own.camera_T_board = det.measurement.camera_T_board;
    own.corners_px = det.measurement.corners_px;
    for (std::size_t n = 0; n < own.corners_px.size(); ++n) own.ids.push_back(det.measurement.cornerId(n));
    s.residuals = vision::cornerResiduals(camera, board, own);
    s.corners = static_cast<int>(own.ids.size());
    s.corners_seen = {own.camera_T_board, own.ids, own.corners_px};
  }
  return s;
}

/// The pixel statistics, where `camera` (the stated one, or with the lens the corners show) and `pose`
/// put the pattern; the tone against `reference` (a clean twin drawn alike) blurred to the image's edges.
void pixelStats(ViewStats& s, const sim::Camera& camera, const sim::Board& board, const cv::Mat& gray, const cv::Mat& ignored,
                const Eigen::Isometry3d& pose, const cv::Mat& reference, double clean_width_px = std::numeric_limits<double>::quiet_NaN()) {
  vision::BoardImage v;
  v.gray = gray;
  v.ignored = ignored;
  v.camera_T_board = pose;
  s.flat = vision::flatSamples(camera, board, v);
  s.levels = vision::blackWhiteLevels(s.flat);
  s.noise = vision::noiseLevels(s.flat);
  s.edges = vision::edgeStats(camera, board, v);
  s.background = vision::backgroundStats(camera, board, v);
  const cv::Mat blurred = toneReference(reference, clean_width_px, s.edges.width_px);
  s.gamma = vision::fitToneCurve(vision::tonePairs(camera, board, v, blurred, kToneStep)).gamma;
}

/// Where a view's pattern is under a geometry, and its clean twin drawn through it (`drawn`: a renderer
/// with that geometry; null: the stated camera, `pose` and `clean`). The statistics assume the board as
/// designed, so they are placed by the lens part alone (the camera with it, the pose refitted under it);
/// the twin is drawn with all of it at the pose refitted under all of it, and its own edge width is
/// measured where the statistics look (the tone's reference is blurred from there to the image's).
struct Aligned {
  sim::Camera camera;
  Eigen::Isometry3d pose;
  cv::Mat clean;
  vision::EdgeStats clean_edges;
};
Aligned aligned(render::BoardRenderer* drawn, const render::CameraProfile& geometry, const sim::Camera& camera, const sim::Board& board,
                const ViewStats& seen, const Eigen::Isometry3d& pose, const cv::Mat& clean, const vision::EdgeStats& clean_edges) {
  if (!drawn || !seen.found) return {camera, pose, clean, clean_edges};
  const Eigen::VectorXd g = twin_detail::geometryOf(geometry);
  Eigen::VectorXd lens_only = Eigen::VectorXd::Zero(g.size());
  lens_only.head<2>() = g.head<2>();
  Aligned a;
  a.camera = render::profiledCamera(camera, geometry);
  a.pose = vision::refitPose(seen.corners_seen, twin_detail::geometryModel(camera, board, lens_only));
  a.clean = drawn->renderClean(vision::refitPose(seen.corners_seen, twin_detail::geometryModel(camera, board, g)));
  vision::BoardImage b;
  b.gray = a.clean;
  b.camera_T_board = a.pose;
  a.clean_edges = vision::edgeStats(a.camera, board, b);
  return a;
}

/// Jackknife estimate over views of a statistic of all views (`of` takes the views to use).
vision::Estimate jackknife(std::size_t n, const std::function<double(const std::vector<std::size_t>&)>& of) {
  vision::Estimate e;
  std::vector<std::size_t> all(n);
  for (std::size_t k = 0; k < n; ++k) all[k] = k;
  e.value = of(all);
  e.n = static_cast<int>(n);
  if (n < 3) {
    e.sigma = 0.0;
    return e;
  }
  std::vector<double> leave;
  for (std::size_t k = 0; k < n; ++k) {
    std::vector<std::size_t> rest;
    for (std::size_t j = 0; j < n; ++j) {
      if (j != k) rest.push_back(j);
    }
    leave.push_back(of(rest));
  }
  double mean = 0.0, ss = 0.0;
  for (double x : leave) mean += x / static_cast<double>(n);
  for (double x : leave) ss += (x - mean) * (x - mean);
  e.sigma = std::sqrt((n - 1.0) / n * ss);
  return e;
}

/// Every statistic of one kind of image over the views (`geometry`: their fitGeometry).
std::map<std::string, vision::Estimate> aggregate(const sim::Camera& camera, const std::vector<ViewStats>& views, const vision::SharedFit& geometry) {
  std::map<std::string, vision::Estimate> out;
  const auto over = [&](const std::function<double(const ViewStats&)>& f) {
    std::vector<double> x;
    for (const ViewStats& v : views) x.push_back(f(v));
    return vision::meanOverViews(x);
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  out["corner_scatter_px"] = over([&](const ViewStats& v) { return v.found ? vision::cornerScatterPx(v.residuals) : nan; });
  out["corner_repeatable_share"] = jackknife(views.size(), [&](const std::vector<std::size_t>& use) {
    std::vector<std::map<int, Eigen::Vector2d>> r;
    for (std::size_t k : use) {
      if (views[k].found) r.push_back(views[k].residuals);
    }
    return vision::repeatableCornerPart(r).share;
  });
  out["lens_shift_px"] = twin_detail::lensShiftEstimate(camera, geometry);
  out["bow_mm"] = twin_detail::bowEstimate(geometry);
  out["corners"] = over([](const ViewStats& v) { return static_cast<double>(v.corners); });
  out["markers"] = over([](const ViewStats& v) { return static_cast<double>(v.markers); });
  out["black_dn"] = over([](const ViewStats& v) { return v.levels.black; });
  out["white_dn"] = over([](const ViewStats& v) { return v.levels.white; });
  out["tone_gamma"] = over([](const ViewStats& v) { return v.gamma; });
  std::vector<std::vector<vision::FlatSample>> flat;
  for (const ViewStats& v : views) flat.push_back(v.flat);
  out["vignetting_half"] = vision::radialFalloff(flat).at_half;
  out["noise_black_dn"] = over([](const ViewStats& v) { return v.noise.black_sd; });
  out["noise_white_dn"] = over([](const ViewStats& v) { return v.noise.white_sd; });
  out["edge_width_px"] = over([](const ViewStats& v) { return v.edges.width_px; });
  out["edge_overshoot"] = over([](const ViewStats& v) { return v.edges.overshoot; });
  out["edge_undershoot"] = over([](const ViewStats& v) { return v.edges.undershoot; });
  out["background_dn"] = over([](const ViewStats& v) { return v.background.mean; });
  out["background_sd_dn"] = over([](const ViewStats& v) { return v.background.sd; });
  return out;
}

/// real | rendered | profiled around the board's centre, at most 240 px square each.
cv::Mat sideBySide(const sim::Camera& camera, const sim::Board& board, const Eigen::Isometry3d& pose, const std::vector<cv::Mat>& images) {
  constexpr int kCrop = 240;
  const Eigen::Vector2d c = vision::projectBoardPoint(camera, pose, sim::cornerInBoard(board, 0));  // a corner: edges and a marker
  const int w = std::min(kCrop, camera.width_px), h = std::min(kCrop, camera.height_px);
  const int x = std::clamp(static_cast<int>(c.x()) - w / 2, 0, camera.width_px - w), y = std::clamp(static_cast<int>(c.y()) - h / 2, 0, camera.height_px - h);
  std::vector<cv::Mat> parts;
  for (const cv::Mat& m : images) {
    if (!m.empty()) parts.push_back(m(cv::Rect(x, y, w, h)));
  }
  cv::Mat out;
  cv::hconcat(parts, out);
  return out;
}

}  // namespace

bool TwinStatistic::profiled_within(double fraction) const {
  return profiled.valid() && real.valid() && std::abs(profiled.value - real.value) <= fraction * std::abs(real.value);
}

sim::Scene twinScene(const sim::Camera& camera, const sim::Board& board) {
  sim::Scene scene;
  scene.camera = camera;
  scene.board = board;
  // the printed face (-z_board) turned up (+z_base), toward the default sun: lit as a board on a table is
  scene.base_T_board.linear() = Eigen::AngleAxisd(sim::kPi, Eigen::Vector3d::UnitX()).toRotationMatrix();
  return scene;
}

const std::vector<std::pair<std::string, std::string>>& twinStatisticNames() {
  static const std::vector<std::pair<std::string, std::string>> names{
      {"corner_scatter_px", "corner scatter about the view's fitted pose [px RMS]"},
      {"corner_repeatable_share", "share of the corner scatter repeating per corner id"},
      {"lens_shift_px", "radial distortion beyond the stated intrinsics: shift at the image corner [px]"},
      {"bow_mm", "board bow: sagitta at the half diagonal [mm]"},
      {"corners", "corners detected per view"},
      {"markers", "markers decoded per view"},
      {"black_dn", "black level [DN]"},
      {"white_dn", "white level [DN]"},
      {"tone_gamma", "tone curve gamma against the twin (blurred to its edge width)"},
      {"vignetting_half", "white level at half radius, relative"},
      {"noise_black_dn", "noise on black [DN]"},
      {"noise_white_dn", "noise on white [DN]"},
      {"edge_width_px", "edge width 10-90 % [px]"},
      {"edge_overshoot", "edge overshoot, of the step"},
      {"edge_undershoot", "edge undershoot, of the step"},
      {"background_dn", "background level [DN]"},
      {"background_sd_dn", "background spread [DN]"},
  };
  return names;
}

TwinComparison compareWithTwins(const sim::Camera& camera, const sim::Board& board, const std::vector<RealView>& views,
                                const render::CameraProfile* profile, std::uint64_t seed) {
  const auto t0 = std::chrono::steady_clock::now();
  TwinComparison c;
  c.profiled = profile != nullptr;
  c.camera = camera;
  c.per_view.assign(3, {});
  const sim::Scene scene = twinScene(camera, board);
  render::BoardRenderer renderer(scene, render::RenderSettings{});
  // the corners first, real and the clean twins' (detected with the real view's ignored pixels filled as
  // the real image's were), and the geometry they show
  const auto detect = [&](const cv::Mat& img, const cv::Mat& ignored) {
    return vision::measureGray(vision::fillIgnored(img, ignored), camera, board, measureSettings());
  };
  std::vector<RealView> used;
  std::vector<cv::Mat> cleans;
  for (const RealView& v : views) {
    if (!v.detection.measurement.found()) continue;
    cleans.push_back(renderer.renderClean(v.detection.measurement.camera_T_board));
    c.per_view[kRendered].push_back(cornerStats(camera, board, detect(cleans.back(), v.ignored)));
    c.per_view[kReal].push_back(cornerStats(camera, board, v.detection));
    c.views.push_back(v.name);
    used.push_back(v);
  }
  if (c.views.empty()) throw sim::InputError("orbcal twin: the board was found in no view: nothing to compare");
  for (int kind : {kReal, kRendered}) c.geometry.push_back(twin_detail::fitGeometry(camera, board, c.per_view[kind]));
  // the real images' pixels are measured where the geometry their corners show puts the pattern
  const render::CameraProfile shown = twin_detail::shownGeometry(c);
  std::unique_ptr<render::BoardRenderer> drawn, printed;
  if (!shown.geometryIdentity()) drawn = std::make_unique<render::BoardRenderer>(scene, render::RenderSettings{}, shown);
  if (profile && !profile->geometryIdentity()) printed = std::make_unique<render::BoardRenderer>(scene, render::RenderSettings{}, *profile);
  std::mt19937_64 rng(seed);
  std::vector<RealView> at_real = used;  // the real views at the poses their corners give under the shown geometry
  std::vector<cv::Mat> drawn_cleans;      // and their clean twins drawn through it (the profile's fit pairs pixels with these)
  for (std::size_t k = 0; k < used.size(); ++k) {
    const RealView& v = used[k];
    const Eigen::Isometry3d& pose = v.detection.measurement.camera_T_board;
    pixelStats(c.per_view[kRendered][k], camera, board, cleans[k], v.ignored, pose, cleans[k]);
    const vision::EdgeStats& clean_edges = c.per_view[kRendered][k].edges;
    const Aligned real = aligned(drawn.get(), shown, camera, board, c.per_view[kReal][k], pose, cleans[k], clean_edges);
    pixelStats(c.per_view[kReal][k], real.camera, board, v.gray, v.ignored, real.pose, real.clean, real.clean_edges.width_px);
    c.per_view[kReal][k].reference_edges = real.clean_edges;
    at_real[k].detection.measurement.camera_T_board = real.pose;
    drawn_cleans.push_back(real.clean);
    cv::Mat profiled;
    if (profile) {
      // drawn through the profile's geometry at the pose the real corners give under it
      const Aligned at = aligned(printed.get(), *profile, camera, board, c.per_view[kReal][k], pose, cleans[k], clean_edges);
      profiled = render::applyCameraProfile(at.clean, vision::boardHullMask(at.camera, board, at.pose, 0.0), *profile, camera, rng);
      c.per_view[kProfiled].push_back(cornerStats(camera, board, detect(profiled, v.ignored)));
      pixelStats(c.per_view[kProfiled].back(), at.camera, board, profiled, v.ignored, at.pose, at.clean, at.clean_edges.width_px);
    }
    c.crops.push_back(sideBySide(camera, board, pose, {v.gray, cleans[k], profiled}));
  }
  if (profile) c.geometry.push_back(twin_detail::fitGeometry(camera, board, c.per_view[kProfiled]));
  const auto real = aggregate(camera, c.per_view[kReal], c.geometry[kReal]), rendered = aggregate(camera, c.per_view[kRendered], c.geometry[kRendered]);
  const auto profiled = profile ? aggregate(camera, c.per_view[kProfiled], c.geometry[kProfiled]) : std::map<std::string, vision::Estimate>{};
  for (const auto& [key, label] : twinStatisticNames()) {
    TwinStatistic s;
    s.key = key;
    s.label = label;
    s.real = real.at(key);
    s.rendered = rendered.at(key);
    if (profile) s.profiled = profiled.at(key);
    s.significant = vision::differsSignificantly(s.real, s.rendered);
    s.profiled_significant = vision::differsSignificantly(s.real, s.profiled);
    c.statistics.push_back(s);
  }
  c.fitted = fitCameraProfile(camera, board, c, at_real, drawn_cleans);
  c.effects = namedEffects(c);
  c.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return c;
}

}  // namespace orbcal::workflow
