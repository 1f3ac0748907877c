#pragma once
// A calibration dataset on disk: the contract between `orbcal render` (which writes rendered ones),
// `orbcal measure` and the calibrators (which read them), and users who bring their own images.
//
//   <folder>/manifest.yaml   format, program version, robot and scene file names, seeds, the true
//                            injected errors (simulation only), joint noise
//   <folder>/robot.yaml      the arm (copied in, so the dataset stands alone)
//   <folder>/robot.urdf      for a URDF robot only: the URDF; robot.yaml is then the chain read from it
//   <folder>/scene.yaml      the scene
//   <folder>/errors.yaml     simulation only, when the plant came from an error-set file (sim/truth.hpp):
//                            that file, copied in; the manifest names it as true_errors.file
//   <folder>/samples.csv     one row per sample, header line first:
//       index, image, q1_rad..qN_rad              joint readings the model is driven with (commanded or encoder)
//       [, q1_true_rad..qN_true_rad]              true plant joints after control noise (simulation only)
//       [, cam_board_x_m, _y_m, _z_m, _rx_rad, _ry_rad, _rz_rad]   ground-truth camera_T_board:
//                                                 translation and rotation vector (simulation only)
//   <folder>/images/...      the images named in the image column (paths relative to the folder)
// Optional columns may be absent from the header or left empty on a row.
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "orbcal/sim/arm.hpp"
#include "orbcal/sim/scene.hpp"

namespace orbcal::sim {

inline constexpr const char* kDatasetFormat = "orbcal-dataset-1";
/// A URDF robot's URDF in a dataset folder (robot.yaml names it; render/dataset_writer.hpp).
inline constexpr const char* kDatasetUrdfFile = "robot.urdf";

struct DatasetManifest {
  std::string format = kDatasetFormat;
  std::string program_version;
  std::string robot_file = "robot.yaml";
  std::string scene_file = "scene.yaml";
  std::string samples_file = "samples.csv";
  int num_samples = 0;
  std::optional<Eigen::VectorXd> true_errors;  ///< SI, y order (arm.hpp); simulation only
  /// Entries of true_errors per joint: the arm's paramsPerJoint(), 5 (rows with beta_deg) for Hayati.
  int true_errors_per_joint = 4;
  std::string error_set;                       ///< e.g. "table3"; "file" for an error-set file
  /// The error-set file copied into the dataset (sim::kDatasetErrorSetFile), whose effects the plant had
  /// on top of true_errors; empty for a named set (and in manifests older than the key).
  std::string error_set_file;
  double joint_noise_sigma_rad = 0.0;
  std::uint64_t configuration_seed = 0;
  std::uint64_t noise_seed = 0;
  std::uint64_t render_seed = 0;
  bool operator==(const DatasetManifest& o) const;
};

struct DatasetSample {
  int index = 0;
  std::string image;                                   ///< relative to the dataset folder
  Eigen::VectorXd q_rad;                               ///< joint readings (commanded or encoder)
  std::optional<Eigen::VectorXd> q_true_rad;           ///< simulation only
  std::optional<Eigen::Isometry3d> camera_T_board_true;  ///< simulation only
};

struct Dataset {
  std::string folder;
  DatasetManifest manifest;
  Arm arm;      ///< from manifest.robot_file
  Scene scene;  ///< from manifest.scene_file
  std::vector<DatasetSample> samples;
  std::string path(const std::string& relative) const { return folder + "/" + relative; }
};

std::string formatManifest(const DatasetManifest& m);
DatasetManifest parseManifest(const std::string& text, const std::string& source);
std::string formatSamplesCsv(const std::vector<DatasetSample>& samples, int num_joints);
/// Throws InputError naming the file, line and column for an index that is not a whole number from 0, an
/// index or an image given twice, empty joint readings, and (with `limits`) a reading outside the arm's
/// joint limits.
std::vector<DatasetSample> parseSamplesCsv(const std::string& text, const std::string& source, int num_joints,
                                           const Arm* limits = nullptr);

/// Reads manifest, robot, scene and samples (not the images). Throws InputError naming the file, line and
/// column; the joint readings are checked against the robot's limits and num_samples against the rows.
Dataset loadDataset(const std::string& folder);
/// Writes manifest.yaml and samples.csv atomically (robot.yaml and scene.yaml are the caller's).
void writeDatasetTables(const Dataset& dataset, int num_joints);

}  // namespace orbcal::sim
