// A geometry-only `orbcal calibrate` whose held-out residuals diagnose's lack-of-fit tests flag says, in
// its verdict, that structure is left and which command names it; on data the geometry explains it
// says nothing of the kind. Seeded simulations with a known truth (no noise stated, as a new user's).
#include <catch2/catch.hpp>

#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/workflow/measured.hpp"
#include "test_util.hpp"

using namespace orbcal;

namespace {

workflow::MeasuredCalibrateResult calibrateGeometry(const std::string& name, const std::vector<std::string>& inject) {
  const std::string dir = test::tempDir(name);
  sim::SimulationSpec s;
  s.samples = 150;
  s.seed = 7;
  s.payload_kg = {3.0};
  s.noise_position_m = 0.02e-3;
  s.noise_rotation_rad = 0.005 * sim::kDegToRad;
  const sim::Arm arm = sim::loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  for (const std::string& e : inject) s.effects.push_back(sim::parseEffect(e, arm.numJoints(), "test"));
  sim::SimulatedData d = workflow::runSimulate(arm, s, dir + "/data");
  d.data.noise_position_m.reset();  // as the README's template: no noise stated
  d.data.noise_rotation_rad.reset();
  d.data.noise_joint_rad.reset();
  const std::string desc = sim::writeMeasuredData(d.data, dir + "/unstated", dir + "/data/robot.yaml");
  workflow::MeasuredCalibrateOptions o;
  o.description = desc;
  o.out = dir + "/cal";
  o.plots = false;
  return workflow::runMeasuredCalibrate(o);
}

}  // namespace

TEST_CASE("calibrate DESC.yaml: a geometry-only calibration that leaves structure says so and names diagnose",
          "[e2e][measured][structure]") {
  const workflow::MeasuredCalibrateResult r = calibrateGeometry("structure-left", {"compliance:2"});
  CAPTURE(r.structure_left, r.heldout_after.position_rms_m);
  CHECK(r.lack_of_fit.left());
  CHECK(r.structure_left.find("Structure is left") != std::string::npos);
  CHECK(r.structure_left.find("`orbcal diagnose ") != std::string::npos);
  CHECK(r.structure_left.find("joint 2") != std::string::npos);
  const std::string report = test::slurp(r.report_path);
  CHECK(report.find("Structure is left") != std::string::npos);
}

TEST_CASE("calibrate DESC.yaml: a geometry-only calibration of geometry-only data leaves no structure to report",
          "[e2e][measured][structure]") {
  const workflow::MeasuredCalibrateResult r = calibrateGeometry("structure-none", {});
  CAPTURE(r.structure_left);
  CHECK(r.structure_left.empty());
  CHECK_FALSE(r.lack_of_fit.left());
}
