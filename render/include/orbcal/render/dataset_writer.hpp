#pragma once
// `orbcal render`: a rendered calibration dataset (layout: sim/dataset.hpp and docs/file-formats.md).
//
//  1. configurations: sim::generateConfigurations on the NOMINAL arm (the planner knows only the
//     nominal model), seed = configuration seed; or the given ones (job.configs: joints or flange poses),
//     in their order;
//  2. true joints = commanded + N(0, joint noise) (sim::addJointNoise, stream kJointNoiseStream);
//  3. ground truth camera_T_board = sim::cameraTBoard(the TRUE arm's flange pose at q_true): sim::TrueArm,
//     nominal + injected DH errors, plus the effects of an error-set file (sample i at t_i, approach
//     direction from sample i - 1; sim/truth.hpp);
//  4. that pose rendered (BoardRenderer::render, degradations and the camera profile's image part
//     drawn from makeRng(render seed, kRenderStream + index); with job.profile the board drawn as
//     printed), written as images/NNNNNN.png.
// A profile is copied into the folder as camera_profile.yaml, given configurations as configurations.csv
// (both compared on resume like the other inputs: a folder holding one that this run does not use differs).
// Shard i of N (job.shard, `--shard i/N`): everything above is computed for the whole dataset of
// job.count samples, as without a shard, and only the samples [floor(i count / N), floor((i + 1) count / N))
// are rendered and written, with their global indices, image names and render streams; the folder is a
// dataset of its own (samples.csv: its rows; the manifest's `shard` key and num_samples = its rows, see
// sim/dataset.hpp) that sim::mergeDatasetShards joins with the others. The configurations are planned up to
// the shard's last sample only (sim::GeneratorSettings::stop_after: the same ones).
// Order on disk: robot.yaml, errors.yaml (a verbatim copy of an error-set file, when --errors names one), the
// scene's mesh files, scene.yaml and manifest.yaml first; the images
// (each frame drawn on the calling thread, then undistorted, degraded, PNG-encoded and written on two
// worker threads while the next frames are drawn; each atomically, flushed to disk together by one
// syncfs before samples.csv);
// samples.csv last, so a dataset without samples.csv is an unfinished run.
// The folder stands alone: robot.yaml is a verbatim copy of the robot file and every mesh the scene
// uses is copied in. A mesh given by a relative path without ".." goes to DIR/<that path> (where the
// copied scene, whose relative paths resolve against DIR, finds it). One given by an absolute path or
// a path with ".." (or one that would land on the dataset's own files) goes to DIR/meshes/<file name>
// (with -2, -3, ... before the extension when two different files share a name), and scene.yaml is then
// NOT verbatim: that `file:` value is rewritten to the copy's path and a comment at the top of the copy
// lists the original paths. Otherwise scene.yaml is a verbatim copy. Only the mesh files themselves are
// copied (not side files such as an .obj's .mtl: the renderer uses only the geometry). A scene whose
// camera is a file (`camera: {file: ...}`, sim/camera_io.hpp) has it copied to DIR/camera.EXT and its
// `file:` value rewritten the same way, compared on resume like the meshes.
// A URDF robot (sim/urdf.hpp): robot.urdf is a verbatim copy of the URDF and robot.yaml the chain read
// from it (sim::formatArm, convention urdf, naming robot.urdf and the links), so that a dataset's
// readers load robot.yaml as for any robot and `orbcal calibrate` finds the URDF to write back.
// Resume: rerunning with the same inputs (manifest, robot.yaml, errors.yaml, scene.yaml and mesh
// bytes) into the same folder deletes the temporary files a killed run left in images/ (NAME.tmp.PID),
// keeps every image that exists and decodes as 8-bit grey of the camera's size, and renders the rest.
// Different inputs (a different shard too): refused (InputError naming manifest.yaml and the manifest
// fields or files that differ) unless `force`, which deletes the old images, samples.csv and manifest.yaml first, and
// errors.yaml when the new plant has no error-set file (InputError naming any file it cannot remove).
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::render {

inline constexpr std::uint64_t kJointNoiseStream = 0x6a6f696e74ULL;        // "joint"
inline constexpr std::uint64_t kRenderStream = 0x72656e6465720000ULL;      // "render" << 16, + sample index

struct DatasetJob {
  std::string robot = sim::kDefaultRobot;  ///< file or builtin:NAME (a robot YAML or a URDF)
  std::string base_link, tip_link;         ///< a URDF robot's chain (empty: root and only leaf link)
  std::string scene = sim::kDefaultScene;
  sim::ErrorSetSpec errors;                ///< injected into the true arm: table3 | zero | random | an error-set file
  int count = 50;
  std::uint64_t configuration_seed = 1;
  std::uint64_t noise_seed = 1;
  std::uint64_t render_seed = 1;
  double joint_noise_sigma_rad = 0.01 * sim::kDegToRad;
  std::string out;                         ///< dataset folder (created)
  /// {i, N}: render only shard i of N of the `count` samples (sim::datasetShard; InputError naming --shard
  /// unless 0 <= i < N <= count).
  std::optional<std::pair<int, int>> shard;
  bool force = false;
  int generator_threads = 0;               ///< 0: all hardware threads
  /// -1: OpenCV's fast PNG path (zlib level 1, SUB filter); 0..9: cv::IMWRITE_PNG_COMPRESSION, which also
  /// makes libpng search the filters per row (slower). Lossless either way.
  int png_compression = -1;
  /// camera_profile.yaml (render/camera_profile.hpp) applied to every image; empty: none.
  std::string profile;
  /// A configurations CSV (sim::parseConfigurationsCsv: index, q1_rad..qN_rad, or qJ_deg / qJ_m columns)
  /// rendered in its order instead of planned ones; `count` is then its number of rows. Empty: planned.
  /// Or flange poses (sim::parseFlangePosesCsv: flange_x_m .. flange_qz, the controller's base_T_flange):
  /// the camera is placed by them with no joint or link acting (no joint noise, a named error set not
  /// injected; an error-set file may change the camera only), samples.csv holds the poses instead of
  /// joints, and the folder also holds images.yaml (sim::flangePoseImagesDescription) and its camera
  /// file images_camera.yaml: `orbcal calibrate DIR/images.yaml` estimates the hand-eye from them.
  std::string configs;
};

struct DatasetRunReport {
  int rendered = 0;          ///< images rendered and written by this run
  int skipped = 0;           ///< images already there (resumed)
  int first_sample = 0;      ///< the samples [first_sample, end_sample) were written (a shard's; else all)
  int end_sample = 0;
  int total_samples = 0;     ///< of the whole dataset: job.count, or the given configurations' rows
  double plan_seconds = 0;   ///< wall time of planning: configurations, joint noise, true poses
  bool resumed = false;      ///< the folder held this dataset's manifest
  int msaa_samples = 0;
  std::vector<std::string> warnings;  ///< from the renderer (e.g. MSAA fallback)
  double render_seconds = 0; ///< wall time of the render + write loop
};

/// Progress: (images done including skipped, total). May throw to stop the run (images written so
/// far stay intact; the queued ones are written first).
using DatasetProgress = std::function<void(int done, int total)>;

/// Writes the dataset. Throws sim::InputError naming the file (bad input, unwritable folder, full
/// disk) with every earlier image intact.
DatasetRunReport renderDataset(const DatasetJob& job, const DatasetProgress& progress = {});

}  // namespace orbcal::render
