// A mobile manipulator end to end (docs/mobile-manipulator.md): the built-in prismatic torso + 7-DOF
// arm, seen by a simulated four-marker rigid body with markers missing in some rows, hides an encoder
// scale error on the torso's prismatic joint and on an arm joint. calibrate recovers both within 3
// sigma; diagnose, not told of them, names the one on the prismatic joint.
#include <catch2/catch.hpp>

#include <regex>

#include "run_orbcal.hpp"
#include "test_util.hpp"

using namespace orbcal;
using Catch::Matchers::Contains;

namespace {

struct Estimate {
  double value = 0.0, sigma = 0.0;
};

/// A parameter's value and sigma as model.yaml lists them under `parameters:`.
Estimate parameterOf(const std::string& model_yaml, const std::string& name) {
  const std::regex row("name: " + name + ", effect: [a-z_]+, value: ([-+0-9.eE]+), sigma: ([-+0-9.eE]+)");
  std::smatch m;
  REQUIRE(std::regex_search(model_yaml, m, row));
  return {std::stod(m[1]), std::stod(m[2])};
}

}  // namespace

TEST_CASE("mobile manipulator: torso and arm scale errors seen by four markers are recovered and named", "[e2e][prismatic][points]") {
  const std::string dir = test::tempDir("mobile-manipulator");
  const test::OrbcalRun sim = test::runOrbcal(
      dir, "simulate --robot builtin:mobile_manipulator.urdf -n 200 --sessions 1 --markers 4 --missing-markers 0.1 "
           "--inject scale:1 scale:4 --seed 11 -o data --quiet");
  INFO(sim.err);
  REQUIRE(sim.status == 0);
  CHECK_THAT(test::slurp(dir + "/data/measurements.yaml"), Contains("prismatic_unit: m") && Contains("points: "));
  CHECK_THAT(test::slurp(dir + "/data/session_1.csv"), Contains(",,"));  // some markers missing

  const test::OrbcalRun cal = test::runOrbcal(dir, "calibrate data/measurements.yaml --effects scale:1 scale:4 -o cal --no-plots");
  INFO(cal.err);
  REQUIRE(cal.status == 0);
  const std::string fitted = test::slurp(dir + "/cal/model.yaml"), truth = test::slurp(dir + "/data/truth/model.yaml");
  for (const char* name : {"s1", "s4"}) {
    const Estimate e = parameterOf(fitted, name), t = parameterOf(truth, name);
    INFO(name << ": " << e.value << " +- " << e.sigma << ", true " << t.value);
    REQUIRE(e.sigma > 0.0);
    CHECK(std::abs(e.value - t.value) < 3.0 * e.sigma);
    CHECK(std::abs(t.value) > 3.0 * e.sigma);  // the error is there to be found, not within the noise
  }

  const test::OrbcalRun diag = test::runOrbcal(dir, "diagnose data/measurements.yaml -o diag --no-plots");
  INFO(diag.out << diag.err);
  REQUIRE(diag.status == 0);
  const std::regex verdict("calibrate with --effects[^\\n]*scale:1");
  CHECK(std::regex_search(diag.out, verdict));
}
