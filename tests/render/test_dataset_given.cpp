// `orbcal render --configs` and `--profile` in the dataset writer: given configurations rendered in their
// order, a camera profile applied to every image, both copied into the folder and compared on resume.
// A 320 x 256 camera (the default scene's field of view) keeps the renders fast.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "orbcal/render/camera_profile.hpp"
#include "orbcal/render/dataset_writer.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "test_util.hpp"

using namespace orbcal;
using Catch::Matchers::Contains;

namespace {

void replaceOnce(std::string& text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  if (at == std::string::npos) throw std::runtime_error("the default scene has no '" + from + "' any more");
  text.replace(at, from.size(), to);
}

/// The default scene with a camera of a quarter the size (same field of view), written to dir/scene.yaml.
std::string smallScene(const std::string& dir) {
  std::string text = sim::readTextSource(sim::kDefaultScene);
  replaceOnce(text, "width_px: 1280", "width_px: 320");
  replaceOnce(text, "height_px: 1024", "height_px: 256");
  replaceOnce(text, "fx_px: 1400.0", "fx_px: 350.0");
  replaceOnce(text, "fy_px: 1400.0", "fy_px: 350.0");
  replaceOnce(text, "cx_px: 643.3", "cx_px: 160.7");
  replaceOnce(text, "cy_px: 508.9", "cy_px: 127.3");
  replaceOnce(text, "image_margin_px: 20", "image_margin_px: 5");
  const std::string path = dir + "/scene.yaml";
  std::ofstream(path) << text;
  return path;
}

/// Three configurations the planner finds for the scene (seed 5), written as a CSV in degrees.
std::vector<Eigen::VectorXd> writeConfigsDeg(const std::string& scene, const std::string& path) {
  const sim::Arm arm = sim::loadArm(sim::RobotSource{sim::kDefaultRobot, "", ""});
  sim::GeneratorSettings gen;
  gen.count = 3;
  gen.seed = 5;
  const std::vector<Eigen::VectorXd> q = sim::generateConfigurations(arm, sim::loadScene(scene), gen);
  std::ofstream out(path);
  out.precision(17);
  out << "index";
  for (int j = 1; j <= arm.numJoints(); ++j) out << ",q" << j << "_deg";
  out << "\n";
  for (std::size_t k = 0; k < q.size(); ++k) {
    out << k;
    for (int j = 0; j < q[k].size(); ++j) out << "," << q[k][j] / sim::kDegToRad;
    out << "\n";
  }
  return q;
}

render::DatasetJob job(const std::string& scene, const std::string& out) {
  render::DatasetJob j;
  j.scene = scene;
  j.count = 4;
  j.configuration_seed = j.noise_seed = j.render_seed = 3;
  j.out = out;
  return j;
}

}  // namespace

TEST_CASE("render --configs: the given configurations, in order, one sample each; a bad CSV names the file and column",
          "[render][dataset][profile]") {
  const std::string dir = test::tempDir("render-given-configs");
  const std::string scene = smallScene(dir);
  const std::vector<Eigen::VectorXd> q = writeConfigsDeg(scene, dir + "/configs.csv");
  render::DatasetJob j = job(scene, dir + "/ds");
  j.configs = dir + "/configs.csv";
  const render::DatasetRunReport r = render::renderDataset(j);
  CHECK(r.rendered == 3);  // the CSV's rows, not job.count
  CHECK(r.total_samples == 3);
  const sim::Dataset ds = sim::loadDataset(dir + "/ds");
  REQUIRE(ds.samples.size() == 3);
  for (std::size_t k = 0; k < 3; ++k) {
    CAPTURE(k);
    CHECK((ds.samples[k].q_rad - q[k]).cwiseAbs().maxCoeff() < 1e-12);  // degrees in, radians out
    CHECK(cv::imread(ds.path(ds.samples[k].image), cv::IMREAD_UNCHANGED).cols == 320);
  }
  CHECK(sim::readTextSource(dir + "/ds/configurations.csv") == sim::readTextSource(j.configs));
  // Rerun: resumed; with other configurations: refused, naming the copy that differs.
  CHECK(render::renderDataset(j).resumed);
  std::ofstream(dir + "/other.csv") << sim::readTextSource(j.configs) << "3";
  for (int k = 0; k < q[0].size(); ++k) std::ofstream(dir + "/other.csv", std::ios::app) << ",0";
  std::ofstream(dir + "/other.csv", std::ios::app) << "\n";
  render::DatasetJob other = j;
  other.configs = dir + "/other.csv";
  CHECK_THROWS_WITH(render::renderDataset(other), Contains("configurations.csv"));
  // Bad CSVs: a non-number, a missing joint column.
  std::string text = sim::readTextSource(j.configs);
  text.replace(text.find('\n') + 3, 1, "x");  // the first row's q1_deg
  std::ofstream(dir + "/bad.csv") << text;
  other.configs = dir + "/bad.csv";
  other.out = dir + "/bad";
  CHECK_THROWS_WITH(render::renderDataset(other), Contains(dir + "/bad.csv") && Contains("q1_deg"));
  std::ofstream(dir + "/short.csv") << "index,q1_deg,q2_deg\n0,1,2\n";
  other.configs = dir + "/short.csv";
  CHECK_THROWS_WITH(render::renderDataset(other), Contains(dir + "/short.csv") && Contains("q3_rad"));
  CHECK(!std::filesystem::exists(dir + "/bad"));  // a refused run leaves no folder
}

TEST_CASE("render --profile: every image through the profile, the profile kept in the folder and compared on resume",
          "[render][dataset][profile]") {
  const std::string dir = test::tempDir("render-profile");
  const std::string scene = smallScene(dir);
  render::CameraProfile p;
  p.tone = {25.0, 220.0, 1.5};
  p.background.mean_dn = 77.0;
  render::saveCameraProfile(p, dir + "/camera_profile.yaml");
  render::DatasetJob plain = job(scene, dir + "/plain");
  render::DatasetJob profiled = job(scene, dir + "/profiled");
  profiled.profile = dir + "/camera_profile.yaml";
  render::renderDataset(plain);
  render::renderDataset(profiled);
  const sim::Dataset a = sim::loadDataset(dir + "/plain"), b = sim::loadDataset(dir + "/profiled");
  REQUIRE(a.samples.size() == b.samples.size());
  for (std::size_t k = 0; k < a.samples.size(); ++k) {
    const cv::Mat clean = cv::imread(a.path(a.samples[k].image), cv::IMREAD_UNCHANGED);
    const cv::Mat out = cv::imread(b.path(b.samples[k].image), cv::IMREAD_UNCHANGED);
    REQUIRE(out.size() == clean.size());
    int toned = 0, background = 0;
    for (int r = 0; r < out.rows; ++r)
      for (int c = 0; c < out.cols; ++c) {
        const int o = out.at<unsigned char>(r, c);
        if (o == 77) ++background;
        if (std::abs(o - (25.0 + 195.0 * std::pow(clean.at<unsigned char>(r, c) / 255.0, 1.0 / 1.5))) <= 0.5 + 1e-4) ++toned;
      }
    CAPTURE(k, toned, background);
    CHECK(background > 0);
    CHECK(toned > static_cast<int>(out.total() / 20));  // the board's pixels: the tone curve of the plain render's
    CHECK(toned + background > 0.97 * out.total());  // the rest: a mix along the board's outline
  }
  CHECK(sim::readTextSource(dir + "/profiled/camera_profile.yaml") == sim::readTextSource(profiled.profile));
  // The same folder without the profile: a different dataset.
  render::DatasetJob dropped = profiled;
  dropped.profile.clear();
  CHECK_THROWS_WITH(render::renderDataset(dropped), Contains("camera_profile.yaml"));
  dropped.force = true;
  render::renderDataset(dropped);
  CHECK(!std::filesystem::exists(dir + "/profiled/camera_profile.yaml"));
}
