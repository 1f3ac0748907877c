// The CLI with a prismatic joint: `orbcal fk` takes a revolute joint in degrees and a prismatic one in
// millimetres (labelled in --help), on the built-in mobile manipulator.
#include <catch2/catch.hpp>

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
  const test::OrbcalRun help = test::runOrbcal(dir, "fk --help");
  CHECK_THAT(help.out, Contains("revolute [deg], prismatic [mm]"));
  const test::OrbcalRun bad = test::runOrbcal(dir, "fk --robot builtin:mobile_manipulator.urdf 1m 0 0 0 0 0 0 0");
  CHECK(bad.status == 1);
  CHECK_THAT(bad.err, Contains("q1: expected a finite length in millimetres, got '1m'"));
}
