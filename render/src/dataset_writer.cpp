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
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <thread>
#include <yaml-cpp/yaml.h>

#include "orbcal/render/distortion.hpp"
#include "orbcal/render/renderer.hpp"
#include "orbcal/render/settings.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/truth.hpp"

namespace orbcal::render {

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
        if (!cv::imencode(".png", job.second(), png, params)) {
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
  const cv::Mat img = cv::imread(path, cv::IMREAD_UNCHANGED);
  return !img.empty() && img.type() == CV_8UC1 && img.cols == camera.width_px && img.rows == camera.height_px;
}

/// A mesh file the scene uses, as copied into the dataset folder.
struct MeshCopy {
  std::string relative;    ///< path inside the dataset folder, '/'-separated
  std::string bytes;       ///< the file's content
  bool rewritten = false;  ///< the copied scene.yaml names it by `relative` instead of as written
};

/// True when `relative` (inside the dataset folder) is the dataset's own file or folder, or under it.
bool reservedInDataset(const std::filesystem::path& relative, const sim::DatasetManifest& m) {
  const std::string first = relative.begin()->string();
  return first == m.robot_file || first == sim::kDatasetUrdfFile || first == m.scene_file || first == m.samples_file ||
         first == "manifest.yaml" ||
         first == "images" || (!m.error_set_file.empty() && first == m.error_set_file);
}

/// Where each mesh goes in the dataset folder, so that the copied scene.yaml (at DIR/scene.yaml; relative
/// mesh paths resolve against its folder) finds it: a relative path without ".." keeps its place,
/// DIR/<path>; an absolute one, one with "..", or one that would land on the dataset's own files goes to
/// DIR/meshes/<file name> (made unique) and is rewritten in the copied scene. Reads every mesh.
std::vector<MeshCopy> planMeshCopies(const RenderSettings& settings, const sim::DatasetManifest& m) {
  std::vector<MeshCopy> copies(settings.meshes.size());
  std::map<std::string, std::string> taken;  // relative path in the dataset -> the bytes it holds
  // Kept paths first, so that relocated meshes never take a kept one's place.
  for (std::size_t i = 0; i < settings.meshes.size(); ++i) {
    const MeshSpec& spec = settings.meshes[i];
    try {
      copies[i].bytes = sim::readTextSource(spec.file);
    } catch (const sim::InputError& e) {
      throw sim::InputError(settings.source + ": " + spec.key + ": cannot read mesh '" + spec.file + "' to copy it into "
                            "the dataset: " + e.what());
    }
    // ".." is checked as written: DIR/a/../x.obj does not resolve unless DIR/a exists.
    bool up = false;
    for (const auto& part : std::filesystem::path(spec.file_as_written)) up |= part == "..";
    const std::filesystem::path written = std::filesystem::path(spec.file_as_written).lexically_normal();
    if (written.is_absolute() || up || written.empty() || reservedInDataset(written, m)) {
      copies[i].rewritten = true;
      continue;
    }
    copies[i].relative = written.generic_string();
    taken.emplace(copies[i].relative, copies[i].bytes);  // the same path always resolves to the same file
  }
  for (std::size_t i = 0; i < settings.meshes.size(); ++i) {
    MeshCopy& c = copies[i];
    if (!c.rewritten) continue;
    const std::filesystem::path name = std::filesystem::path(settings.meshes[i].file).filename();
    std::string relative = "meshes/" + name.string();
    for (int n = 2;; ++n) {
      const auto it = taken.find(relative);
      if (it == taken.end() || it->second == c.bytes) break;  // free, or the same content already there
      relative = "meshes/" + name.stem().string() + "-" + std::to_string(n) + name.extension().string();
    }
    c.relative = relative;
    taken.emplace(relative, c.bytes);
  }
  return copies;
}

/// Text of the YAML string `s`, double-quoted.
std::string yamlQuoted(const std::string& s) {
  std::string q = "\"";
  for (char ch : s) {
    if (ch == '"' || ch == '\\') q += '\\';
    q += ch;
  }
  return q + "\"";
}

/// Where the one-line scalar `node` of `text` (parsed from it) ends: past its closing quote, or past its
/// value when plain; npos when it is not written on one line.
std::size_t scalarEnd(const std::string& text, const YAML::Node& node) {
  const std::size_t begin = static_cast<std::size_t>(node.Mark().pos);
  const std::string value = node.Scalar();
  const char open = begin < text.size() ? text[begin] : '\0';
  if (open == '"' || open == '\'') {
    for (std::size_t k = begin + 1; k < text.size() && text[k] != '\n'; ++k) {
      if (open == '"' && text[k] == '\\') {
        ++k;
      } else if (text[k] == open) {
        if (open == '\'' && k + 1 < text.size() && text[k + 1] == '\'') {
          ++k;  // '' is a quote inside a single-quoted string
        } else {
          return k + 1;
        }
      }
    }
    return std::string::npos;
  }
  return text.compare(begin, value.size(), value) == 0 ? begin + value.size() : std::string::npos;
}

/// The scene text with the `file:` value of each rewritten mesh replaced by its place in the dataset,
/// everything else (comments, layout) unchanged, and a comment at the top saying what was rewritten.
std::string rewriteMeshPaths(const std::string& scene_text, const RenderSettings& settings,
                             const std::vector<MeshCopy>& copies) {
  struct Edit {
    std::size_t begin, end;
    std::string text;
  };
  std::vector<Edit> edits;
  std::string note;
  const YAML::Node root = YAML::Load(scene_text);  // parsed before (loadRenderSettings): no syntax errors here
  for (std::size_t i = 0; i < copies.size(); ++i) {
    if (!copies[i].rewritten) continue;
    const MeshSpec& spec = settings.meshes[i];
    const YAML::Node node = root["meshes"][i]["file"];
    const std::size_t begin = static_cast<std::size_t>(node.Mark().pos);
    const std::string value = node.Scalar();
    const std::size_t end = scalarEnd(scene_text, node);
    if (end == std::string::npos) {
      throw sim::InputError(settings.source + ": " + spec.key + ": cannot rewrite this mesh path in the dataset's copy "
                            "of the scene (write it on one line, plain or quoted)");
    }
    edits.push_back({begin, end, yamlQuoted(copies[i].relative)});
    note += "#   " + spec.key + ": " + value + "\n";
  }
  if (edits.empty()) return scene_text;
  std::sort(edits.begin(), edits.end(), [](const Edit& a, const Edit& b) { return a.begin > b.begin; });
  std::string text = scene_text;
  for (const Edit& e : edits) text.replace(e.begin, e.end - e.begin, e.text);
  // Check the rewrite: the copied scene must name each relocated mesh by its place in the dataset.
  const RenderSettings check = parseRenderSettings(sim::ConfigNode::parse(text, settings.source), "");
  for (std::size_t i = 0; i < copies.size(); ++i) {
    if (check.meshes.size() != copies.size() || (copies[i].rewritten && check.meshes[i].file_as_written != copies[i].relative)) {
      throw sim::InputError(settings.source + ": " + settings.meshes[i].key +
                            ": cannot rewrite this mesh path in the dataset's copy of the scene");
    }
  }
  return "# orbcal render: copied into this dataset with these mesh paths rewritten to the copies in meshes/;\n"
         "# they were:\n" + note + text;
}

/// A scene whose camera is {file: PATH} (sim::Scene::camera_file): the camera file goes into the dataset
/// as camera.EXT (camera-2.EXT, ... if a mesh copy holds that name), appended to `files`, and the copied
/// scene's camera.file names it (whether PATH was relative, absolute or had ".."), so the dataset
/// stands alone. Returns the scene text to copy.
std::string placeCameraFile(const sim::Scene& scene, const std::string& scene_copy, std::vector<MeshCopy>& files) {
  if (scene.camera_file.empty()) return scene_copy;
  MeshCopy c;
  c.bytes = sim::readTextSource(scene.camera_file);  // read before by sim::loadScene
  c.rewritten = true;
  const std::filesystem::path original(scene.camera_file);
  const std::string ext = original.has_extension() ? original.extension().string() : ".yaml";
  c.relative = "camera" + ext;
  for (int n = 2;; ++n) {
    const auto same = [&](const MeshCopy& f) { return f.relative == c.relative; };
    const auto it = std::find_if(files.begin(), files.end(), same);
    if (it == files.end() || it->bytes == c.bytes) break;
    c.relative = "camera-" + std::to_string(n) + ext;
  }
  const YAML::Node node = YAML::Load(scene_copy)["camera"]["file"];
  const std::size_t begin = static_cast<std::size_t>(node.Mark().pos);
  const std::size_t end = scalarEnd(scene_copy, node);
  if (end == std::string::npos) {
    throw sim::InputError(scene.source + ": camera.file: cannot rewrite this path in the dataset's copy of the scene "
                          "(write it on one line, plain or quoted)");
  }
  std::string text = scene_copy;
  text.replace(begin, end - begin, yamlQuoted(c.relative));
  if (YAML::Load(text)["camera"]["file"].Scalar() != c.relative) {
    throw sim::InputError(scene.source + ": camera.file: cannot rewrite this path in the dataset's copy of the scene");
  }
  files.push_back(c);
  return "# orbcal render: camera.file rewritten to the copy " + c.relative + " in this dataset; it was: " +
         node.Scalar() + "\n" + text;
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

}  // namespace

DatasetRunReport renderDataset(const DatasetJob& job, const DatasetProgress& progress) {
  if (job.out.empty()) throw sim::InputError("--out: the dataset folder must be given");
  if (job.count < 1) throw sim::InputError("--count: must be at least 1");
  std::optional<sim::DatasetShard> shard;
  if (job.shard) shard = sim::datasetShard(job.shard->first, job.shard->second, job.count, "--shard");
  const int first = shard ? shard->first_sample : 0, end = shard ? shard->end_sample : job.count;
  // Inputs: everything is read and checked before anything is written.
  std::string robot_text = sim::readTextSource(job.robot);
  const std::string scene_text = sim::readTextSource(job.scene);
  const sim::Arm nominal = sim::loadArm(sim::RobotSource{job.robot, job.base_link, job.tip_link});
  // A URDF robot: the dataset keeps the URDF (robot.urdf) and, as robot.yaml, the chain read from it
  // (convention urdf, naming robot.urdf and the links), which every reader of datasets loads as it is.
  std::string urdf_text;
  if (nominal.convention == sim::DhConvention::kUrdf && !nominal.urdf.empty()) {
    urdf_text = sim::readTextSource(nominal.urdf.file);
    sim::Arm copy = nominal;
    copy.urdf.file = sim::kDatasetUrdfFile;
    robot_text = sim::formatArm(copy, "The chain " + nominal.urdf.base_link + " -> " + nominal.urdf.tip_link + " of " +
                                          job.robot + " (copied as " + sim::kDatasetUrdfFile + "), read by orbcal render");
  }
  const sim::Scene scene = sim::loadScene(job.scene);
  const RenderSettings settings = loadRenderSettings(job.scene);
  const sim::TrueArm truth = sim::makeTrueArm(nominal, job.errors, "--errors");
  // The images are taken through the plant's camera (see below). Its distortion map (~50 ms of CPU) is
  // built on a thread of its own while the folder is checked and the configurations are generated.
  const sim::Camera plant_camera = truth.camera(scene.camera);
  std::future<DistortionMap> distortion_map;
  if (plant_camera.hasDistortion()) {
    distortion_map = std::async(std::launch::async, [plant_camera] { return makeDistortionMap(plant_camera); });
  }

  sim::Dataset dataset;
  dataset.folder = job.out;
  sim::DatasetManifest& m = dataset.manifest;
  if (truth.fromFile()) m.error_set_file = sim::kDatasetErrorSetFile;  // before the meshes are placed
  // The meshes go into the folder too, so that the dataset stands alone (see planMeshCopies).
  std::vector<MeshCopy> meshes = planMeshCopies(settings, m);
  const std::string scene_copy = placeCameraFile(scene, rewriteMeshPaths(scene_text, settings, meshes), meshes);
  m.program_version = ORBCAL_VERSION;
  m.num_samples = end - first;
  m.shard = shard;
  m.true_errors = truth.geometryErrors();
  m.true_errors_per_joint = nominal.paramsPerJoint();
  m.error_set = truth.fromFile() ? "file" : job.errors.name;
  m.joint_noise_sigma_rad = job.joint_noise_sigma_rad;
  m.configuration_seed = job.configuration_seed;
  m.noise_seed = job.noise_seed;
  m.render_seed = job.render_seed;

  // The folder is locked while this run writes it (a second writer is refused); a folder this run
  // creates is removed again when the run fails before its first image is written.
  std::error_code ec;
  std::filesystem::path created;  // the outermost folder this run creates (empty: none)
  for (std::filesystem::path p = job.out; !p.empty() && !std::filesystem::exists(p, ec); p = p.parent_path()) {
    created = p;
    if (p == p.parent_path()) break;
  }
  sim::makeDirectories(job.out);
  const sim::FolderLock lock(job.out, "orbcal render");
  const RemoveNewFolderOnFailure cleanup{job.out, created.string()};  // runs before the lock is released

  // Resume or refuse.
  const std::string manifest_path = job.out + "/manifest.yaml";
  DatasetRunReport report;
  if (std::filesystem::exists(manifest_path, ec)) {
    std::vector<std::string> differ;  // what is not the same, for the message
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
    if (!fileEquals(dataset.path(m.robot_file), robot_text)) differ.push_back(m.robot_file);
    if (!urdf_text.empty() && !fileEquals(dataset.path(sim::kDatasetUrdfFile), urdf_text)) differ.push_back(sim::kDatasetUrdfFile);
    if (!fileEquals(dataset.path(m.scene_file), scene_copy)) differ.push_back(m.scene_file);
    if (truth.fromFile() && !fileEquals(dataset.path(m.error_set_file), truth.file_text)) {
      differ.push_back(m.error_set_file);
    }
    for (const MeshCopy& c : meshes) {
      if (!fileEquals(dataset.path(c.relative), c.bytes)) differ.push_back(c.relative);
    }
    if (differ.empty()) {
      report.resumed = true;
      removeTemporaryImages(dataset.path("images"));
    } else if (!job.force) {
      std::string list;
      for (const std::string& d : differ) list += (list.empty() ? "" : ", ") + d;
      throw sim::InputError(manifest_path + ": the folder holds a dataset made from different inputs (differs: " + list +
                            "); use another --out folder or --force to replace it");
    } else {
      removeForForce(dataset.path(m.samples_file), false);
      removeForForce(manifest_path, false);
      if (!truth.fromFile()) removeForForce(dataset.path(sim::kDatasetErrorSetFile), false);  // an earlier run's
      removeForForce(dataset.path("images"), true);
    }
  }

  // Configurations on the nominal arm; the plant's joints and the true board pose (sample i of the
  // plant: its covariates at t_i, the approach direction from sample i - 1). A shard takes the samples
  // first..end-1 of that same sequence: the configurations are the first `end` of job.count (the
  // generator stops there, with job.count's attempt budget) and the joint noise is drawn for every
  // sample before `end`, in order.
  const auto t_plan = std::chrono::steady_clock::now();
  report.first_sample = first;
  report.end_sample = end;
  sim::GeneratorSettings gen;
  gen.count = job.count;
  gen.stop_after = end;
  gen.seed = job.configuration_seed;
  gen.threads = job.generator_threads;
  const std::vector<Eigen::VectorXd> commanded = sim::generateConfigurations(nominal, scene, gen);
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
      s.camera_T_board_true = sim::cameraTBoard(truth.flangePose(i, q_true, i > 0 ? &q_true_previous : nullptr), scene);
      dataset.samples.push_back(std::move(s));
    }
    q_true_previous = std::move(q_true);
  }
  report.plan_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_plan).count();

  // Inputs copied in and the manifest, then the images, then samples.csv.
  sim::makeDirectories(job.out);
  sim::makeDirectories(dataset.path("images"));
  if (!report.resumed) {
    sim::writeFileAtomic(dataset.path(m.robot_file), robot_text);
    if (!urdf_text.empty()) sim::writeFileAtomic(dataset.path(sim::kDatasetUrdfFile), urdf_text);
    if (truth.fromFile()) sim::writeFileAtomic(dataset.path(m.error_set_file), truth.file_text);
    for (const MeshCopy& c : meshes) {
      sim::makeDirectories(std::filesystem::path(dataset.path(c.relative)).parent_path().string());
      sim::writeFileAtomic(dataset.path(c.relative), c.bytes);
    }
    sim::writeFileAtomic(dataset.path(m.scene_file), scene_copy);
    sim::writeFileAtomic(manifest_path, sim::formatManifest(m));
  }

  // The images are taken through the plant's camera: the scene's plus the error-set file's distortion
  // effect, which the copied scene.yaml does not have (lens distortion the calibration does not model).
  sim::Scene taken = scene;
  taken.camera = plant_camera;
  BoardRenderer renderer(taken, settings, &distortion_map);
  report.msaa_samples = renderer.msaaSamples();
  report.warnings = renderer.warnings();
  const auto t0 = std::chrono::steady_clock::now();
  {
    AsyncPngWriter writer(job.png_compression);
    const int total = static_cast<int>(dataset.samples.size());
    for (int k = 0; k < total; ++k) {
      const sim::DatasetSample& s = dataset.samples[k];
      const std::string path = dataset.path(s.image);
      if (report.resumed && usableImage(path, scene.camera)) {
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
  sim::writeDatasetTables(dataset, nominal.numJoints());  // samples.csv, then manifest.yaml (unchanged)
  return report;
}

}  // namespace orbcal::render
