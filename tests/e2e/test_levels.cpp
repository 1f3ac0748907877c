// Calibration levels and motion-capture rigid bodies through the `orbcal` program: simulated 4-marker
// data with missing markers; `--level frames` writes a model that `orbcal evaluate` loads (the nominal
// geometry kept); the default level is chosen by cross-validation and the terminal and the report say
// which and the held-out error of each; a level naming no parameter is a one-line error naming the key.
#include <catch2/catch.hpp>
#include <filesystem>

#include "orbcal/sim/io.hpp"
#include "orbcal/sim/model_io.hpp"
#include "run_orbcal.hpp"

using namespace orbcal;
using Catch::Contains;

TEST_CASE("a frames-only model of rigid-body data is written, and orbcal evaluate loads it", "[e2e][measured][level]") {
  const std::string dir = test::tempDir("levels-frames");
  const std::string robot = test::sourcePath("scenes/iiwa7.yaml");
  // The true arm is the nominal one: a frames-only model is then consistent with the stated noise (with
  // geometry errors the chi-square check would refuse it, rightly).
  REQUIRE(test::runOrbcal(dir, "simulate --robot " + robot + " --geometry zero --markers 4 --missing-markers 0.2 -n 60 --seed 3 -o data")
              .status == 0);
  REQUIRE(test::slurp(dir + "/data/measurements.yaml").find("points: [[p1_x_m, p1_y_m, p1_z_m]") != std::string::npos);

  const test::OrbcalRun cal = test::runOrbcal(dir, "calibrate data/measurements.yaml --level frames -o cal");
  INFO(cal.out << cal.err);
  REQUIRE(cal.status == 0);
  CHECK_THAT(cal.out, Contains("level frames (as asked)"));
  const sim::LoadedModel m = sim::loadModelFile(dir + "/cal/model.yaml");
  CHECK(m.model.marker_points.size() == 4);
  // The nominal geometry kept: every DH row of the model's robot is the nominal one.
  const sim::Arm nominal = sim::loadArm(robot);
  REQUIRE(m.model.arm.numJoints() == nominal.numJoints());
  for (int j = 0; j < nominal.numJoints(); ++j) {
    CHECK(m.model.arm.joints[j].a_m == Approx(nominal.joints[j].a_m).margin(1e-12));
    CHECK(m.model.arm.joints[j].d_m == Approx(nominal.joints[j].d_m).margin(1e-12));
    CHECK(m.model.arm.joints[j].theta_rad == Approx(nominal.joints[j].theta_rad).margin(1e-12));
  }
  const test::OrbcalRun ev = test::runOrbcal(dir, "evaluate --model cal/model.yaml --data data/measurements.yaml -o eval");
  INFO(ev.out << ev.err);
  CHECK(ev.status == 0);
  CHECK(std::filesystem::exists(dir + "/eval/evaluation.json"));
}

TEST_CASE("the default level is chosen by cross-validation and says why", "[e2e][measured][level]") {
  const std::string dir = test::tempDir("levels-auto");
  const std::string robot = test::sourcePath("scenes/iiwa7.yaml");
  REQUIRE(test::runOrbcal(dir, "simulate --robot " + robot + " --markers 4 --missing-markers 0.2 -n 80 --seed 5 -o data").status == 0);
  const test::OrbcalRun cal = test::runOrbcal(dir, "calibrate data/measurements.yaml -o cal");
  INFO(cal.out << cal.err);
  CHECK_THAT(cal.out, Contains("chosen by 5-fold cross-validation repeated 8 times with other splits on ") && Contains("frames ") &&
                          Contains("offsets ") && Contains(" map ") && Contains("effective") && Contains("full ") &&
                          Contains("predicted best by") && Contains("its held-out squared position error per configuration is lower by"));
  CHECK_THAT(test::slurp(dir + "/cal/report.md"), Contains("chosen by 5-fold cross-validation repeated 8 times"));

  const test::OrbcalRun bad = test::runOrbcal(dir, "calibrate data/measurements.yaml --level theta1,bogus2 -o cal2");
  CHECK(bad.status != 0);
  CHECK_THAT(bad.err, Contains("--level") && Contains("'bogus2'"));
  CHECK(bad.err.find('\n') == bad.err.size() - 1);  // one line
}
