// A URDF robot through render -> calibrate -> calibrated URDF (sim/urdf.hpp): the iiwa7 URDF of
// tests/data, derived from scenes/iiwa7.yaml's DH table.
#include <catch2/catch.hpp>

#include "orbcal/workflow/calibrate.hpp"
#include "orbcal/workflow/experiment.hpp"
#include "orbcal/render/dataset_writer.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/io.hpp"
#include "test_util.hpp"

using namespace orbcal;
using Catch::Matchers::Contains;

TEST_CASE("a URDF robot renders, calibrates, and its calibrated URDF reloads to the calibrated arm", "[e2e][urdf]") {
  const std::string urdf = test::sourcePath("tests/data/iiwa7.urdf");
  render::DatasetJob job;
  job.robot = urdf;
  job.base_link = "world";
  job.tip_link = "iiwa_link_ee";
  job.scene = test::sourcePath("scenes/iiwa7_scene.yaml");
  job.errors.name = "random";  // 0.3 deg and 1 mm on every origin parameter and zero offset (seed 1)
  job.count = 30;
  const std::string dir = test::tempDir("urdf-e2e");
  job.out = dir + "/dataset";
  render::renderDataset(job);
  // The dataset keeps the URDF verbatim and, as robot.yaml, the chain read from it.
  CHECK(test::slurp(job.out + "/" + sim::kDatasetUrdfFile) == test::slurp(urdf));
  const sim::Dataset d = sim::loadDataset(job.out);
  REQUIRE(d.arm.convention == sim::DhConvention::kUrdf);
  CHECK(d.arm.urdf.file == job.out + "/robot.urdf");
  CHECK(d.arm.numParams() == 49);

  workflow::CalibrateOptions o;
  o.dataset = job.out;
  o.out = dir + "/calibration";
  o.quiet = true;
  const workflow::CalibrateResult r = workflow::runCalibrate(o);
  REQUIRE(r.has_truth);
  CHECK(r.usable >= 28);
  // 7 errors a joint are redundant: the identifiability analysis keeps a minimal set, and LSE/LM hold
  // the rest. Each z-axis joint's yaw is its zero offset again (same axis, same point): held.
  CHECK(r.classes.minimal.size() < 49);
  CHECK(std::find(r.classes.held.begin(), r.classes.held.end(), sim::paramIndex(d.arm, 0, sim::kOyaw)) != r.classes.held.end());
  CHECK_THAT(test::slurp(r.report_path), Contains("Held as unidentifiable (" + std::to_string(r.classes.held.size()) + "): yaw1, "));
  // Wang et al. 2023's bar (90%) on the held-out samples, against the camera and against the truth.
  CHECK(calib::improvement(r.before.position_avg_m, r.after.position_avg_m) >= 0.90);
  CHECK(calib::improvement(r.truth_before.position_avg_m, r.truth_after.position_avg_m) >= 0.90);

  // The calibrated URDF, reloaded, has the calibrated YAML arm's kinematics (and that is nominal + estimate).
  REQUIRE(!r.urdf_path.empty());
  const sim::Arm from_urdf = sim::loadArm(sim::RobotSource{r.urdf_path, "world", "iiwa_link_ee"});
  const sim::Arm from_yaml = sim::loadArm(r.robot_path);
  CHECK(from_yaml.urdf.file == o.out + "/robot_calibrated.urdf");
  const sim::Arm expected = sim::withErrors(d.arm, r.estimate.y);
  double max_urdf = 0.0, max_expected = 0.0, moved = 0.0;
  for (const Eigen::VectorXd& q : test::randomConfigs(d.arm, 100, 3)) {
    const Eigen::Isometry3d T = sim::forwardKinematics(from_yaml, q);
    max_urdf = std::max(max_urdf, (sim::forwardKinematics(from_urdf, q).matrix() - T.matrix()).norm());
    max_expected = std::max(max_expected, (sim::forwardKinematics(expected, q).matrix() - T.matrix()).norm());
    moved = std::max(moved, (sim::forwardKinematics(d.arm, q).translation() - T.translation()).norm());
  }
  CHECK(max_urdf < 1e-9);
  CHECK(max_expected < 1e-9);
  CHECK(moved > 1e-3);  // the calibration moved the flange: a URDF written back unchanged would fail above
  // Only the chain joints' origins changed: the fixed joints' are as they were.
  CHECK_THAT(test::slurp(r.urdf_path), Contains("<origin xyz=\"0 0 0.126\" rpy=\"0 0 0\"/>"));
}

TEST_CASE("experiments take a URDF's chain by --base-link and --tip-link", "[e2e][urdf]") {
  const std::string dir = test::tempDir("urdf-experiment");
  workflow::ExperimentOptions o;
  o.robot = test::sourcePath("tests/data/iiwa7.urdf");
  o.scene = test::sourcePath("scenes/iiwa7_scene.yaml");
  o.errors.name = "zero";
  o.validation = 15;
  o.repetitions = 1;
  o.quiet = true;
  o.out = dir + "/default";
  workflow::runFloor(o);  // the root link to the only leaf link
  o.base_link = "world";
  o.tip_link = "iiwa_link_ee";
  o.out = dir + "/named";
  workflow::runFloor(o);  // the same chain, named
  const std::string floor = test::slurp(dir + "/default/floor/floor.csv");
  CHECK(floor.size() > 40);
  CHECK(floor == test::slurp(dir + "/named/floor/floor.csv"));
  // A shorter chain is the arm the experiment gets: Table 3's errors are for 7 joints.
  o.tip_link = "iiwa_link_6";
  o.errors.name = "table3";
  CHECK_THAT(test::inputError([&] { workflow::runFloor(o); }), Contains("has 6 joints"));
}
