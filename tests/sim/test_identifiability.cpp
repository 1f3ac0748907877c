// Identifiability: the SSRMS's d3, d4, d5 act along the parallel axes z3 || z4 || z5 (rows 4 and 5 of
// Table 2 have alpha = 0), so with fixed base and tool frames only their sum is observable: rank 26.
#include <catch2/catch.hpp>
#include <random>

#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/identifiability.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "test_util.hpp"

using namespace orbcal::sim;

TEST_CASE("SSRMS: rank 26 of 28, only d3 + d4 + d5 observable", "[sim][identifiability]") {
  const Arm arm = loadArm(kDefaultRobot);
  GeneratorSettings s;
  s.count = 50;
  const auto configs = generateConfigurations(arm, loadScene(kDefaultScene), s);
  const IdentifiabilityReport r = analyzeIdentifiability(arm, configs);
  CHECK(r.num_params == 28);
  CHECK(r.rank == 26);
  REQUIRE(r.redundancies.size() == 1);
  const Redundancy& red = r.redundancies[0];
  CHECK(red.params == std::vector<int>{paramIndex(arm, 2, kD), paramIndex(arm, 3, kD), paramIndex(arm, 4, kD)});
  CHECK(red.lost == 2);
  REQUIRE(red.observable.rows() == 1);
  CHECK((red.observable.row(0) - Eigen::RowVector3d(1, 1, 1)).norm() < 1e-9);
  CHECK(red.describe() == "d3, d4, d5: 2 directions lost; observable only as d3 + d4 + d5");
  // The identifiable part is well conditioned on board-facing views (a wide margin, not a golden number).
  CHECK(r.condition_number < 1e3);
  // The null directions really are null: J n = 0.
  const Eigen::MatrixXd J = stackedJacobian(arm, configs);
  CHECK((J * r.null_space).norm() < 1e-9 * J.norm());
  CHECK(formatIdentifiability(r).find("observable only as d3 + d4 + d5") != std::string::npos);
}

TEST_CASE("breaking the parallelism of joint 5 leaves only d3 + d4 redundant", "[sim][identifiability]") {
  // Twist row 5 (alpha_4) by 10 deg: z4 is no longer parallel to z5, but z3 || z4 still holds
  // (row 4 keeps alpha = 0), so exactly one direction, within {d3, d4}, is lost.
  Arm arm = loadArm(kDefaultRobot);
  arm.joints[4].alpha_rad = 10.0 * kDegToRad;
  std::vector<Eigen::VectorXd> configs;
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> angle(-3.0, 3.0);
  for (int k = 0; k < 40; ++k) configs.push_back(Eigen::VectorXd::NullaryExpr(7, [&] { return angle(rng); }));
  const IdentifiabilityReport r = analyzeIdentifiability(arm, configs);
  CHECK(r.rank == 27);
  REQUIRE(r.redundancies.size() == 1);
  CHECK(r.redundancies[0].params == std::vector<int>{paramIndex(arm, 2, kD), paramIndex(arm, 3, kD)});
  CHECK(r.redundancies[0].describe() == "d3, d4: 1 direction lost; observable only as d3 + d4");
}

// Our numerical check on Jia et al. 2019's arm (docs/methods.md; "Absolute: 29 of 35"; dependent,
// greedy: beta1, beta2, d4, d5, beta5, beta6) on its illustrative geometry (scenes/ssrms_hayati.yaml), full pose, fixed base and tool, 60
// random configurations. Reproduced: each beta_i of a non-parallel pair (alpha_i = 90 deg, a_i = 0; the
// paper's case 3) duplicates theta_i, and d3, d4, d5 act along the parallel axes z2 || z3 || z4.
TEST_CASE("Hayati DH, Jia et al. 2019 geometry: absolute model rank over 60 random configurations", "[sim][identifiability]") {
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/ssrms_hayati.yaml"));
  std::vector<Eigen::VectorXd> configs;
  std::mt19937_64 rng(26);
  std::uniform_real_distribution<double> angle(-kPi, kPi);
  for (int k = 0; k < 60; ++k) configs.push_back(Eigen::VectorXd::NullaryExpr(7, [&] { return angle(rng); }));
  const IdentifiabilityReport r = analyzeIdentifiability(arm, configs);
  CHECK(r.num_params == 35);
  INFO(formatIdentifiability(r));
  CHECK(r.rank == 29);
  std::vector<std::string> described;
  for (const Redundancy& red : r.redundancies) described.push_back(red.describe());
  CHECK(described == std::vector<std::string>{"theta1, beta1: 1 direction lost; observable only as theta1 + beta1",
                                              "theta2, beta2: 1 direction lost; observable only as theta2 + beta2",
                                              "d3, d4, d5: 2 directions lost; observable only as d3 + d4 + d5",
                                              "theta5, beta5: 1 direction lost; observable only as theta5 + beta5",
                                              "theta6, beta6: 1 direction lost; observable only as theta6 + beta6"});
}
