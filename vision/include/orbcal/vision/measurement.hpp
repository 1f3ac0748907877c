#pragma once
// One image -> one measured end-effector pose with its covariance, or a status saying why not; and
// the measurement table `orbcal measure` writes (<dataset>/measurements.csv). loadMeasurements is its
// reader for tools and users; the experiments use the rows in memory.
//
// measurements.csv: header line, then one row per sample of samples.csv, in its order. No image is
// dropped: a sample without a pose has its status and reason and empty numeric cells.
//   index, image                           as in samples.csv
//   status                                 found | not_found | rejected | unreadable
//   reason                                 short fixed phrase (empty when found), e.g. "no board found"
//   detail                                 specifics for a human (commas replaced by ';')
//   num_corners, rms_px                    corners used; RMS distance detected - reprojected (px)
//   cam_board_{x,y,z}_m, cam_board_{rx,ry,rz}_rad     camera_T_board: translation, rotation vector
//   base_flange_{x,y,z}_m, base_flange_{rx,ry,rz}_rad base_T_flange measured (pose.hpp)
//   cov_<r><c> for 0 <= r <= c <= 5 (21 cells, row-major upper triangle): covariance of e_f, the
//                                          right perturbation of base_T_flange in the flange frame,
//                                          ordered [x y z (m); rx ry rz (rad)] (pose.hpp)
//   err_{x,y,z}_m, err_{rx,ry,rz}_rad       sim::poseMinus(base_T_flange measured, FK(nominal arm, q));
//                                          empty when no joint reading was available
#include <Eigen/Geometry>
#include <functional>
#include <map>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/vision/corners.hpp"
#include "orbcal/vision/pose.hpp"

namespace orbcal::vision {

struct MeasureSettings {
  DetectorSettings detector;
  /// A pose whose corners reproject worse than this (RMS, px) is rejected: a mis-ordered, partly
  /// wrong or smeared detection. Rendered views give ~0.07 px, calibrated real lenses 0.2-0.5 px;
  /// 1 px leaves room for real images while catching gross detection errors (> several px).
  double max_rms_px = 1.0;
  /// Reject images whose size differs from the scene camera's (another camera, a resized copy).
  bool require_camera_size = true;
  /// A board that is the same after a half turn (sim::halfTurnSymmetric: circle grids) is measured in
  /// the detector's order, its orientation left to the caller, who resolves it across views with the
  /// flange poses (calib::resolveHalfTurns). Off: such a view is kRejected ("orientation undecidable").
  bool half_turn_resolved_across_views = false;
  /// Circle grids: subtract the ellipse-centre bias the view's pose predicts (circles.hpp); off only to
  /// measure what it changes.
  bool correct_ellipse_bias = true;
};

struct Measurement {
  int index = 0;
  std::string image;
  ImageStatus status = ImageStatus::kNotFound;
  std::string reason;
  std::string detail;
  int num_corners = 0;
  double rms_px = 0.0;
  // Valid when status == kFound:
  Eigen::Isometry3d camera_T_board = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d base_T_flange = Eigen::Isometry3d::Identity();
  sim::Matrix6d covariance = sim::Matrix6d::Zero();  ///< of e_f (pose.hpp)
  bool has_pose_error = false;                       ///< a joint reading q was given
  sim::Vector6d pose_error = sim::Vector6d::Zero();  ///< poseMinus(base_T_flange, FK(nominal, q)); zero without q
  /// The detected inner corners (px), k as in sim::cornerInBoard; in memory only (measurements.csv
  /// does not hold them, so loadMeasurements leaves this empty). Filled when found.
  std::vector<Eigen::Vector2d> corners_px;
  /// ChArUco boards: the inner corner each of corners_px is (ascending; a partly visible board gives
  /// some). Empty for a chessboard: corners_px then holds every corner in order.
  std::vector<int> corner_ids;
  /// The inner corner corners_px[n] is.
  int cornerId(std::size_t n) const { return corner_ids.empty() ? static_cast<int>(n) : corner_ids[n]; }
  bool found() const { return status == ImageStatus::kFound; }
};

/// Detect (a chessboard: every corner, ordered; a ChArUco board: the corners seen, with identities),
/// solve and convert one grey image (CV_8UC1; throws std::invalid_argument otherwise).
/// `nominal`/`q` give the pose error; pass q empty to skip it. index/image are left for the caller.
/// A detection whose orientation is not known is never kFound (kRejected, "orientation undecidable"),
/// whatever settings.detector.require_orientation says: a half-turned pose would be silently wrong
/// (unless settings.half_turn_resolved_across_views). A circle grid's centres are measured free of the
/// ellipse-centre bias (vision/circles.hpp): the bias the first pose predicts is subtracted and the pose
/// solved again.
Measurement measureImage(const cv::Mat& gray, const sim::Scene& scene, const sim::Arm& nominal, const Eigen::VectorXd& q,
                         const MeasureSettings& settings = {});

/// Reads an image file as 8-bit grey. On failure returns an empty Mat and sets `reason`
/// ("file missing" / "cannot decode") and `detail`; never throws for a bad file.
cv::Mat readGrayImage(const std::string& path, std::string* reason, std::string* detail);

/// Every sample of a dataset (images read from dataset.folder), in order; `progress(done, total)`.
/// An OpenCV error on one image becomes that image's status (kRejected, "detector error", detail
/// = the exception's text): one bad image never stops the run.
std::vector<Measurement> measureDataset(const sim::Dataset& dataset, const MeasureSettings& settings = {},
                                        const std::function<void(int, int)>& progress = {});

/// `text` as a cell of measurements.csv holds it: commas become ';' and line breaks ' ' (no quoting).
std::string measurementCell(std::string text);

std::string formatMeasurementsCsv(const std::vector<Measurement>& rows);
/// Throws sim::InputError naming the file, line and column: a number that is not one, an index or
/// num_corners that is not a non-negative integer within int range, a repeated index, a found row
/// without its pose or covariance cells.
std::vector<Measurement> parseMeasurementsCsv(const std::string& text, const std::string& source);
std::vector<Measurement> loadMeasurements(const std::string& path);

struct MeasurementSummary {
  int total = 0, found = 0, not_found = 0, rejected = 0, unreadable = 0;
  std::map<std::string, int> reasons;  ///< "<status>: <reason>" -> count, for the images not used
  double median_rms_px = 0.0;          ///< over the found ones
};
MeasurementSummary summarize(const std::vector<Measurement>& rows);
/// The summary for a report or the terminal: the counts, then one indented line per detail.
std::string formatSummary(const MeasurementSummary& s);
/// The same on one line ("; " between its parts), for a one-line message.
std::string summaryLine(const MeasurementSummary& s);

}  // namespace orbcal::vision
