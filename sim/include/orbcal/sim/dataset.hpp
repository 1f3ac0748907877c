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
//
// A shard (`orbcal render --shard i/N`) is a dataset folder of its own holding the samples
// [floor(i C / N), floor((i + 1) C / N)) of a dataset of C samples, with their global indices and image
// names; its manifest has `shard: {index: i, count: N, first_sample: a, end_sample: b, dataset_samples: C}`
// and num_samples = b - a (its own rows). mergeDatasetShards puts finished shards back together.
#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <optional>
#include <utility>
#include <string>
#include <vector>

#include "orbcal/sim/arm.hpp"
#include "orbcal/sim/scene.hpp"

namespace orbcal::sim {

inline constexpr const char* kDatasetFormat = "orbcal-dataset-1";
/// A URDF robot's URDF in a dataset folder (robot.yaml names it; render/dataset_writer.hpp).
inline constexpr const char* kDatasetUrdfFile = "robot.urdf";

/// Shard `index` of `count` of a dataset of `dataset_samples` samples: the samples
/// [first_sample, end_sample) = [floor(index dataset_samples / count), floor((index + 1) dataset_samples / count)).
struct DatasetShard {
  int index = 0;
  int count = 1;
  int first_sample = 0;
  int end_sample = 0;
  int dataset_samples = 0;
  int size() const { return end_sample - first_sample; }
  bool operator==(const DatasetShard& o) const;
  bool operator!=(const DatasetShard& o) const { return !(*this == o); }
};

/// Shard `index` of `count` (0 <= index < count) of a dataset of `dataset_samples` samples. Throws
/// InputError naming `what` (e.g. "--shard") for an index or count out of range.
DatasetShard datasetShard(int index, int count, int dataset_samples, const std::string& what);
/// "i/N" (as `--shard` takes it) -> {i, N} with 0 <= i < N; InputError naming `what` otherwise.
std::pair<int, int> parseShardSpec(const std::string& text, const std::string& what);

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
  std::optional<DatasetShard> shard;           ///< a shard of a larger dataset (num_samples: its own rows)
  bool operator==(const DatasetManifest& o) const;
};

/// The manifest fields (as named in manifest.yaml, e.g. "seeds.configurations", "shard") in which `a` and
/// `b` differ, compared as operator== does; empty when a == b.
std::vector<std::string> manifestDifferences(const DatasetManifest& a, const DatasetManifest& b);

struct DatasetSample {
  int index = 0;
  std::string image;                                   ///< relative to the dataset folder
  Eigen::VectorXd q_rad;                               ///< joint readings (commanded or encoder); empty with base_T_flange
  /// The view given as the flange's pose instead of joint readings (`render --configs` of flange poses,
  /// sim/flange_poses.hpp): samples.csv's kFlangePoseColumns, no joint columns.
  std::optional<Eigen::Isometry3d> base_T_flange;
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
/// The samples' table; samples given by flange poses (all or none) have kFlangePoseColumns instead of
/// the num_joints joint columns.
std::string formatSamplesCsv(const std::vector<DatasetSample>& samples, int num_joints);
/// Throws InputError naming the file, line and column for an index that is not a whole number from 0, an
/// index or an image given twice, empty joint readings, and (with `limits`) a reading outside the arm's
/// joint limits.
std::vector<DatasetSample> parseSamplesCsv(const std::string& text, const std::string& source, int num_joints,
                                           const Arm* limits = nullptr);
/// True when the dataset's views are given by flange poses (no joint readings).
bool viewsByFlangePose(const Dataset& d);
/// Throws InputError naming d's samples.csv when its views are given by flange poses: joint-level
/// calibration, diagnosis and the study need joint readings (`what`: e.g. "calibrate"); the image
/// description kImagesDescriptionFile beside it calibrates the hand-eye and board frames.
void requireJointReadings(const Dataset& d, const std::string& what);
/// The image description (orbcal-measurements-1) a dataset of flange poses holds beside samples.csv.
inline constexpr const char* kImagesDescriptionFile = "images.yaml";

/// Reads manifest, robot, scene and samples (not the images). Throws InputError naming the file, line and
/// column; the joint readings are checked against the robot's limits and num_samples against the rows.
Dataset loadDataset(const std::string& folder);
/// Writes manifest.yaml and samples.csv atomically (robot.yaml and scene.yaml are the caller's).
void writeDatasetTables(const Dataset& dataset, int num_joints);

struct MergeReport {
  int shards = 0;
  int samples = 0;
  int linked = 0;   ///< images hard-linked (shard and output on one file system)
  int copied = 0;   ///< images copied (hard links refused, e.g. across file systems)
};

/// Merges the finished shards of one dataset (`orbcal render --shard`) into the dataset folder `out`,
/// which is what rendering the dataset in one go writes: one manifest.yaml without the shard key
/// (num_samples: all of them), the shards' input files (robot.yaml, scene.yaml, errors.yaml, robot.urdf,
/// meshes, camera file: every file of a shard but its manifest, samples file and images), its images
/// (hard links when the file systems allow, else copies; orbcal never rewrites an image in place, so a
/// shard re-rendered later leaves the linked ones alone) and one samples.csv in index order.
/// A dataset without the shard key counts as shard 0 of 1 (one unsharded render merges into a copy of
/// itself). Each shard is locked (sim::FolderLock) while it is read. Checked first, each a one-line
/// InputError naming the shard folder: a folder that is not a dataset, an unfinished shard (no samples file), rows
/// that are not the shard's samples, an image missing, a manifest (shard key apart) or an input file that
/// differs from the first shard's (names the field or file), and the shards together covering every
/// sample exactly once (names the missing samples or the overlapping shards). `out` must not exist: it
/// is built in `out`.tmp-PID beside it, flushed to disk and renamed into place, so it never holds half a
/// dataset (a killed merge may leave that temporary folder). `progress` is called per image with
/// (done, total).
MergeReport mergeDatasetShards(const std::vector<std::string>& shard_dirs, const std::string& out,
                               const std::function<void(int, int)>& progress = {});

}  // namespace orbcal::sim
