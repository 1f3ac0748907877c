// What the reports flag and summarize (calib/experiment.hpp): suspicious estimates, with and without the
// truth; the summary table has one row per model.
#include <catch2/catch.hpp>

#include "orbcal/calib/experiment.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/io.hpp"
#include "test_util.hpp"

using namespace orbcal;

TEST_CASE("suspicious estimates: a length 200 times the truth is flagged, honest estimates are not", "[calib][report]") {
  const sim::Arm arm = sim::loadArm(test::sourcePath("scenes/ssrms.yaml"));
  const Eigen::VectorXd truth = sim::paperTable3Errors();
  calib::Estimate e;
  e.y = truth + Eigen::VectorXd::Constant(truth.size(), 1e-5);  // off by 0.01 mm / 0.0006 deg: honest
  CHECK(calib::suspiciousEstimates(arm, e, &truth).empty());
  const int a1 = sim::paramIndex(arm, 0, sim::kA);
  e.y[a1] = 200.0 * truth[a1];  // Table 3's a1 is 0.5 mm: 100 mm
  const auto flagged = calib::suspiciousEstimates(arm, e, &truth);
  REQUIRE(flagged.size() == 1u);
  CHECK(flagged[0] == "a1 = +100.000 mm (injected +0.500)");
  // Without the truth: beyond 10 typical magnitudes (5 mm for lengths, 1 deg for angles).
  calib::Estimate real;
  real.y = Eigen::VectorXd::Zero(arm.numParams());
  real.y[sim::paramIndex(arm, 2, sim::kD)] = 0.049;                          // 49 mm: large, not absurd
  real.y[sim::paramIndex(arm, 3, sim::kD)] = 0.051;                          // 51 mm: absurd for an error
  real.y[sim::paramIndex(arm, 4, sim::kTheta)] = 11.0 * sim::kDegToRad;      // 11 deg
  const auto absurd = calib::suspiciousEstimates(arm, real, nullptr);
  REQUIRE(absurd.size() == 2u);
  CHECK(absurd[0] == "d4 = +51.000 mm");
  CHECK(absurd[1] == "theta5 = +11.000 deg");
}

TEST_CASE("comparison summary: one row per model, initial and floor included", "[calib][report]") {
  calib::Comparison c;
  c.initial.position_avg_m = 0.080;
  c.floor.position_avg_m = 0.002;
  calib::MethodOutcome m;
  m.method.name = "LM";
  m.summary.position_avg_m = 0.003;
  c.methods.push_back(m);
  const std::string t = calib::formatComparisonSummary(c);
  CHECK(std::count(t.begin(), t.end(), '\n') == 2 + 3);
  CHECK(t.find("| LM | 3.0000 | 1.500 |") != std::string::npos);  // 3 mm is 1.5 x the 2 mm floor
  CHECK(t.find("96.2%") != std::string::npos);                    // (80 - 3) / 80
}
