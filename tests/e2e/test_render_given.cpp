// `orbcal render --configs FILE --profile FILE` on the command line: the configurations `orbcal configs`
// wrote are the ones rendered, each image goes through the profile, bad input is one line naming the file.
// `--configs` of flange poses: the camera is where the poses and the scene's flange_T_camera put it, and the
// folder's images.yaml calibrates that hand-eye back from the images (no robot model involved).
#include <catch2/catch.hpp>
#include <filesystem>
#include <random>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/flange_poses.hpp"
#include "orbcal/sim/image_views.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/workflow/measured_images.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/io.hpp"
#include "run_orbcal.hpp"

using namespace orbcal;
using Catch::Matchers::Contains;

TEST_CASE("orbcal render --configs --profile renders the given configurations through the profile", "[e2e][render]") {
  const std::string dir = test::tempDir("e2e-render-given");
  REQUIRE(test::runOrbcal(dir, "configs -n 2 --seed 4 -o c.csv").status == 0);
  std::ofstream(dir + "/p.yaml") << "format: orbcal-camera-profile-1\nbackground: {mean_dn: 99}\n";
  const test::OrbcalRun run = test::runOrbcal(dir, "render --configs c.csv --profile p.yaml -o ds");
  CAPTURE(run.out, run.err);
  REQUIRE(run.status == 0);
  const sim::Dataset ds = sim::loadDataset(dir + "/ds");
  const std::vector<Eigen::VectorXd> q = sim::parseConfigurationsCsv(sim::readTextSource(dir + "/c.csv"), "c.csv", ds.arm.numJoints());
  REQUIRE(ds.samples.size() == 2);
  for (std::size_t k = 0; k < 2; ++k) {
    CHECK((ds.samples[k].q_rad - q[k]).cwiseAbs().maxCoeff() == 0.0);  // exact: the CSV holds them bit for bit
    const cv::Mat img = cv::imread(ds.path(ds.samples[k].image), cv::IMREAD_UNCHANGED);
    CHECK(img.at<unsigned char>(0, 0) == 99);  // the profile's background (the scene's is 0)
  }
  // --count with --configs, a profile with a misspelt key, a CSV without a joint column: one line, non-zero.
  const test::OrbcalRun both = test::runOrbcal(dir, "render --configs c.csv -n 3 -o ds2");
  CHECK(both.status != 0);
  CHECK_THAT(both.err, Contains("--count"));
  std::ofstream(dir + "/bad.yaml") << "format: orbcal-camera-profile-1\ntone: {gama: 2}\n";
  const test::OrbcalRun bad = test::runOrbcal(dir, "render --profile bad.yaml -n 1 -o ds3");
  CHECK(bad.status != 0);
  CHECK_THAT(bad.err, Contains("bad.yaml") && Contains("gama"));
  std::ofstream(dir + "/short.csv") << "index,q1_rad\n0,0.1\n";
  const test::OrbcalRun short_csv = test::runOrbcal(dir, "render --configs short.csv -o ds4");
  CHECK(short_csv.status != 0);
  CHECK_THAT(short_csv.err, Contains("short.csv") && Contains("q2_rad"));
  CHECK(!std::filesystem::exists(dir + "/ds3"));
  CHECK(!std::filesystem::exists(dir + "/ds4"));
}

namespace {

/// `count` flange poses of the default arm at planned configurations of the quick scene (seed `seed`), written to DIR/flange.csv.
std::vector<Eigen::Isometry3d> flangePoses(const std::string& dir, int count, std::uint64_t seed) {
  const sim::Arm arm = sim::loadArm(sim::RobotSource{sim::kDefaultRobot, "", ""});
  sim::GeneratorSettings gen;
  gen.count = count;
  gen.seed = seed;
  std::vector<Eigen::Isometry3d> poses;
  for (const Eigen::VectorXd& q : sim::generateConfigurations(arm, sim::loadScene(test::sourcePath("scenes/quick_scene.yaml")), gen)) {
    poses.push_back(sim::forwardKinematics(arm, q));
  }
  test::write(dir + "/flange.csv", sim::formatFlangePosesCsv(poses));
  return poses;
}

}  // namespace

TEST_CASE("orbcal render --configs of flange poses: the views calibrate back to the scene's hand-eye", "[e2e][render][real-images]") {
  const std::string dir = test::tempDir("e2e-render-flange");
  const std::string scene_path = test::sourcePath("scenes/quick_scene.yaml");
  const sim::Arm arm = sim::loadArm(sim::RobotSource{sim::kDefaultRobot, "", ""});
  const sim::Scene scene = sim::loadScene(scene_path);
  const std::vector<Eigen::Isometry3d> poses = flangePoses(dir, 12, 31);
  const test::OrbcalRun run = test::runOrbcal(dir, "render --scene " + scene_path + " --configs flange.csv -o ds");
  CAPTURE(run.out, run.err);
  REQUIRE(run.status == 0);

  // samples.csv: the poses bit for bit, no joints; the truth is the scene's chain from them.
  const sim::Dataset ds = sim::loadDataset(dir + "/ds");
  REQUIRE(sim::viewsByFlangePose(ds));
  REQUIRE(ds.samples.size() == poses.size());
  for (std::size_t k = 0; k < poses.size(); ++k) {
    CHECK(ds.samples[k].q_rad.size() == 0);
    CHECK((ds.samples[k].base_T_flange->matrix() - poses[k].matrix()).cwiseAbs().maxCoeff() < 1e-15);
    const Eigen::Isometry3d expected = scene.flange_T_camera.inverse() * poses[k].inverse() * scene.base_T_board;
    CHECK((ds.samples[k].camera_T_board_true->matrix() - expected.matrix()).cwiseAbs().maxCoeff() < 1e-12);
  }

  // images.yaml: the hand-eye from the images alone, within 4 of its jackknife 1-sigma of the truth.
  const sim::ImageViews views = sim::loadImageViews(ds.path(sim::kImagesDescriptionFile));
  const workflow::ImageCalibrateResult r = workflow::calibrateImageViews(views, workflow::detectImageViews(views));
  CAPTURE(r.refusals, r.heldout_rms_px, r.hand_sigma.transpose());
  CHECK(r.used == 12);
  CHECK(r.refusals.empty());
  const sim::Vector6d error = sim::poseMinus(r.hand_T_eye, scene.flange_T_camera);
  CAPTURE(error.transpose());
  for (int i = 0; i < 6; ++i) CHECK(std::abs(error[i]) < 4.0 * r.hand_sigma[i]);
  CHECK(error.head<3>().norm() < 2e-3);  // and within 2 mm: the criterion for real sets
  CHECK(r.lens_checked);
  CHECK_FALSE(r.lens_taken);  // the stated lens is the one the images were taken through

  // calibrate DIR (joint levels) refuses it, naming images.yaml; an error set that moves the arm is refused.
  const test::OrbcalRun joints = test::runOrbcal(dir, "calibrate ds -o cal");
  CHECK(joints.status != 0);
  CHECK_THAT(joints.err, Contains("flange poses") && Contains("images.yaml"));
  std::string errors = "format: orbcal-errors-1\ngeometry:\n";
  for (int j = 0; j < arm.numJoints(); ++j) errors += std::string("  - {theta_deg: ") + (j == 1 ? "0.1" : "0") + ", alpha_deg: 0, a_mm: 0, d_mm: 0}\n";
  test::write(dir + "/errors.yaml", errors);
  const test::OrbcalRun moved = test::runOrbcal(dir, "render --scene " + scene_path + " --configs flange.csv --errors errors.yaml -o ds2");
  CHECK(moved.status != 0);
  CHECK_THAT(moved.err, Contains("--errors") && Contains("flange.csv"));
  test::write(dir + "/bad.csv", "index,flange_x_m,flange_y_m,flange_z_m,flange_qw,flange_qx,flange_qy,flange_qz\n0,1,2,3,0.9,0,0,0\n");
  const test::OrbcalRun bad = test::runOrbcal(dir, "render --scene " + scene_path + " --configs bad.csv -o ds3");
  CHECK(bad.status != 0);
  CHECK_THAT(bad.err, Contains("bad.csv: line 2: flange_qw"));
  CHECK(!std::filesystem::exists(dir + "/ds2"));
  CHECK(!std::filesystem::exists(dir + "/ds3"));
}

TEST_CASE("images whose camera file misses the lens's distortion: the lens check finds it and the hand-eye holds",
          "[e2e][render][real-images]") {
  const std::string dir = test::tempDir("e2e-render-lens");
  const std::string scene_path = test::sourcePath("scenes/quick_scene.yaml");
  const sim::Scene scene = sim::loadScene(scene_path);
  flangePoses(dir, 16, 37);
  // A barrel distortion the camera file does not state (as in tests/e2e/test_distortion.cpp: k1 -0.05..-0.10, k2 0..0.04).
  std::mt19937_64 rng(41);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double dk1 = -(0.05 + 0.05 * u(rng)), dk2 = 0.04 * u(rng);
  test::write(dir + "/lens.yaml", "format: orbcal-errors-1\ngeometry: zero\neffects:\n  - {spec: distortion, parameters: {dk1: " +
                                      sim::formatNumber("%.17g", dk1) + ", dk2: " + sim::formatNumber("%.17g", dk2) + ", dp1: 0, dp2: 0}}\n");
  const test::OrbcalRun run = test::runOrbcal(dir, "render --scene " + scene_path + " --configs flange.csv --errors lens.yaml -o ds");
  CAPTURE(run.out, run.err);
  REQUIRE(run.status == 0);
  const sim::ImageViews views = sim::loadImageViews(dir + "/ds/" + sim::kImagesDescriptionFile);
  const workflow::ImageCalibrateResult r = workflow::calibrateImageViews(views, workflow::detectImageViews(views));
  const sim::Vector6d error = sim::poseMinus(r.hand_T_eye, scene.flange_T_camera);
  CAPTURE(dk1, dk2, r.lens_k.transpose(), r.lens_sigma.transpose(), r.lens_stated_heldout_rms_px, r.heldout_rms_px, r.refusals,
          error.transpose(), r.hand_sigma.transpose());
  REQUIRE(r.lens_checked);
  CHECK(r.lens_taken);
  CHECK(std::abs(r.lens_k[0] - dk1) < 4.0 * r.lens_sigma[0]);
  CHECK(std::abs(r.lens_k[1] - dk2) < 4.0 * r.lens_sigma[1]);
  CHECK(r.heldout_rms_px < 0.5 * r.lens_stated_heldout_rms_px);
  CHECK(r.refusals.empty());
  for (int i = 0; i < 6; ++i) CHECK(std::abs(error[i]) < 4.0 * r.hand_sigma[i]);
}
