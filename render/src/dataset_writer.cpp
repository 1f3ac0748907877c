#include "orbcal/render/dataset_writer.hpp"

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <exception>
#include <filesystem>
#include <mutex>
#include <opencv2/imgcodecs.hpp>
#include <thread>

#include "orbcal/render/renderer.hpp"
#include "orbcal/render/settings.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/fileio.hpp"

namespace orbcal::render {

namespace {

constexpr int kQueueDepth = 2;  // images waiting for the writer: bounds memory, keeps both cores busy

/// Encodes and writes PNGs on its own thread. push() blocks while the queue is full and rethrows the
/// writer's first error; finish() drains the queue and rethrows. The destructor drains and joins.
class AsyncPngWriter {
 public:
  explicit AsyncPngWriter(int compression) : compression_(compression), thread_([this] { run(); }) {}
  ~AsyncPngWriter() {
    try {
      finish();
    } catch (...) {  // already reported by whoever stopped the run
    }
  }
  AsyncPngWriter(const AsyncPngWriter&) = delete;
  AsyncPngWriter& operator=(const AsyncPngWriter&) = delete;

  void push(std::string path, cv::Mat image) {
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
      work_.notify_one();
    }
    if (thread_.joinable()) thread_.join();
    if (error_) std::rethrow_exception(error_);
  }

 private:
  void run() {
    for (;;) {
      std::pair<std::string, cv::Mat> job;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        work_.wait(lock, [&] { return !queue_.empty() || done_; });
        if (queue_.empty() || error_) return;
        job = std::move(queue_.front());
        queue_.pop_front();
      }
      try {
        std::vector<unsigned char> png;
        if (!cv::imencode(".png", job.second, png, {cv::IMWRITE_PNG_COMPRESSION, compression_})) {
          throw sim::InputError(job.first + ": cannot encode the PNG");
        }
        sim::writeFileAtomic(job.first, std::string(png.begin(), png.end()));
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex_);
        error_ = std::current_exception();
      }
      space_.notify_one();
    }
  }

  int compression_;
  std::mutex mutex_;
  std::condition_variable work_, space_;
  std::deque<std::pair<std::string, cv::Mat>> queue_;
  bool done_ = false;
  std::exception_ptr error_;
  std::thread thread_;
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

/// An image from an earlier run that can be kept: it decodes, with the camera's size.
bool usableImage(const std::string& path, const sim::Camera& camera) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return false;
  const cv::Mat img = cv::imread(path, cv::IMREAD_UNCHANGED);
  return !img.empty() && img.cols == camera.width_px && img.rows == camera.height_px;
}

}  // namespace

DatasetRunReport renderDataset(const DatasetJob& job, const DatasetProgress& progress) {
  if (job.out.empty()) throw sim::InputError("--out: the dataset folder must be given");
  if (job.count < 1) throw sim::InputError("--count: must be at least 1");
  // Inputs: everything is read and checked before anything is written.
  const std::string robot_text = sim::readTextSource(job.robot);
  const std::string scene_text = sim::readTextSource(job.scene);
  const sim::Arm nominal = sim::loadArm(job.robot);
  const sim::Scene scene = sim::loadScene(job.scene);
  const RenderSettings settings = loadRenderSettings(job.scene);
  const Eigen::VectorXd y_true = sim::makeErrorSet(nominal, job.errors, "--errors");
  const sim::Arm true_arm = sim::withErrors(nominal, y_true);

  sim::Dataset dataset;
  dataset.folder = job.out;
  sim::DatasetManifest& m = dataset.manifest;
  m.program_version = ORBCAL_VERSION;
  m.num_samples = job.count;
  m.true_errors = y_true;
  m.error_set = job.errors.name;
  m.joint_noise_sigma_rad = job.joint_noise_sigma_rad;
  m.configuration_seed = job.configuration_seed;
  m.noise_seed = job.noise_seed;
  m.render_seed = job.render_seed;

  // Resume or refuse.
  const std::string manifest_path = job.out + "/manifest.yaml";
  DatasetRunReport report;
  std::error_code ec;
  if (std::filesystem::exists(manifest_path, ec)) {
    bool same = false;
    try {
      const sim::DatasetManifest old = sim::parseManifest(sim::readTextSource(manifest_path), manifest_path);
      // The manifest prints numbers exactly, so a reparsed new manifest compares equal to the old one
      // when (and only when) the inputs are the same.
      const sim::DatasetManifest fresh = sim::parseManifest(sim::formatManifest(m), manifest_path);
      same = old == fresh && fileEquals(dataset.path(m.robot_file), robot_text) &&
             fileEquals(dataset.path(m.scene_file), scene_text);
    } catch (const sim::InputError&) {
      same = false;
    }
    if (same) {
      report.resumed = true;
    } else if (!job.force) {
      throw sim::InputError(manifest_path + ": the folder holds a dataset made from different inputs (robot, scene, "
                            "errors, count, seeds or joint noise); use another --out folder or --force to replace it");
    } else {
      for (const std::string& f : {m.samples_file, std::string("manifest.yaml")}) std::filesystem::remove(dataset.path(f), ec);
      std::filesystem::remove_all(dataset.path("images"), ec);
      if (ec) throw sim::InputError(dataset.path("images") + ": cannot remove the old images: " + ec.message());
    }
  }

  // Configurations on the nominal arm; the plant's joints and the true board pose.
  sim::GeneratorSettings gen;
  gen.count = job.count;
  gen.seed = job.configuration_seed;
  gen.threads = job.generator_threads;
  const std::vector<Eigen::VectorXd> commanded = sim::generateConfigurations(nominal, scene, gen);
  std::mt19937_64 noise_rng = sim::makeRng(job.noise_seed, kJointNoiseStream);
  for (int i = 0; i < job.count; ++i) {
    sim::DatasetSample s;
    s.index = i;
    s.image = imageName(i);
    s.q_rad = commanded[i];
    s.q_true_rad = sim::addJointNoise(commanded[i], job.joint_noise_sigma_rad, noise_rng);
    s.camera_T_board_true = sim::cameraTBoard(true_arm, scene, *s.q_true_rad);
    dataset.samples.push_back(std::move(s));
  }

  // Inputs copied in and the manifest, then the images, then samples.csv.
  sim::makeDirectories(job.out);
  sim::makeDirectories(dataset.path("images"));
  if (!report.resumed) {
    sim::writeFileAtomic(dataset.path(m.robot_file), robot_text);
    sim::writeFileAtomic(dataset.path(m.scene_file), scene_text);
    sim::writeFileAtomic(manifest_path, sim::formatManifest(m));
  }

  BoardRenderer renderer(scene, settings);
  report.msaa_samples = renderer.msaaSamples();
  report.warnings = renderer.warnings();
  const auto t0 = std::chrono::steady_clock::now();
  {
    AsyncPngWriter writer(job.png_compression);
    for (int i = 0; i < job.count; ++i) {
      const sim::DatasetSample& s = dataset.samples[i];
      const std::string path = dataset.path(s.image);
      if (report.resumed && usableImage(path, scene.camera)) {
        ++report.skipped;
      } else {
        writer.push(path, renderer.render(*s.camera_T_board_true, job.render_seed, kRenderStream + i));
        ++report.rendered;
      }
      if (progress) progress(i + 1, job.count);
    }
    writer.finish();
  }
  report.render_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  sim::writeDatasetTables(dataset, nominal.numJoints());  // samples.csv, then manifest.yaml (unchanged)
  return report;
}

}  // namespace orbcal::render
