// The CLI with a prismatic joint, on the built-in mobile manipulator (joint 1 the prismatic torso):
// `orbcal fk` and `orbcal configs --joint-box-deg` take a revolute joint in degrees and a prismatic
// one in millimetres (labelled in --help); diagnose's residuals.csv and evidence table label and
// scale each joint's value by its type.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/se3.hpp"
#include "run_orbcal.hpp"
#include "test_util.hpp"

using namespace orbcal;
using Catch::Matchers::Contains;

TEST_CASE("fk: the torso in mm, the arm in deg", "[e2e][prismatic]") {
  const std::string dir = test::tempDir("prismatic-fk");
  // The arm straight up (all zeros): the flange is at z = 0.35 (lift origin) + q0 + 0.45 (mount) +
  // 0.34 + 0.4 + 0.4 + 0.126 (the iiwa's links) and x = 0.1 (the mount's offset).
  const test::OrbcalRun low = test::runOrbcal(dir, "fk --robot builtin:mobile_manipulator.urdf 0 0 0 0 0 0 0 0");
  const test::OrbcalRun high = test::runOrbcal(dir, "fk --robot builtin:mobile_manipulator.urdf 250 0 0 0 0 0 0 0");
  INFO(low.err << high.err);
  REQUIRE(low.status == 0);
  REQUIRE(high.status == 0);
  CHECK_THAT(low.out, Contains("position_mm: [100.000000, ") && Contains(", 2066.000000]"));
  CHECK_THAT(high.out, Contains("position_mm: [100.000000, ") && Contains(", 2316.000000]"));  // 250 mm higher
  const test::OrbcalRun json = test::runOrbcal(dir, "fk --robot builtin:mobile_manipulator.urdf --json 250 0 0 0 0 0 0 0");
  REQUIRE(json.status == 0);
  CHECK_THAT(json.out, Contains("\"joints\": {\"q1_mm\": 250, \"q2_deg\": 0, \"q3_deg\": 0, "));
  const test::OrbcalRun help = test::runOrbcal(dir, "fk --help");
  CHECK_THAT(help.out, Contains("revolute [deg], prismatic [mm]"));
  const test::OrbcalRun bad = test::runOrbcal(dir, "fk --robot builtin:mobile_manipulator.urdf 1m 0 0 0 0 0 0 0");
  CHECK(bad.status == 1);
  CHECK_THAT(bad.err, Contains("q1: expected a finite length in millimetres, got '1m'"));
}

TEST_CASE("diagnose: residuals.csv gives the torso's position in mm and the arm's angles in deg", "[e2e][prismatic][diagnose]") {
  const std::string dir = test::tempDir("prismatic-residuals");
  const test::OrbcalRun sim = test::runOrbcal(
      dir, "simulate --robot builtin:mobile_manipulator.urdf -n 40 --sessions 1 --seed 5 -o data --quiet");
  INFO(sim.err);
  REQUIRE(sim.status == 0);
  const test::OrbcalRun diag = test::runOrbcal(dir, "diagnose data/measurements.yaml -o diag --no-plots");
  INFO(diag.out << diag.err);
  REQUIRE(diag.status == 0);

  // The data file (SI: the torso in m, the arm in rad) is the independent source of the joint readings.
  const sim::CsvTable data = sim::CsvTable::parse(test::slurp(dir + "/data/session_1.csv"), "session_1.csv");
  const sim::CsvTable res = sim::CsvTable::parse(test::slurp(dir + "/diag/residuals.csv"), "residuals.csv");
  REQUIRE(res.rows() == data.rows());
  CHECK(res.column("q1_deg") < 0);
  CHECK(res.column("q2_mm") < 0);
  CHECK(res.column("tau2_Nm") >= 0);
  const int torso_mm = res.requireColumn("q1_mm"), arm_deg = res.requireColumn("q2_deg");
  const int torso_m = data.requireColumn("q1_m"), arm_rad = data.requireColumn("q2_rad");
  const int torso_force = res.requireColumn("tau1_N"), data_force = data.requireColumn("tau1_N");  // SI N in both
  const int index = res.requireColumn("index");
  // residuals.csv prints 6 significant digits: relative 1e-5 covers its rounding, and a value in the
  // other unit (x 57.3 or / 17.5) cannot pass.
  constexpr double kPrintTolerance = 1e-5;
  double torso_travel_mm = 0.0;
  for (std::size_t r = 0; r < res.rows(); ++r) {
    const std::size_t k = static_cast<std::size_t>(res.wholeNumber(r, index));
    REQUIRE(k < data.rows());
    const double torso = data.number(k, torso_m) * 1e3, angle = data.number(k, arm_rad) * sim::kRadToDeg;
    CAPTURE(r, torso, angle);
    CHECK(res.number(r, torso_mm) == Approx(torso).epsilon(kPrintTolerance).margin(1e-9));
    CHECK(res.number(r, arm_deg) == Approx(angle).epsilon(kPrintTolerance).margin(1e-9));
    CHECK(res.number(r, torso_force) == Approx(data.number(k, data_force)).epsilon(kPrintTolerance).margin(1e-9));
    torso_travel_mm = std::max(torso_travel_mm, std::abs(torso));
  }
  CHECK(torso_travel_mm > 10.0);  // the torso moves: a column of zeros would pass the comparison

  const std::string report = test::slurp(dir + "/diag/report.md");
  CHECK_THAT(report, Contains("joint 1 position (harmonics 1, 2)") && Contains("joint 2 angle (harmonics 1, 2)"));
  CHECK_THAT(report, !Contains("joint 1 angle"));
}

TEST_CASE("configs: the joint box takes the torso in mm", "[e2e][prismatic][configs]") {
  const std::string dir = test::tempDir("prismatic-box");
  // The torso lifts 0 to 400 mm: a box at 500-600 mm leaves it no travel, and the message says so in mm.
  const test::OrbcalRun bad = test::runOrbcal(
      dir, "configs --robot builtin:mobile_manipulator.urdf --joint-box-deg 500 600 0 1 0 1 0 1 0 1 0 1 0 1 0 1 -o box.csv");
  CHECK(bad.status == 1);
  CHECK_THAT(bad.err, Contains("--joint-box-deg: joint 1: the box 500..600 mm leaves no travel within the robot's limits 0..400 mm"));
  CHECK_THAT(test::runOrbcal(dir, "configs --help").out, Contains("[deg; mm for a prismatic joint]"));
}
