// Inverse kinematics with theta_2 locked (Wang et al. 2023 eq. 4): round trips, least joint motion, failure.
#include <catch2/catch.hpp>
#include <random>

#include "orbcal/sim/ik.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "test_util.hpp"

using namespace orbcal::sim;

namespace {
constexpr double kRoundTripTol = 1e-9;  // the bar: flange position to 1e-9 m (and 1e-9 rad)
}

TEST_CASE("IK round trips to 1e-9 m with theta_2 locked", "[sim][ik]") {
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/ssrms.yaml"));
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> angle(-3.0, 3.0), nudge(-0.2, 0.2);
  IkOptions opt;
  opt.locked_joint = 1;
  int solved = 0;
  for (int n = 0; n < 40; ++n) {
    Eigen::VectorXd q_true = Eigen::VectorXd::NullaryExpr(7, [&] { return angle(rng); });
    const Eigen::Isometry3d target = forwardKinematics(arm, q_true);
    Eigen::VectorXd q_start = q_true + Eigen::VectorXd::NullaryExpr(7, [&] { return nudge(rng); });
    q_start[1] = q_true[1];  // the locked joint is held at its start value
    const IkResult ik = inverseKinematics(arm, target, q_start, opt);
    CAPTURE(n, q_true.transpose(), q_start.transpose());
    // Every case must converge; a failure is reported here (with its case) and counted below, and
    // the remaining cases still run, so one miss does not hide others.
    CHECK(ik.converged);
    if (!ik.converged) continue;
    ++solved;
    const Eigen::Isometry3d reached = forwardKinematics(arm, ik.q);
    CHECK((reached.translation() - target.translation()).norm() < kRoundTripTol);
    CHECK(rotationAngle(reached.linear().transpose() * target.linear()) < kRoundTripTol);
    CHECK(ik.q[1] == q_start[1]);
    CHECK(withinLimits(arm, ik.q));
    // q_true is one solution, so the least-motion solution is at most as far from the start.
    CHECK((ik.q - q_start).norm() <= (q_true - q_start).norm() + 1e-9);
  }
  REQUIRE(solved == 40);
}

TEST_CASE("IK from the solution itself does not move", "[sim][ik]") {
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/ssrms.yaml"));
  const Eigen::VectorXd q = Eigen::VectorXd::LinSpaced(7, -1.2, 1.7);
  IkOptions opt;
  opt.locked_joint = 1;
  const IkResult ik = inverseKinematics(arm, forwardKinematics(arm, q), q, opt);
  REQUIRE(ik.converged);
  CHECK((ik.q - q).norm() < 1e-12);
}

TEST_CASE("IK reports an unreachable pose", "[sim][ik]") {
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/ssrms.yaml"));
  Eigen::Isometry3d far = Eigen::Isometry3d::Identity();
  far.translation() = Eigen::Vector3d(100.0, 0.0, 0.0);  // the arm reaches about 17 m
  IkOptions opt;
  opt.locked_joint = 1;
  const IkResult ik = inverseKinematics(arm, far, Eigen::VectorXd::Zero(7), opt);
  CHECK_FALSE(ik.converged);
  CHECK(ik.position_error_m > 50.0);
}

TEST_CASE("nearest 2 pi equivalent stays within the limits", "[sim][ik]") {
  CHECK(nearestEquivalentAngle(0.1, 6.0, -4.7, 4.7) == Approx(0.1));  // 0.1 + 2 pi is past the limit
  CHECK(nearestEquivalentAngle(0.1, 4.5, -10, 10) == Approx(0.1 + 2 * kPi));
  CHECK(nearestEquivalentAngle(-3.0, -1.0, -4.7, 4.7) == Approx(-3.0));
}
