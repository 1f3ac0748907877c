#pragma once
// `orbcal twin DESCRIPTION.yaml -o DIR [--profile camera_profile.yaml]`: every real view of a
// description of images (sim/image_views.hpp) beside its rendered twin, the same board seen by the same
// camera from the same pose, and what differs, statistic by statistic (vision/image_stats.hpp), each
// with its uncertainty over the views and whether the difference is significant; and a camera profile
// (render/camera_profile.hpp) fitted from the differences, which `--profile` applies to the twins.
//
// The twin of a view is rendered at the board pose the view's own detected corners give (its PnP): the
// calibrated chain (frames.yaml's) misplaces the corners of a view by its held-out residual (1.5 to 2.4
// px on the shared sets), which would blur every pixel-pair comparison; the calibration is run and
// reported beside the twins. Writes twin.json (per statistic: real, rendered, profiled, uncertainty,
// significant), camera_profile.yaml (the fitted profile), report.md and report.html (with crops of
// real | rendered | profiled views side by side).
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "orbcal/render/camera_profile.hpp"
#include "orbcal/sim/scene.hpp"
#include "orbcal/vision/image_stats.hpp"
#include "orbcal/vision/real_views.hpp"
#include "orbcal/vision/shared_fit.hpp"

namespace orbcal::workflow {

/// One real view: its grey image as taken, the pixels to ignore (empty: none) and its detection.
struct RealView {
  std::string name;
  cv::Mat gray, ignored;
  vision::ViewMeasurement detection;
};

/// A statistic compared: real, the clean twins, the twins with the camera profile (when given).
struct TwinStatistic {
  std::string key;    ///< e.g. "white_dn"
  std::string label;  ///< for the report, e.g. "white level [DN]"
  vision::Estimate real, rendered, profiled;
  bool significant = false;           ///< real and rendered differ by more than 2 sigma
  bool profiled_significant = false;  ///< real and profiled do
  /// |profiled - real| within 30 % of |real| (issue criterion); false without a profile.
  bool profiled_within(double fraction) const;
};

/// An effect the comparison names: a part of the fitted profile away from the identity by more than a
/// practical threshold, whose statistic differs significantly between real and rendered.
struct NamedEffect {
  std::string name;       ///< "vignetting", "tone curve", "black level", "white level", "blur", "sharpening",
                          ///< "noise", "print scale", "corner displacement", "background",
                          ///< "lens distortion" (the stated intrinsics miss it), "bow"
  double size = 0.0;      ///< in `unit`
  std::string unit;       ///< e.g. "a2", "gamma", "DN", "px sigma", "x/y scale ratio - 1", "mm RMS"
  std::string statistic;  ///< the statistic that shows it
  std::string detail;     ///< the fitted parameters behind the size, where more than one (may be empty)
};
/// Every view's statistics, per image kind (real, rendered, profiled).
struct ViewStats {
  std::map<int, Eigen::Vector2d> residuals;  ///< corner residuals about the view's own pose (px)
  vision::CornerView corners_seen;           ///< the detected corners and the view's own pose
  int corners = 0, markers = 0;
  bool found = false;
  vision::Levels levels;
  vision::NoiseLevels noise;
  vision::EdgeStats edges;
  /// real views: the edges of the clean twin as drawn through the geometry the corners show, measured
  /// where this view's are (the clean twin's own where it shows none): the baseline of blur and sharpening
  vision::EdgeStats reference_edges;
  vision::BackgroundStats background;
  std::vector<vision::FlatSample> flat;
  double gamma = std::numeric_limits<double>::quiet_NaN();  ///< tone fit of this image against the clean twin
};

struct TwinComparison {
  std::vector<TwinStatistic> statistics;
  std::vector<std::string> views;           ///< names of the views compared (the board found in the real image)
  std::vector<std::vector<ViewStats>> per_view;  ///< [kind][view], kind 0 real, 1 rendered, 2 profiled
  /// [kind]: the radial distortion beyond the stated intrinsics (k1, k2) and the board's bow (sagitta, m)
  /// fitted to the corners with every pose refitted (vision/shared_fit.hpp), empty where a kind has no views
  std::vector<vision::SharedFit> geometry;
  render::CameraProfile fitted;             ///< the profile fitted from real against rendered
  sim::Camera camera;                       ///< the stated camera the twins were rendered with
  std::vector<NamedEffect> effects;         ///< namedEffects of this comparison
  std::vector<cv::Mat> crops;               ///< per view: real | rendered | profiled side by side (CV_8UC1)
  bool profiled = false;
  double seconds = 0.0;
};

/// The scene twins are rendered in: `camera` and `board`, the default rendering settings, the board's
/// printed face turned toward the default sun (lit as a board lying on a table is).
sim::Scene twinScene(const sim::Camera& camera, const sim::Board& board);

std::vector<NamedEffect> namedEffects(const TwinComparison& c);

/// The statistics' keys and labels, in the order of twin.json and the report.
const std::vector<std::pair<std::string, std::string>>& twinStatisticNames();

/// Renders the twin of each real view whose board was found (at its detected pose, with `camera`,
/// `board` and the images' size), measures every statistic on real, rendered and (with `profile`)
/// profiled images, and fits a camera profile from real against rendered. Randomness (the profile's
/// noise) from `seed`.
TwinComparison compareWithTwins(const sim::Camera& camera, const sim::Board& board, const std::vector<RealView>& views,
                                const render::CameraProfile* profile, std::uint64_t seed = 1);

/// The profile of real images against their twins: tone, vignetting, noise, blur and sharpening,
/// background and the board as printed (per-corner displacement, scale along x and y relative to each
/// other; lens and bow from the corners: twin_geometry.cpp). Used by compareWithTwins; its inputs are the
/// comparison's per-view statistics, the real views at the poses their corners give under the geometry
/// the comparison shows, and their clean twins drawn through it (the stated camera where it shows none).
render::CameraProfile fitCameraProfile(const sim::Camera& camera, const sim::Board& board, const TwinComparison& c,
                                       const std::vector<RealView>& views, const std::vector<cv::Mat>& rendered);

struct TwinOptions {
  std::string description;   ///< orbcal-measurements-1 with images:
  std::string out;           ///< default <description's folder>/twin
  std::string profile;       ///< camera_profile.yaml to apply (empty: none)
  std::uint64_t seed = 1;
};

struct TwinResult {
  TwinComparison comparison;
  int rows = 0;
  bool calibrated = false;           ///< the calibration was accepted
  double heldout_rms_px = 0.0;       ///< its cross-validated residual (where calibrated)
  std::vector<std::string> calibration_refusals;
  std::string json_path, profile_path, report_path;
  double seconds = 0.0;
};

/// The whole command: read, detect, calibrate, compare, fit, write. InputError naming the file and key.
TwinResult runTwin(const TwinOptions& o);

}  // namespace orbcal::workflow
