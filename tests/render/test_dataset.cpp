// `orbcal render`'s dataset writer: every field reloads, reruns resume and are identical, bad inputs refused.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "orbcal/render/dataset_writer.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
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

  const render::DatasetRunReport resumed = render::renderDataset(job);
  CHECK(resumed.resumed);
  CHECK(resumed.skipped == 1);
  CHECK(resumed.rendered == kCount - 1);

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
  CHECK(readBytes(job.out + "/images/000000.png") == image0);  // nothing lost
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
