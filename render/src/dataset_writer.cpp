#include "orbcal/render/dataset_writer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <exception>
#include <filesystem>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <thread>

#include "orbcal/render/camera_profile.hpp"
#include "orbcal/render/distortion.hpp"
#include "orbcal/render/renderer.hpp"
#include "orbcal/render/settings.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/flange_poses.hpp"
#include "orbcal/sim/image_files.hpp"
#include "orbcal/sim/camera_io.hpp"
#include "orbcal/sim/truth.hpp"
#include "dataset_copies.hpp"

namespace orbcal::render {

using namespace dataset_copies;  // the inputs copied into the dataset folder

namespace {

constexpr int kQueueDepth = 2;     // images waiting for the writers: bounds memory, keeps both cores busy
// Writer threads. Finishing (bicubic undistortion, ~2-5 ms here) plus PNG encoding (~2-4 ms) can take
// longer than drawing a frame; two writers keep the drawing thread from waiting for one.
constexpr int kWriterThreads = 2;

/// Makes the images (the renderer's finish(): distortion, degradations), encodes and writes the PNGs on
/// kWriterThreads threads of its own while the caller draws the next frames. push() blocks while the queue is full and
/// rethrows the writer's first error; finish() drains the queue and rethrows. The destructor drains and joins.
class AsyncPngWriter {
 public:
  explicit AsyncPngWriter(int compression) : compression_(compression) {
    for (int i = 0; i < kWriterThreads; ++i) threads_.emplace_back([this] { run(); });
  }
  ~AsyncPngWriter() {
    try {
      finish();
    } catch (...) {  // already reported by whoever stopped the run
    }
  }
  AsyncPngWriter(const AsyncPngWriter&) = delete;
  AsyncPngWriter& operator=(const AsyncPngWriter&) = delete;

  void push(std::string path, std::function<cv::Mat()> image) {
    std::unique_lock<std::mutex> lock(mutex_);
    space_.wait(lock, [&] { return queue_.size() < kQueueDepth || error_; });
    if (error_) std::rethrow_exception(error_);
    queue_.emplace_back(std::move(path), std::move(image));
    work_.notify_one();
  }
  void finish() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      done_ = true;
      work_.notify_all();
    }
    for (std::thread& t : threads_) {
      if (t.joinable()) t.join();
    }
    if (error_) std::rethrow_exception(error_);
  }

 private:
  void run() {
    for (;;) {
      std::pair<std::string, std::function<cv::Mat()>> job;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        work_.wait(lock, [&] { return !queue_.empty() || done_; });
        if (queue_.empty() || error_) return;
        job = std::move(queue_.front());
        queue_.pop_front();
      }
      try {
        std::vector<unsigned char> png;
        // Without IMWRITE_PNG_COMPRESSION OpenCV takes its fast path (zlib level 1, the SUB filter on every
        // row, RLE strategy); naming any level makes libpng try every filter on every row (3x slower here).
        const std::vector<int> params =
            compression_ < 0 ? std::vector<int>{} : std::vector<int>{cv::IMWRITE_PNG_COMPRESSION, compression_};
        if (!sim::encodeImage(".png", job.second(), png, params)) {
          throw sim::InputError(job.first + ": cannot encode the PNG");
        }
        sim::writeFileAtomic(job.first, std::string(png.begin(), png.end()), false);  // synced once, before samples.csv
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!error_) error_ = std::current_exception();  // the first error is the one reported
      }
      space_.notify_one();
    }
  }

  int compression_;
  std::mutex mutex_;
  std::condition_variable work_, space_;
  std::deque<std::pair<std::string, std::function<cv::Mat()>>> queue_;
  bool done_ = false;
  std::exception_ptr error_;
  std::vector<std::thread> threads_;
};

std::string imageName(int index) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "images/%06d.png", index);
  return buf;
}

bool fileEquals(const std::string& path, const std::string& text) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return false;
  try {
    return sim::readTextSource(path) == text;
  } catch (const sim::InputError&) {
    return false;
  }
}

/// An image from an earlier run that can be kept: it decodes as 8-bit grey (CV_8UC1, what the renderer
/// writes), with the camera's size.
bool usableImage(const std::string& path, const sim::Camera& camera) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return false;
  const cv::Mat img = sim::readImage(path, cv::IMREAD_UNCHANGED);
  return !img.empty() && img.type() == CV_8UC1 && img.cols == camera.width_px && img.rows == camera.height_px;
}

/// Removes `path` (a file; absent is fine) for --force; throws InputError naming it when it stays.
void removeForForce(const std::string& path, bool folder) {
  std::error_code ec;
  if (folder) {
    std::filesystem::remove_all(path, ec);
  } else {
    std::filesystem::remove(path, ec);
  }
  if (ec) throw sim::InputError(path + ": cannot remove it to replace the dataset (--force): " + ec.message());
}

/// Deletes the temporary files sim::writeFileAtomic leaves in images/ when a run is killed mid-write
/// (NAME.tmp.PID). Returns how many.
int removeTemporaryImages(const std::string& images_dir) {
  int removed = 0;
  std::error_code ec;
  if (!std::filesystem::is_directory(images_dir, ec)) return 0;
  for (std::filesystem::directory_iterator it(images_dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    std::error_code ec_file;
    if (name.find(".tmp.") == std::string::npos || !it->is_regular_file(ec_file)) continue;
    if (!std::filesystem::remove(it->path(), ec_file) || ec_file) {
      throw sim::InputError(it->path().string() + ": cannot remove this leftover temporary file: " + ec_file.message());
    }
    ++removed;
  }
  if (ec) throw sim::InputError(images_dir + ": cannot list the folder: " + ec.message());
  return removed;
}

/// When destroyed by an exception before `dataset` holds a finished image (.png), removes `created`, the
/// outermost folder the run created for it (when not empty): a render that fails before its first
/// image leaves no folder behind.
struct RemoveNewFolderOnFailure {
  std::string dataset, created;
  const int exceptions = std::uncaught_exceptions();
  ~RemoveNewFolderOnFailure() {
    if (created.empty() || std::uncaught_exceptions() <= exceptions) return;
    std::error_code ec;
    for (std::filesystem::directory_iterator it(dataset + "/images", ec), end; !ec && it != end; it.increment(ec)) {
      if (it->path().extension() == ".png") return;
    }
    std::filesystem::remove_all(created, ec);
  }
};

/// What a run reads, all of it checked before anything is written.
struct RunInputs {
  sim::Arm nominal;
  sim::Scene scene;
  RenderSettings settings;
  sim::TrueArm truth;
  sim::Camera plant_camera;  ///< what the images are taken through: the scene's camera with the error set's distortion
  std::string scene_text;    ///< the scene file as read
  CameraProfile profile;     ///< job.profile's (identity without one)
  std::vector<Eigen::VectorXd> given;  ///< job.configs' configurations (empty: planned)
  std::vector<Eigen::Isometry3d> given_flange;  ///< job.configs' flange poses (base_T_flange), when it gives poses
  int count = 0;             ///< samples of the whole dataset
  std::string profile_text, configs_text;  ///< job.profile's and job.configs' files as read (empty: none)
};

/// The files the dataset folder holds besides its images, manifest.yaml and samples.csv, as written.
struct InputCopies {
  std::string robot_text;       ///< robot.yaml
  std::string urdf_text;        ///< robot.urdf of a URDF robot; empty for a robot YAML
  std::string scene_copy;       ///< scene.yaml, paths rewritten to the copies
  std::vector<MeshCopy> files;  ///< the meshes and the camera file
};

/// The plant of views given as flange poses: no joint or link acts (the flange is where the pose says),
/// so a named error set (table3, random) is not injected, and an error-set file may only change the
/// camera (its `distortion`); one with DH errors or chain effects is refused, naming --errors.
sim::TrueArm flangePoseTruth(const sim::Arm& nominal, const sim::TrueArm& truth, const DatasetJob& job) {
  if (!truth.fromFile()) {
    sim::ErrorSetSpec zero = job.errors;
    zero.name = "zero";
    return sim::makeTrueArm(nominal, zero, "--errors");
  }
  if (!truth.model.effects.empty() || truth.geometryErrors().cwiseAbs().maxCoeff() > 0.0) {
    throw sim::InputError("--errors: " + job.errors.name + " changes the arm (DH errors or effects), but " + job.configs +
                          " gives flange poses, where no joint or link acts: give joint configurations, or an error set "
                          "with the camera's distortion only");
  }
  return truth;
}

/// Reads and checks the robot, the scene and its render settings, and the error set; the robot's text
/// as the dataset keeps it goes to copies.robot_text and copies.urdf_text.
RunInputs readRunInputs(const DatasetJob& job, InputCopies& copies) {
  RunInputs in;
  copies.robot_text = sim::readTextSource(job.robot);
  in.scene_text = sim::readTextSource(job.scene);
  in.nominal = sim::loadArm(sim::RobotSource{job.robot, job.base_link, job.tip_link});
  // A URDF robot: the dataset keeps the URDF (robot.urdf) and, as robot.yaml, the chain read from it
  // (convention urdf, naming robot.urdf and the links), which every reader of datasets loads as it is.
  const sim::Arm& nominal = in.nominal;
  if (nominal.convention == sim::DhConvention::kUrdf && !nominal.urdf.empty()) {
    copies.urdf_text = sim::readTextSource(nominal.urdf.file);
    sim::Arm copy = nominal;
    copy.urdf.file = sim::kDatasetUrdfFile;
    copies.robot_text = sim::formatArm(copy, "The chain " + nominal.urdf.base_link + " -> " + nominal.urdf.tip_link + " of " +
                                                 job.robot + " (copied as " + sim::kDatasetUrdfFile + "), read by orbcal render");
  }
  in.scene = sim::loadScene(job.scene);
  in.settings = loadRenderSettings(job.scene);
  in.truth = sim::makeTrueArm(nominal, job.errors, "--errors");
  in.plant_camera = in.truth.camera(in.scene.camera);
  if (!job.profile.empty()) {
    in.profile = loadCameraProfile(job.profile);
    checkBoardPrint(in.profile, in.scene.board);
    in.profile_text = sim::readTextSource(job.profile);
  }
  in.count = job.count;
  if (!job.configs.empty()) {
    in.configs_text = sim::readTextSource(job.configs);
    if (sim::holdsFlangePoses(in.configs_text, job.configs)) {
      in.given_flange = sim::parseFlangePosesCsv(in.configs_text, job.configs);
      in.truth = flangePoseTruth(nominal, in.truth, job);
      in.count = static_cast<int>(in.given_flange.size());
    } else {
      in.given = sim::parseConfigurationsCsv(in.configs_text, job.configs, nominal.numJoints());
      in.count = static_cast<int>(in.given.size());
    }
    if (in.count == 0) throw sim::InputError(job.configs + ": no configurations (a header and no rows)");
  }
  return in;
}

/// The manifest of samples first..end-1 (of the shard, if any) rendered from `in` as `job` asks.
sim::DatasetManifest runManifest(const DatasetJob& job, const RunInputs& in, const std::optional<sim::DatasetShard>& shard,
                                 int first, int end) {
  sim::DatasetManifest m;
  if (in.truth.fromFile()) m.error_set_file = sim::kDatasetErrorSetFile;  // before the meshes are placed
  m.program_version = ORBCAL_VERSION;
  m.num_samples = end - first;
  m.shard = shard;
  m.true_errors = in.truth.geometryErrors();
  m.true_errors_per_joint = in.nominal.paramsPerJoint();
  m.error_set = in.truth.fromFile() ? "file" : in.given_flange.empty() ? job.errors.name : "zero";
  m.joint_noise_sigma_rad = in.given_flange.empty() ? job.joint_noise_sigma_rad : 0.0;
  m.configuration_seed = job.configuration_seed;
  m.noise_seed = job.noise_seed;
  m.render_seed = job.render_seed;
  return m;
}

bool hasCopy(const InputCopies& copies, const std::string& relative) {
  for (const MeshCopy& c : copies.files) {
    if (c.relative == relative) return true;
  }
  return false;
}

/// The outermost folder that making `out` creates; empty when `out` exists.
std::filesystem::path outermostNewFolder(const std::string& out) {
  std::error_code ec;
  std::filesystem::path created;
  for (std::filesystem::path p = out; !p.empty() && !std::filesystem::exists(p, ec); p = p.parent_path()) {
    created = p;
    if (p == p.parent_path()) break;
  }
  return created;
}

/// What in the folder of `dataset` (which holds a manifest.yaml at manifest_path) is not what this run
/// would write: the manifest, a copied input, or an unreadable manifest. Empty: the run can resume.
std::vector<std::string> differingInputs(const sim::Dataset& dataset, const std::string& manifest_path,
                                         const InputCopies& copies, const sim::TrueArm& truth) {
  const sim::DatasetManifest& m = dataset.manifest;
  std::vector<std::string> differ;
  try {
    const sim::DatasetManifest old = sim::parseManifest(sim::readTextSource(manifest_path), manifest_path);
    // The manifest prints numbers exactly, so a reparsed new manifest compares equal to the old one
    // when (and only when) the inputs are the same.
    const sim::DatasetManifest fresh = sim::parseManifest(sim::formatManifest(m), manifest_path);
    if (!(old == fresh)) {
      differ = sim::manifestDifferences(old, fresh);
    }
  } catch (const sim::InputError& e) {
    differ.push_back(std::string("manifest.yaml (") + e.what() + ")");
  }
  if (!fileEquals(dataset.path(m.robot_file), copies.robot_text)) differ.push_back(m.robot_file);
  if (!copies.urdf_text.empty() && !fileEquals(dataset.path(sim::kDatasetUrdfFile), copies.urdf_text)) {
    differ.push_back(sim::kDatasetUrdfFile);
  }
  if (!fileEquals(dataset.path(m.scene_file), copies.scene_copy)) differ.push_back(m.scene_file);
  if (truth.fromFile() && !fileEquals(dataset.path(m.error_set_file), truth.file_text)) {
    differ.push_back(m.error_set_file);
  }
  for (const MeshCopy& c : copies.files) {
    if (!fileEquals(dataset.path(c.relative), c.bytes)) differ.push_back(c.relative);
  }
  for (const char* name : {kProfileFile, kConfigsFile, kImagesCameraFile, sim::kImagesDescriptionFile}) {  // an earlier run's that this one does not use
    std::error_code ec;
    if (!hasCopy(copies, name) && std::filesystem::exists(dataset.path(name), ec)) differ.push_back(name);
  }
  return differ;
}

/// Resume or refuse: true when the folder (locked by the caller) holds an unfinished dataset made from
/// the same inputs (its leftover temporary images removed); false for a folder without a manifest, or
/// with --force one made from other inputs, whose samples.csv, manifest and images are removed. Throws
/// InputError naming what differs otherwise.
bool resumeOrReplace(const DatasetJob& job, const sim::Dataset& dataset, const InputCopies& copies,
                     const sim::TrueArm& truth) {
  const sim::DatasetManifest& m = dataset.manifest;
  const std::string manifest_path = dataset.path("manifest.yaml");
  std::error_code ec;
  if (!std::filesystem::exists(manifest_path, ec)) return false;
  const std::vector<std::string> differ = differingInputs(dataset, manifest_path, copies, truth);
  if (differ.empty()) {
    removeTemporaryImages(dataset.path("images"));
    return true;
  }
  if (!job.force) {
    std::string list;
    for (const std::string& d : differ) list += (list.empty() ? "" : ", ") + d;
    throw sim::InputError(manifest_path + ": the folder holds a dataset made from different inputs (differs: " + list +
                          "); use another --out folder or --force to replace it");
  }
  removeForForce(dataset.path(m.samples_file), false);
  removeForForce(manifest_path, false);
  if (!truth.fromFile()) removeForForce(dataset.path(sim::kDatasetErrorSetFile), false);  // an earlier run's
  for (const char* name : {kProfileFile, kConfigsFile, kImagesCameraFile, sim::kImagesDescriptionFile}) {
    if (!hasCopy(copies, name)) removeForForce(dataset.path(name), false);
  }
  removeForForce(dataset.path("images"), true);
  return false;
}

/// Configurations on the nominal arm; the plant's joints and the true board pose (sample i of the
/// plant: its covariates at t_i, the approach direction from sample i - 1), appended to dataset.samples.
/// A shard takes the samples first..end-1 of that same sequence: the configurations are the first `end`
/// of job.count (the generator stops there, with job.count's attempt budget) and the joint noise is
/// drawn for every sample before `end`, in order.
void planSamples(const DatasetJob& job, const RunInputs& in, int first, int end, sim::Dataset& dataset) {
  if (!in.given_flange.empty()) {  // the flange where the pose says: no joints, no joint noise
    for (int i = first; i < end; ++i) {
      sim::DatasetSample s;
      s.index = i;
      s.image = imageName(i);
      s.base_T_flange = in.given_flange[static_cast<std::size_t>(i)];
      s.camera_T_board_true = sim::cameraTBoard(*s.base_T_flange, in.scene);
      dataset.samples.push_back(std::move(s));
    }
    return;
  }
  std::vector<Eigen::VectorXd> commanded = in.given;
  if (commanded.empty()) {
    sim::GeneratorSettings gen;
    gen.count = job.count;
    gen.stop_after = end;
    gen.seed = job.configuration_seed;
    gen.threads = job.generator_threads;
    commanded = sim::generateConfigurations(in.nominal, in.scene, gen);
  }
  std::mt19937_64 noise_rng = sim::makeRng(job.noise_seed, kJointNoiseStream);
  Eigen::VectorXd q_true_previous;
  for (int i = 0; i < end; ++i) {
    Eigen::VectorXd q_true = sim::addJointNoise(commanded[i], job.joint_noise_sigma_rad, noise_rng);
    if (i >= first) {
      sim::DatasetSample s;
      s.index = i;
      s.image = imageName(i);
      s.q_rad = commanded[i];
      s.q_true_rad = q_true;
      s.camera_T_board_true =
          sim::cameraTBoard(in.truth.flangePose(i, q_true, i > 0 ? &q_true_previous : nullptr), in.scene);
      dataset.samples.push_back(std::move(s));
    }
    q_true_previous = std::move(q_true);
  }
}

/// Writes the copied inputs and then the manifest into the dataset's folder (each file atomically).
void writeInputCopies(const sim::Dataset& dataset, const InputCopies& copies, const sim::TrueArm& truth) {
  const sim::DatasetManifest& m = dataset.manifest;
  sim::writeFileAtomic(dataset.path(m.robot_file), copies.robot_text);
  if (!copies.urdf_text.empty()) sim::writeFileAtomic(dataset.path(sim::kDatasetUrdfFile), copies.urdf_text);
  if (truth.fromFile()) sim::writeFileAtomic(dataset.path(m.error_set_file), truth.file_text);
  for (const MeshCopy& c : copies.files) {
    sim::makeDirectories(std::filesystem::path(dataset.path(c.relative)).parent_path().string());
    sim::writeFileAtomic(dataset.path(c.relative), c.bytes);
  }
  sim::writeFileAtomic(dataset.path(m.scene_file), copies.scene_copy);
  sim::writeFileAtomic(dataset.path("manifest.yaml"), sim::formatManifest(m));
}

/// Renders the images of dataset.samples that a resumed run does not keep, through the plant's camera
/// (distortion_map: its distortion map, being built), drawing on this thread and finishing and writing
/// the PNGs on the writer's; then flushes them to disk. Fills the report's image counts, MSAA, warnings
/// and render time.
void renderImages(const DatasetJob& job, const RunInputs& in, const sim::Dataset& dataset,
                  std::future<DistortionMap>& distortion_map, const DatasetProgress& progress, DatasetRunReport& report) {
  // The images are taken through the plant's camera: the scene's plus the error-set file's distortion
  // effect, which the copied scene.yaml does not have (lens distortion the calibration does not model).
  sim::Scene taken = in.scene;
  taken.camera = in.plant_camera;
  BoardRenderer renderer(taken, in.settings, in.profile, &distortion_map);
  report.msaa_samples = renderer.msaaSamples();
  report.warnings = renderer.warnings();
  const auto t0 = std::chrono::steady_clock::now();
  {
    AsyncPngWriter writer(job.png_compression);
    const int total = static_cast<int>(dataset.samples.size());
    for (int k = 0; k < total; ++k) {
      const sim::DatasetSample& s = dataset.samples[k];
      const std::string path = dataset.path(s.image);
      if (report.resumed && usableImage(path, in.scene.camera)) {
        ++report.skipped;
      } else {
        // Drawn here (the GL context's thread), finished on the writer's: renderer.render() in two halves.
        auto drawn = std::make_shared<const BoardRenderer::Drawn>(renderer.draw(*s.camera_T_board_true));
        writer.push(path, [&renderer, drawn, seed = job.render_seed, stream = kRenderStream + s.index] {
          return renderer.finish(*drawn, seed, stream);
        });
        ++report.rendered;
      }
      if (progress) progress(k + 1, total);
    }
    writer.finish();
  }
  // The images were written without an fsync each (7 ms apiece here): one flush of them all, so that
  // samples.csv, which marks the dataset finished, never reaches the disk before they do.
  sim::syncFileSystem(dataset.path("images"));
  report.render_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

DatasetRunReport renderDataset(const DatasetJob& job, const DatasetProgress& progress) {
  if (job.out.empty()) throw sim::InputError("--out: the dataset folder must be given");
  if (job.count < 1 && job.configs.empty()) throw sim::InputError("--count: must be at least 1");
  InputCopies copies;
  const RunInputs in = readRunInputs(job, copies);
  std::optional<sim::DatasetShard> shard;
  if (job.shard) shard = sim::datasetShard(job.shard->first, job.shard->second, in.count, "--shard");
  const int first = shard ? shard->first_sample : 0, end = shard ? shard->end_sample : in.count;
  // The images are taken through the plant's camera (renderImages). Its distortion map (~50 ms of CPU)
  // is built on a thread of its own while the folder is checked and the configurations are generated.
  std::future<DistortionMap> distortion_map;
  if (in.plant_camera.hasDistortion()) {
    distortion_map = std::async(std::launch::async, [plant_camera = in.plant_camera] { return makeDistortionMap(plant_camera); });
  }

  sim::Dataset dataset;
  dataset.folder = job.out;
  dataset.manifest = runManifest(job, in, shard, first, end);
  // The meshes go into the folder too, so that the dataset stands alone (see planMeshCopies).
  copies.files = planMeshCopies(in.settings, dataset.manifest);
  copies.scene_copy = placeCameraFile(in.scene, rewriteMeshPaths(in.scene_text, in.settings, copies.files), copies.files);
  if (!job.profile.empty()) copies.files.push_back(MeshCopy{kProfileFile, in.profile_text});
  if (!job.configs.empty()) copies.files.push_back(MeshCopy{kConfigsFile, in.configs_text});
  if (!in.given_flange.empty()) {  // the views as an image set with controller poses
    copies.files.push_back(MeshCopy{kImagesCameraFile, sim::formatCameraInfoYaml(in.scene.camera, "orbcal render")});
    copies.files.push_back(MeshCopy{sim::kImagesDescriptionFile,
                                    sim::flangePoseImagesDescription(in.scene, dataset.manifest.samples_file, kImagesCameraFile)});
  }

  // The folder is locked while this run writes it (a second writer is refused); a folder this run
  // creates is removed again when the run fails before its first image is written.
  const std::filesystem::path created = outermostNewFolder(job.out);
  sim::makeDirectories(job.out);
  const sim::FolderLock lock(job.out, "orbcal render");
  const RemoveNewFolderOnFailure cleanup{job.out, created.string()};  // runs before the lock is released

  DatasetRunReport report;
  report.resumed = resumeOrReplace(job, dataset, copies, in.truth);
  const auto t_plan = std::chrono::steady_clock::now();
  report.first_sample = first;
  report.end_sample = end;
  report.total_samples = in.count;
  planSamples(job, in, first, end, dataset);
  report.plan_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_plan).count();

  // Inputs copied in and the manifest, then the images, then samples.csv.
  sim::makeDirectories(job.out);
  sim::makeDirectories(dataset.path("images"));
  if (!report.resumed) writeInputCopies(dataset, copies, in.truth);
  renderImages(job, in, dataset, distortion_map, progress, report);
  sim::writeDatasetTables(dataset, in.nominal.numJoints());  // samples.csv, then manifest.yaml (unchanged)
  return report;
}

}  // namespace orbcal::render
