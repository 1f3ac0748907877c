// `orbcal twin`: read, detect, calibrate, compare with the twins, write (workflow/twin.hpp).
#include <chrono>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/image_files.hpp"
#include "orbcal/workflow/measured_images.hpp"
#include "orbcal/workflow/report_html.hpp"
#include "orbcal/workflow/twin.hpp"

namespace orbcal::workflow {

namespace {

constexpr double kWithin = 0.3;  // the profile's aim: every statistic within 30 % of the real one
constexpr std::size_t kCropsShown = 6;

std::string jsonEstimate(const vision::Estimate& e, const std::string& key) {
  if (!e.valid()) return "null";
  return "{\"value\": " + sim::jsonNumber(e.value, key) + ", \"sigma\": " + sim::jsonNumber(e.sigma, key + ".sigma") +
         ", \"views\": " + std::to_string(e.n) + "}";
}

std::string twinJson(const TwinResult& r) {
  const TwinComparison& c = r.comparison;
  std::ostringstream o;
  o << "{\n  \"format\": \"orbcal-twin-1\",\n  \"views\": " << c.views.size() << ",\n  \"rows\": " << r.rows
    << ",\n  \"profiled\": " << (c.profiled ? "true" : "false") << ",\n  \"statistics\": {";
  for (std::size_t k = 0; k < c.statistics.size(); ++k) {
    const TwinStatistic& s = c.statistics[k];
    const std::string key = "twin.json: " + s.key;
    o << (k ? "," : "") << "\n    " << sim::jsonString(s.key) << ": {\"label\": " << sim::jsonString(s.label)
      << ", \"real\": " << jsonEstimate(s.real, key + ".real") << ", \"rendered\": " << jsonEstimate(s.rendered, key + ".rendered")
      << ", \"profiled\": " << jsonEstimate(s.profiled, key + ".profiled") << ", \"significant\": " << (s.significant ? "true" : "false")
      << ", \"profiled_significant\": " << (s.profiled_significant ? "true" : "false")
      << ", \"profiled_within_30_percent\": " << (s.profiled_within(kWithin) ? "true" : "false") << "}";
  }
  o << "\n  },\n  \"effects\": [";
  for (std::size_t k = 0; k < c.effects.size(); ++k) {
    const NamedEffect& e = c.effects[k];
    o << (k ? "," : "") << "\n    {\"name\": " << sim::jsonString(e.name) << ", \"size\": " << sim::jsonNumber(e.size, "twin.json: effects." + e.name)
      << ", \"unit\": " << sim::jsonString(e.unit) << ", \"statistic\": " << sim::jsonString(e.statistic)
      << ", \"detail\": " << sim::jsonString(e.detail) << "}";
  }
  o << "\n  ]\n}\n";
  return o.str();
}

std::string cell(const vision::Estimate& e) {
  if (!e.valid()) return "-";
  return sim::formatNumber("%.4g", e.value) + " ± " + sim::formatNumber("%.2g", e.sigma);
}

std::string twinMarkdown(const TwinResult& r, const std::string& description) {
  const TwinComparison& c = r.comparison;
  std::ostringstream m;
  m << "# Real views and their rendered twins\n\n";
  m << "**" << c.views.size() << " of " << r.rows << " views compared";
  int significant = 0, within = 0;
  for (const TwinStatistic& s : c.statistics) {
    significant += s.significant ? 1 : 0;
    within += s.profiled_within(kWithin) ? 1 : 0;
  }
  m << "; the clean twins differ significantly (beyond 2 sigma) in " << significant << " of " << c.statistics.size() << " statistics";
  if (c.profiled) m << "; with the profile, " << within << " of " << c.statistics.size() << " are within 30 % of the real value";
  m << ".**\n\n";
  m << "Description: `" << description << "`. Each twin is the board rendered at the pose the view's own corners give, with the "
       "description's camera and board; the statistics are measured alike on both (pixels the description ignores left out in "
       "both). Value ± its standard error over the views (jackknife for the pooled ones).\n\n";
  m << "Calibration of the same views: "
    << (r.calibrated ? "accepted, held-out residual " + sim::formatNumber("%.3f", r.heldout_rms_px) + " px"
                     : "refused (" + (r.calibration_refusals.empty() ? std::string("no views") : r.calibration_refusals.front()) + ")")
    << ".\n\n";
  m << "## Statistics\n\n| statistic | real | rendered | profiled | real vs rendered |\n|---|---|---|---|---|\n";
  for (const TwinStatistic& s : c.statistics) {
    m << "| " << s.label << " | " << cell(s.real) << " | " << cell(s.rendered) << " | " << cell(s.profiled) << " | "
      << (s.significant ? "differs" : "agrees") << " |\n";
  }
  m << "\n## Effects named\n\n";
  if (c.effects.empty()) m << "None: no part of the fitted profile is both beyond its practical threshold and significant.\n";
  for (const NamedEffect& e : c.effects) {
    m << "- " << e.name << ": " << sim::formatNumber("%.4g", e.size) << " " << e.unit << " (shown by " << e.statistic << ")"
      << (e.detail.empty() ? "" : ": " + e.detail) << "\n";
  }
  const render::CameraProfile& p = c.fitted;
  m << "\n## Fitted camera profile (camera_profile.yaml)\n\n";
  m << "- tone: black " << sim::formatNumber("%.1f", p.tone.black_dn) << " DN, white " << sim::formatNumber("%.1f", p.tone.white_dn)
    << " DN, gamma " << sim::formatNumber("%.3f", p.tone.gamma) << "\n";
  m << "- vignetting: a2 " << sim::formatNumber("%.4f", p.vignetting.a2) << ", a4 " << sim::formatNumber("%.4f", p.vignetting.a4) << "\n";
  m << "- noise: variance " << sim::formatNumber("%.4f", p.noise.a_dn) << " x level + " << sim::formatNumber("%.3f", p.noise.b_dn2) << " DN^2\n";
  m << "- extra blur sigma " << sim::formatNumber("%.3f", p.blur_sigma_px) << " px, unsharp mask gain "
    << sim::formatNumber("%.3f", p.sharpening.amount) << " (sigma " << sim::formatNumber("%.2f", p.sharpening.sigma_px) << " px)\n";
  m << "- print scale x / y " << sim::formatNumber("%.5f", p.board.scale_x) << " / " << sim::formatNumber("%.5f", p.board.scale_y)
    << ", bow " << sim::formatNumber("%.3f", p.board.bow_m * 1e3) << " mm; " << p.board.corner_displacement_m.size() << " corner displacements\n";
  m << "- radial distortion beyond the stated intrinsics: k1 " << sim::formatNumber("%.4f", p.lens.k1) << ", k2 " << sim::formatNumber("%.4f", p.lens.k2)
    << " (" << sim::formatNumber("%.2f", render::lensShiftAtImageCorner(c.camera, p.lens)) << " px at the image corner)\n";
  m << "\n## Views: real | rendered" << (c.profiled ? " | profiled" : "") << "\n\n";
  for (std::size_t k = 0; k < std::min(kCropsShown, c.crops.size()); ++k) m << "![" << c.views[k] << "](crops/view" << k << ".png)\n\n";
  return m.str();
}

std::string folderOf(const std::string& path) {
  const std::filesystem::path p = std::filesystem::path(path).parent_path();
  return p.empty() ? "." : p.string();
}

}  // namespace

TwinResult runTwin(const TwinOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  if (!sim::describesImages(o.description)) {
    throw sim::InputError(o.description + ": images: missing: orbcal twin compares a description of images (docs/real-images.md)");
  }
  const sim::ImageViews data = sim::loadImageViews(o.description);
  if (data.board.type == sim::BoardType::kCircles) {
    throw sim::InputError(o.description + ": board: circles: orbcal twin's statistics are those of chessboard and ChArUco squares "
                          "(edges, flat squares); a circle grid calibrates (orbcal calibrate) but has no twin");
  }
  std::optional<render::CameraProfile> profile;
  if (!o.profile.empty()) profile = render::loadCameraProfile(o.profile);
  const std::vector<vision::ViewMeasurement> det = detectImageViews(data);
  TwinResult r;
  r.rows = static_cast<int>(data.views.size());
  const ImageCalibrateResult cal = calibrateImageViews(data, det);
  r.calibrated = cal.refusals.empty();
  r.heldout_rms_px = cal.heldout_rms_px;
  r.calibration_refusals = cal.refusals;
  std::vector<RealView> views;
  for (std::size_t k = 0; k < data.views.size(); ++k) {
    RealView v;
    v.name = std::filesystem::path(data.views[k].image).filename().string();
    v.detection = det[k];
    if (!det[k].measurement.found()) {
      views.push_back(std::move(v));
      continue;
    }
    const cv::Mat colour = sim::readImage(data.views[k].image, cv::IMREAD_COLOR);
    if (colour.empty()) throw sim::InputError(data.views[k].where + ": " + data.views[k].image + ": cannot be read");
    cv::cvtColor(colour, v.gray, cv::COLOR_BGR2GRAY);
    v.ignored = vision::ignoredPixels(colour, data.mask, data.views[k].mask);
    views.push_back(std::move(v));
  }
  r.comparison = compareWithTwins(data.camera, data.board, views, profile ? &*profile : nullptr, o.seed);

  sim::OutputFolder folder(o.out.empty() ? folderOf(o.description) + "/twin" : o.out, "orbcal twin");
  const std::string& out = folder.path();
  std::filesystem::create_directories(out + "/crops");
  for (std::size_t k = 0; k < std::min(kCropsShown, r.comparison.crops.size()); ++k) {
    const std::string crop = out + "/crops/view" + std::to_string(k) + ".png";
    if (!sim::writeImage(crop, r.comparison.crops[k])) throw std::runtime_error(crop + ": cannot write the image");
  }
  sim::writeFileAtomic(out + "/twin.json", twinJson(r));
  render::saveCameraProfile(r.comparison.fitted, out + "/camera_profile.yaml");
  writeReport(out, twinMarkdown(r, o.description));
  folder.commit();
  r.json_path = folder.finalPath() + "/twin.json";
  r.profile_path = folder.finalPath() + "/camera_profile.yaml";
  r.report_path = folder.finalPath() + "/report.html";
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace orbcal::workflow
