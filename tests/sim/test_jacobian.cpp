// The analytic identification Jacobian (Wang et al. 2023 eqs. 5-9) against central differences of the true
// pose error, for every column, in both frames, at the zero, singular and random configurations.
#include <catch2/catch.hpp>
#include <random>

#include "orbcal/sim/io.hpp"
#include "orbcal/sim/jacobian.hpp"
#include "orbcal/sim/se3.hpp"
#include "test_util.hpp"

using namespace orbcal::sim;

namespace {
// Central differences: truncation ~ h^2 |f'''| ~ 1e-12 * 20 m; round-off ~ 1e-16 * 20 m / h = 2e-9.
constexpr double kStep = 1e-6;
// Entries are O(1..20) (m/rad and rad/rad on a 20 m arm); 1e-7 is 50x the round-off bound above and
// would still catch any wrong lever arm, sign or frame (those err by O(0.1..20)).
constexpr double kJacobianTol = 1e-7;

void checkAgainstNumeric(const Arm& arm, const Eigen::VectorXd& q, ErrorFrame frame) {
  const Matrix6Xd J = identificationJacobian(arm, q, frame);
  const Matrix6Xd J_num = numericIdentificationJacobian(arm, q, frame, kStep);
  REQUIRE(J_num.norm() > 1.0);  // a harness returning zeros must not pass
  for (int c = 0; c < arm.numParams(); ++c) {
    Eigen::Index r = 0;
    const double err = (J.col(c) - J_num.col(c)).cwiseAbs().maxCoeff(&r);
    CAPTURE(q.transpose(), paramName(arm, c), r, J(r, c), J_num(r, c));
    REQUIRE(err < kJacobianTol);
  }
}

std::vector<Eigen::VectorXd> testConfigurations(int n, std::uint64_t seed) {
  std::vector<Eigen::VectorXd> qs;
  qs.push_back(Eigen::VectorXd::Zero(n));                      // aligned axes
  Eigen::VectorXd wrist = Eigen::VectorXd::Zero(n);            // wrist singularity: joint 6 at 90 deg
  wrist[5] = 0.5 * kPi;
  qs.push_back(wrist);
  Eigen::VectorXd elbow = Eigen::VectorXd::Zero(n);            // elbow fully stretched or folded
  elbow[3] = kPi;
  qs.push_back(elbow);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> angle(-4.7, 4.7);
  for (int k = 0; k < 12; ++k) qs.push_back(Eigen::VectorXd::NullaryExpr(n, [&] { return angle(rng); }));
  return qs;
}
}  // namespace

TEST_CASE("identification Jacobian matches central differences (modified DH, SSRMS)", "[sim][jacobian]") {
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/ssrms.yaml"));
  for (const auto& q : testConfigurations(7, 11)) {
    checkAgainstNumeric(arm, q, ErrorFrame::kTool);
    checkAgainstNumeric(arm, q, ErrorFrame::kBase);
  }
}

TEST_CASE("identification Jacobian matches central differences (standard DH, iiwa7)", "[sim][jacobian]") {
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/iiwa7.yaml"));
  for (const auto& q : testConfigurations(7, 12)) {
    checkAgainstNumeric(arm, q, ErrorFrame::kTool);
    checkAgainstNumeric(arm, q, ErrorFrame::kBase);
  }
}

TEST_CASE("identification Jacobian holds away from the nominal parameters", "[sim][jacobian]") {
  // The iterated estimators re-linearise at p_nom + y_hat: the formula must hold there too.
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/ssrms.yaml"));
  Eigen::VectorXd y(28);
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n01;
  // Spreads per unit, chosen rather than one number for both units: 0.5 deg on angles (in rad) and
  // 5 mm on lengths (in m), 2-5 times Wang et al. 2023's Table 3 errors (0.2-0.3 deg, 0.5-1 mm), i.e. where
  // the iterated estimators re-linearise. Large enough to test something: the Jacobian at the nominal
  // parameters differs from the true one at p_nom + y by >= 0.1 at the random configurations, 1e6 x
  // kJacobianTol, so a formula that ignored y would fail.
  constexpr double kAngleSpread = 0.5 * kDegToRad;  // rad
  constexpr double kLengthSpread = 0.005;           // m
  for (int i = 0; i < 28; ++i) y[i] = n01(rng) * (isAngleParam(arm, i) ? kAngleSpread : kLengthSpread);
  for (const auto& q : testConfigurations(7, 13)) checkAgainstNumeric(withErrors(arm, y), q, ErrorFrame::kTool);
}

TEST_CASE("manipulator Jacobian matches finite differences of forward kinematics", "[sim][jacobian]") {
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/ssrms.yaml"));
  for (const auto& q : testConfigurations(7, 14)) {
    const Matrix6Xd J = manipulatorJacobian(arm, q);
    const Eigen::Isometry3d T = forwardKinematics(arm, q);
    for (int j = 0; j < 7; ++j) {
      Eigen::VectorXd qp = q, qm = q;
      qp[j] += kStep;
      qm[j] -= kStep;
      const Eigen::Isometry3d Tp = forwardKinematics(arm, qp), Tm = forwardKinematics(arm, qm);
      Vector6d col;
      col << (Tp.translation() - Tm.translation()) / (2 * kStep),
          (logSO3(Tp.linear() * T.linear().transpose()) - logSO3(Tm.linear() * T.linear().transpose())) / (2 * kStep);
      CAPTURE(j, q.transpose());
      REQUIRE((J.col(j) - col).cwiseAbs().maxCoeff() < kJacobianTol);
    }
  }
}

TEST_CASE("tool- and base-frame Jacobians are related by the flange rotation", "[sim][jacobian]") {
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/ssrms.yaml"));
  const Eigen::VectorXd q = Eigen::VectorXd::LinSpaced(7, -1.0, 2.0);
  const Eigen::Matrix3d R = forwardKinematics(arm, q).linear();
  const Matrix6Xd Jt = identificationJacobian(arm, q, ErrorFrame::kTool);
  const Matrix6Xd Jb = identificationJacobian(arm, q, ErrorFrame::kBase);
  CHECK((Jb.topRows<3>() - R * Jt.topRows<3>()).norm() < 1e-12);
  CHECK((Jb.bottomRows<3>() - R * Jt.bottomRows<3>()).norm() < 1e-12);
}

TEST_CASE("identification Jacobian matches central differences (Hayati DH, beta columns included)", "[sim][jacobian]") {
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/ssrms_hayati.yaml"));
  REQUIRE(arm.numParams() == 35);
  for (const auto& q : testConfigurations(7, 15)) {
    checkAgainstNumeric(arm, q, ErrorFrame::kTool);
    checkAgainstNumeric(arm, q, ErrorFrame::kBase);
  }
  // Away from the nominal parameters, beta != 0 included: there alpha and a act along the x axis
  // before Ry(beta), not along x_i. Spreads as in the SSRMS case above (0.5 deg, 5 mm) plus 2 deg on
  // every beta, so a formula that used x_i would err by ~sin(2 deg) * 4 m = 0.14, 1e6 x kJacobianTol.
  Eigen::VectorXd y(35);
  std::mt19937_64 rng(4);
  std::normal_distribution<double> n01;
  for (int i = 0; i < 35; ++i) y[i] = n01(rng) * (isAngleParam(arm, i) ? 0.5 * kDegToRad : 0.005);
  Arm off = withErrors(arm, y);
  for (int j = 0; j < 7; ++j) off.joints[j].beta_rad += (j % 2 ? 2.0 : -2.0) * kDegToRad;
  for (const auto& q : testConfigurations(7, 16)) {
    checkAgainstNumeric(off, q, ErrorFrame::kTool);
    checkAgainstNumeric(off, q, ErrorFrame::kBase);
  }
}

TEST_CASE("identification Jacobian matches central differences (URDF convention)", "[sim][jacobian][urdf]") {
  // The iiwa7 URDF (z axes, rpy of multiples of 90 deg) and the same chain with every origin moved and
  // turned and every axis tilted (all 7 columns a joint non-trivial: rpy away from 0 and 90 deg).
  const Arm arm = loadArm(orbcal::test::sourcePath("tests/data/iiwa7.urdf"));
  REQUIRE(arm.convention == DhConvention::kUrdf);
  for (const auto& q : testConfigurations(7, 14)) {
    checkAgainstNumeric(arm, q, ErrorFrame::kTool);
    checkAgainstNumeric(arm, q, ErrorFrame::kBase);
  }
  Arm bent = arm;
  std::mt19937_64 rng(15);
  std::normal_distribution<double> n01;
  for (DhRow& r : bent.joints) {
    r.xyz_m += 0.05 * Eigen::Vector3d(n01(rng), n01(rng), n01(rng));
    r.rpy_rad += 0.3 * Eigen::Vector3d(n01(rng), n01(rng), n01(rng));
    r.axis = (r.axis + 0.3 * Eigen::Vector3d(n01(rng), n01(rng), n01(rng))).normalized();
    r.theta_rad = 0.2 * n01(rng);
  }
  for (const auto& q : testConfigurations(7, 16)) {
    checkAgainstNumeric(bent, q, ErrorFrame::kTool);
    checkAgainstNumeric(bent, q, ErrorFrame::kBase);
  }
}

TEST_CASE("identification Jacobian from the caller's chain frames equals the one that computes them", "[sim][jacobian]") {
  // predictMarkerPose hands over the frames it already has; any frame other than chainFrames' own
  // (a different link insert, an off-by-one) would move columns by O(0.1..1).
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/iiwa7.yaml"));
  LinkInserts inserts(static_cast<std::size_t>(arm.numJoints()), Eigen::Isometry3d::Identity());
  // A bent third link: 1-2 mm and 3.7 mrad.
  inserts[2] = Eigen::Translation3d(1e-3, -2e-3, 5e-4) * Eigen::AngleAxisd(3.7e-3, Eigen::Vector3d(3.0, -1.0, 2.0).normalized());
  for (const auto& q : testConfigurations(7, 29)) {
    Matrix6Xd computed(6, arm.numParams()), given(6, arm.numParams());
    identificationJacobian(arm, q, ErrorFrame::kTool, computed, inserts);
    identificationJacobian(arm, q, ErrorFrame::kTool, given, inserts, chainFrames(arm, q, inserts));
    REQUIRE(computed.norm() > 1.0);
    REQUIRE(given == computed);
  }
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(7);
  std::vector<Eigen::Isometry3d> short_chain = chainFrames(arm, q, inserts);
  short_chain.pop_back();
  Matrix6Xd J(6, arm.numParams());
  REQUIRE_THROWS_WITH(identificationJacobian(arm, q, ErrorFrame::kTool, J, inserts, short_chain),
                      Catch::Contains("expected 9 frames, got 8"));
}

TEST_CASE("chain frames into a reused vector equal the frames chainFrames returns", "[sim][jacobian]") {
  // predictMarkerPose keeps one vector per thread for the frames of every sample: whatever it held
  // before (another configuration's frames, a longer chain's) must not show in the next.
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/iiwa7.yaml"));
  LinkInserts inserts(static_cast<std::size_t>(arm.numJoints()), Eigen::Isometry3d::Identity());
  inserts[4] = Eigen::Translation3d(-2e-3, 1e-3, 3e-3) * Eigen::AngleAxisd(2.1e-3, Eigen::Vector3d(1.0, 2.0, -2.0).normalized());
  std::vector<Eigen::Isometry3d> reused(20, Eigen::Isometry3d(Eigen::Translation3d(1.0, 2.0, 3.0)));
  for (const auto& q : testConfigurations(7, 31)) {
    for (const LinkInserts& in : {inserts, LinkInserts{}}) {
      chainFrames(arm, q, in, reused);
      const std::vector<Eigen::Isometry3d> fresh = chainFrames(arm, q, in);
      REQUIRE(reused.size() == fresh.size());
      for (std::size_t i = 0; i < fresh.size(); ++i) REQUIRE(reused[i].matrix() == fresh[i].matrix());
    }
  }
}
