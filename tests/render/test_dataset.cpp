// `orbcal render`'s dataset writer: every field reloads, reruns resume and are identical, bad inputs refused.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "orbcal/render/dataset_writer.hpp"
#include "orbcal/render/renderer.hpp"
#include "orbcal/render/settings.hpp"
#include "orbcal/sim/camera_io.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "render_test_util.hpp"
#include "test_util.hpp"

using namespace orbcal;
using Catch::Matchers::Contains;

namespace {
constexpr int kCount = 5;
constexpr int kInterruptAfter = 2;
constexpr double kExactTol = 1e-12;  // the CSV prints numbers exactly (round trip)

struct Interrupted {};

std::string readBytes(const std::string& path) { return sim::readTextSource(path); }

/// The default scene with noise on, written to dir/scene.yaml: the per-image noise must be seeded.
std::string noisyScene(const std::string& dir) {
  std::string text = sim::readTextSource(sim::kDefaultScene);
  text.replace(text.find("  read_noise_dn: 0.0"), std::string("  read_noise_dn: 0.0").size(), "  read_noise_dn: 1.5");
  const std::string path = dir + "/scene.yaml";
  std::ofstream(path) << text;
  return path;
}

render::DatasetJob smallJob(const std::string& scene, const std::string& out) {
  render::DatasetJob job;
  job.scene = scene;
  job.count = kCount;
  job.configuration_seed = 11, job.noise_seed = 12, job.render_seed = 13;
  job.joint_noise_sigma_rad = 0.02 * sim::kDegToRad;
  job.out = out;
  return job;
}
}  // namespace

TEST_CASE("a rendered dataset reloads with every field, and an interrupted run resumes", "[render][dataset]") {
  const std::string dir = test::tempDir("render-dataset");
  const std::string scene = noisyScene(dir);
  const render::DatasetJob job = smallJob(scene, dir + "/ds");

  // Interrupted after two images: those stay, samples.csv is not written yet.
  REQUIRE_THROWS_AS(render::renderDataset(job, [](int done, int) {
                      if (done == kInterruptAfter) throw Interrupted{};
                    }),
                    Interrupted);
  REQUIRE(std::filesystem::exists(job.out + "/manifest.yaml"));
  REQUIRE(!std::filesystem::exists(job.out + "/samples.csv"));
  REQUIRE(std::filesystem::exists(job.out + "/images/000001.png"));
  REQUIRE(!std::filesystem::exists(job.out + "/images/000002.png"));
  // A half-written image from a crash is rendered again.
  std::ofstream(job.out + "/images/000001.png") << "not a png";
  // sim::writeFileAtomic's temporary file, left by a run killed mid-write, is deleted on resume.
  const std::string leftover = job.out + "/images/000002.png.tmp.99999";
  std::ofstream(leftover) << "half an image";

  const render::DatasetRunReport resumed = render::renderDataset(job);
  CHECK(resumed.resumed);
  CHECK(resumed.skipped == 1);
  CHECK(resumed.rendered == kCount - 1);
  CHECK(!std::filesystem::exists(leftover));

  // Reload: every field.
  const sim::Dataset d = sim::loadDataset(job.out);
  CHECK(d.manifest.num_samples == kCount);
  CHECK(d.manifest.program_version == ORBCAL_VERSION);
  CHECK(d.manifest.error_set == "table3");
  CHECK(d.manifest.configuration_seed == 11);
  CHECK(d.manifest.noise_seed == 12);
  CHECK(d.manifest.render_seed == 13);
  CHECK(d.manifest.joint_noise_sigma_rad == Approx(job.joint_noise_sigma_rad).epsilon(1e-12));
  const sim::Arm nominal = sim::loadArm(sim::kDefaultRobot);
  const Eigen::VectorXd y = sim::makeErrorSet(nominal, job.errors, "test");
  REQUIRE(d.manifest.true_errors);
  CHECK((*d.manifest.true_errors - y).cwiseAbs().maxCoeff() < kExactTol);
  CHECK(readBytes(job.out + "/robot.yaml") == sim::readTextSource(sim::kDefaultRobot));
  CHECK(readBytes(job.out + "/scene.yaml") == sim::readTextSource(scene));
  CHECK(d.scene.camera.width_px == 1280);

  // The samples, recomputed independently.
  sim::GeneratorSettings gen;
  gen.count = kCount;
  gen.seed = job.configuration_seed;
  const auto commanded = sim::generateConfigurations(nominal, d.scene, gen);
  std::mt19937_64 noise = sim::makeRng(job.noise_seed, render::kJointNoiseStream);
  const sim::Arm true_arm = sim::withErrors(nominal, y);
  REQUIRE(d.samples.size() == static_cast<std::size_t>(kCount));
  for (int i = 0; i < kCount; ++i) {
    const sim::DatasetSample& s = d.samples[i];
    CAPTURE(i);
    CHECK(s.index == i);
    const Eigen::VectorXd q_true = sim::addJointNoise(commanded[i], job.joint_noise_sigma_rad, noise);
    CHECK((s.q_rad - commanded[i]).cwiseAbs().maxCoeff() < kExactTol);
    REQUIRE(s.q_true_rad);
    CHECK((*s.q_true_rad - q_true).cwiseAbs().maxCoeff() < kExactTol);
    CHECK((*s.q_true_rad - s.q_rad).cwiseAbs().maxCoeff() > 0.0);  // the noise is there
    REQUIRE(s.camera_T_board_true);
    const Eigen::Isometry3d T = sim::cameraTBoard(true_arm, d.scene, q_true);
    CHECK((s.camera_T_board_true->matrix() - T.matrix()).cwiseAbs().maxCoeff() < 1e-9);
    const cv::Mat img = cv::imread(d.path(s.image), cv::IMREAD_UNCHANGED);
    REQUIRE(!img.empty());
    CHECK(img.type() == CV_8UC1);
    CHECK(img.cols == 1280);
    CHECK(img.rows == 1024);
  }

  // An uninterrupted run gives the same bytes: images and tables (noise included) are seeded.
  render::DatasetJob fresh = job;
  fresh.out = dir + "/fresh";
  render::renderDataset(fresh);
  for (const std::string f : {"manifest.yaml", "samples.csv", "images/000000.png", "images/000001.png", "images/000004.png"}) {
    CAPTURE(f);
    CHECK(readBytes(job.out + "/" + f) == readBytes(fresh.out + "/" + f));
  }

  // A finished dataset rerun: nothing rendered.
  const render::DatasetRunReport again = render::renderDataset(job);
  CHECK(again.rendered == 0);
  CHECK(again.skipped == kCount);

  // An image of the right size that is not 8-bit grey (here BGR) is not kept: rendered again, same bytes.
  cv::imwrite(job.out + "/images/000004.png", cv::Mat(1024, 1280, CV_8UC3, cv::Scalar(1, 2, 3)));
  const render::DatasetRunReport colour = render::renderDataset(job);
  CHECK(colour.rendered == 1);
  CHECK(colour.skipped == kCount - 1);
  CHECK(readBytes(job.out + "/images/000004.png") == readBytes(fresh.out + "/images/000004.png"));
}

TEST_CASE("the dataset writer refuses other inputs in the same folder unless forced", "[render][dataset]") {
  const std::string dir = test::tempDir("render-dataset-refuse");
  render::DatasetJob job = smallJob(sim::kDefaultScene, dir + "/ds");
  job.count = 2;
  render::renderDataset(job);
  const std::string image0 = readBytes(job.out + "/images/000000.png");
  render::DatasetJob other = job;
  other.configuration_seed = 99;
  REQUIRE_THROWS_WITH(render::renderDataset(other), Contains(job.out + "/manifest.yaml") && Contains("--force"));
  // The message names the manifest field that differs (and only that one).
  REQUIRE_THROWS_WITH(render::renderDataset(other), Contains("seeds.configurations") && !Contains("seeds.render") &&
                                                        !Contains("program_version"));
  CHECK(readBytes(job.out + "/images/000000.png") == image0);  // nothing lost
  {
    // Another program version made the folder: refused, naming program_version.
    const std::string manifest = readBytes(job.out + "/manifest.yaml");
    std::string older = manifest;
    const std::string key = "program_version: ";
    const auto at = older.find(key);
    REQUIRE(at != std::string::npos);
    older.replace(at + key.size(), older.find('\n', at) - at - key.size(), "0.0.0-older");
    std::ofstream(job.out + "/manifest.yaml") << older;
    REQUIRE_THROWS_WITH(render::renderDataset(job), Contains(job.out + "/manifest.yaml") && Contains("program_version") &&
                                                      !Contains("seeds.configurations"));
    std::ofstream(job.out + "/manifest.yaml") << manifest;
  }
  other.force = true;
  const render::DatasetRunReport r = render::renderDataset(other);
  CHECK(r.rendered == 2);
  CHECK(sim::loadDataset(job.out).manifest.configuration_seed == 99);
}

TEST_CASE("the dataset writer reports an unwritable folder by name", "[render][dataset]") {
  const std::string dir = test::tempDir("render-dataset-unwritable");
  std::ofstream(dir + "/file") << "x";
  render::DatasetJob job = smallJob(sim::kDefaultScene, dir + "/file/ds");  // a folder inside a regular file
  job.count = 1;
  REQUIRE_THROWS_AS(render::renderDataset(job), sim::InputError);
  REQUIRE_THROWS_WITH(render::renderDataset(job), Contains(dir + "/file/ds"));
  render::DatasetJob bad_scene = smallJob(dir + "/no_such_scene.yaml", dir + "/ds2");
  REQUIRE_THROWS_WITH(render::renderDataset(bad_scene), Contains(dir + "/no_such_scene.yaml"));
  CHECK(!std::filesystem::exists(dir + "/ds2"));  // nothing written on bad input
}

TEST_CASE("a dataset with meshes stands alone: meshes copied in, compared on resume, the folder re-renders elsewhere",
          "[render][dataset][mesh]") {
  const std::string dir = test::tempDir("render-dataset-meshes");
  // The scene: one mesh by a relative path (kept at that path in the dataset) and one by an absolute
  // path whose file name clashes with the first but whose bytes differ (copied to meshes/, renamed,
  // and rewritten in the copied scene.yaml).
  const std::string scene_dir = dir + "/scene", other_dir = dir + "/other";
  std::filesystem::create_directories(scene_dir + "/meshes");
  std::filesystem::create_directories(other_dir);
  const std::string plate = readBytes(test::sourcePath("scenes/meshes/occluder_plate.obj"));
  std::ofstream(scene_dir + "/meshes/occluder_plate.obj", std::ios::binary) << plate;
  std::ofstream(other_dir + "/occluder_plate.obj", std::ios::binary) << plate << "# another copy\n";
  const std::string scene = scene_dir + "/scene.yaml";
  std::ofstream(scene) << test::defaultSceneWithMeshes(
      "meshes:\n"
      "  - file: meshes/occluder_plate.obj\n"
      "    pose: {xyz_m: [0.32, 0.2, -0.3], rpy_deg: [0, 0, 0]}\n"
      "  - {file: \"" + other_dir + "/occluder_plate.obj\", pose: {xyz_m: [0.1, 0.3, -0.25], rpy_deg: [0, 0, 30]}}\n");

  render::DatasetJob job = smallJob(scene, dir + "/ds");
  job.count = 2;
  render::renderDataset(job);
  CHECK(readBytes(job.out + "/meshes/occluder_plate.obj") == plate);
  CHECK(readBytes(job.out + "/meshes/occluder_plate-2.obj") == plate + "# another copy\n");
  {
    const render::RenderSettings copied = render::loadRenderSettings(job.out + "/scene.yaml");
    REQUIRE(copied.meshes.size() == 2);
    CHECK(copied.meshes[0].file_as_written == "meshes/occluder_plate.obj");    // as written
    CHECK(copied.meshes[1].file_as_written == "meshes/occluder_plate-2.obj");  // rewritten
  }

  // The mesh edited: refused, naming the mesh; the dataset is untouched.
  std::ofstream(scene_dir + "/meshes/occluder_plate.obj", std::ios::app) << "# edited\n";
  REQUIRE_THROWS_WITH(render::renderDataset(job), Contains(job.out + "/manifest.yaml") &&
                                                      Contains("meshes/occluder_plate.obj") && Contains("--force"));
  CHECK(readBytes(job.out + "/meshes/occluder_plate.obj") == plate);

  // The folder alone, moved elsewhere with the original scene and meshes gone: it reloads, its scene
  // finds its meshes, re-rendering gives the stored images, and rerunning on it resumes with nothing to do.
  const std::string moved = dir + "/moved";
  std::filesystem::copy(job.out, moved, std::filesystem::copy_options::recursive);
  std::filesystem::remove_all(scene_dir);
  std::filesystem::remove_all(other_dir);
  std::filesystem::remove_all(job.out);
  const sim::Dataset d = sim::loadDataset(moved);
  const render::RenderSettings settings = render::loadRenderSettings(d.path(d.manifest.scene_file));
  REQUIRE(settings.meshes.size() == 2);
  CHECK(settings.meshes[0].file == moved + "/meshes/occluder_plate.obj");
  CHECK(settings.meshes[1].file == moved + "/meshes/occluder_plate-2.obj");
  render::RenderSettings no_meshes = settings;
  no_meshes.meshes.clear();
  render::BoardRenderer renderer(d.scene, settings), bare(d.scene, no_meshes);
  int differs_without_meshes = 0;
  for (const sim::DatasetSample& s : d.samples) {
    CAPTURE(s.index);
    const cv::Mat stored = cv::imread(d.path(s.image), cv::IMREAD_UNCHANGED);
    const cv::Mat again = renderer.render(*s.camera_T_board_true, job.render_seed, render::kRenderStream + s.index);
    REQUIRE(stored.size() == again.size());
    CHECK(cv::countNonZero(stored != again) == 0);
    const cv::Mat without = bare.render(*s.camera_T_board_true, job.render_seed, render::kRenderStream + s.index);
    differs_without_meshes += cv::countNonZero(stored != without) > 0 ? 1 : 0;
  }
  CHECK(differs_without_meshes > 0);  // the meshes are in the images, so the check above used them
  render::DatasetJob rerun = job;
  rerun.robot = moved + "/robot.yaml";
  rerun.scene = moved + "/scene.yaml";
  rerun.out = moved;
  const render::DatasetRunReport r = render::renderDataset(rerun);
  CHECK(r.resumed);
  CHECK(r.rendered == 0);
  CHECK(r.skipped == 2);
}

TEST_CASE("a dataset whose scene takes its camera from a camera_info file stands alone", "[render][dataset][camera_io]") {
  const std::string dir = test::tempDir("render-dataset-camera-file");
  const sim::Scene inline_scene = sim::loadScene(sim::kDefaultScene);
  // The camera file outside the scene's folder, by an absolute path: copied in as camera.yaml and the
  // copied scene rewritten to name it.
  std::filesystem::create_directories(dir + "/cams");
  std::filesystem::create_directories(dir + "/scene");
  const std::string camera_text = sim::formatCameraInfoYaml(inline_scene.camera, "cam");
  std::ofstream(dir + "/cams/cam.yaml") << camera_text;
  std::string text = sim::readTextSource(sim::kDefaultScene);
  const auto a = text.find("\ncamera:\n"), b = text.find("\nboard:\n");
  REQUIRE(a != std::string::npos);
  REQUIRE(b != std::string::npos);
  text.replace(a + 1, b - a, "camera: {file: '" + dir + "/cams/cam.yaml'}\n");
  const std::string scene = dir + "/scene/scene.yaml";
  std::ofstream(scene) << text;

  render::DatasetJob job = smallJob(scene, dir + "/ds");
  job.count = 2;
  render::renderDataset(job);
  CHECK(readBytes(job.out + "/camera.yaml") == camera_text);
  // Moved with the camera file gone: the dataset's scene finds its copy, the same camera as inline.
  const std::string moved = dir + "/moved";
  std::filesystem::copy(job.out, moved, std::filesystem::copy_options::recursive);
  std::filesystem::remove_all(dir + "/cams");
  const sim::Dataset d = sim::loadDataset(moved);
  CHECK(d.scene.camera_file == moved + "/camera.yaml");
  CHECK(d.scene.camera.fx_px == inline_scene.camera.fx_px);
  CHECK(d.scene.camera.cx_px == inline_scene.camera.cx_px);
  CHECK(d.scene.camera.cy_px == inline_scene.camera.cy_px);
  CHECK(d.scene.camera.width_px == inline_scene.camera.width_px);
  // The images are those of the inline camera.
  render::BoardRenderer renderer(inline_scene, render::loadRenderSettings(sim::kDefaultScene));
  for (const sim::DatasetSample& s : d.samples) {
    const cv::Mat stored = cv::imread(d.path(s.image), cv::IMREAD_UNCHANGED);
    const cv::Mat again = renderer.render(*s.camera_T_board_true, job.render_seed, render::kRenderStream + s.index);
    REQUIRE(stored.size() == again.size());
    CHECK(cv::countNonZero(stored != again) == 0);
  }
}
