// Forward kinematics against poses derived by hand, and against an independent composition of
// elementary motions (Eigen's AngleAxis/Translation, not linkTransform's closed-form matrix).
#include <catch2/catch.hpp>
#include <random>

#include "orbcal/sim/arm.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "test_util.hpp"

using namespace orbcal::sim;

namespace {
constexpr double kExactTol = 1e-12;  // a few ulps of a 20 m chain of 9 transforms

Eigen::Isometry3d elementary(DhConvention c, const DhRow& r, double q) {
  using Eigen::AngleAxisd;
  using Eigen::Translation3d;
  using Eigen::Vector3d;
  const double th = r.theta_rad + q;
  if (c == DhConvention::kModified) {
    return Eigen::Isometry3d(AngleAxisd(r.alpha_rad, Vector3d::UnitX()) * Translation3d(r.a_m, 0, 0) *
                             AngleAxisd(th, Vector3d::UnitZ()) * Translation3d(0, 0, r.d_m));
  }
  const Eigen::Isometry3d standard(AngleAxisd(th, Vector3d::UnitZ()) * Translation3d(0, 0, r.d_m) *
                                   Translation3d(r.a_m, 0, 0) * AngleAxisd(r.alpha_rad, Vector3d::UnitX()));
  if (c == DhConvention::kStandard) return standard;
  return standard * AngleAxisd(r.beta_rad, Vector3d::UnitY());  // Hayati: standard DH, then Ry(beta)
}
}  // namespace

TEST_CASE("SSRMS forward kinematics at hand-derived poses", "[sim][fk]") {
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/ssrms.yaml"));
  REQUIRE(arm.numJoints() == 7);
  REQUIRE(arm.numParams() == 28);
  // q = 0, derived row by row from Wang et al. 2023 Table 2 with l0..l8 of Nguyen & Hughes: the flange sits
  // at x = -(l0 + l2 + l4 + l6 + l8) = -4.3312 m, z = -(l1 + l3 + l5 + l7) = -15.6252 m, with
  // x_E = -x_B, y_E = y_B, z_E = -z_B.
  Eigen::VectorXd q = Eigen::VectorXd::Zero(7);
  Eigen::Isometry3d T = forwardKinematics(arm, q);
  CHECK((T.translation() - Eigen::Vector3d(-4.3312, 0.0, -15.6252)).norm() < kExactTol);
  CHECK((T.linear() - Eigen::Vector3d(-1, 1, -1).asDiagonal().toDenseMatrix()).norm() < kExactTol);
  // q1 = 90 deg turns everything after joint 1 about its axis z1 = -x_B through (-l0, 0, 0):
  // a rotation of -90 deg about x_B maps (y, z) -> (z, -y).
  q[0] = 0.5 * kPi;
  T = forwardKinematics(arm, q);
  CHECK((T.translation() - Eigen::Vector3d(-4.3312, -15.6252, 0.0)).norm() < kExactTol);
  Eigen::Matrix3d R_expected;
  R_expected << -1, 0, 0, 0, 0, -1, 0, -1, 0;
  CHECK((T.linear() - R_expected).norm() < kExactTol);
}

TEST_CASE("iiwa7 standard-DH forward kinematics at zero is a straight column", "[sim][fk]") {
  // Standard DH with the offsets of the data's author: at q = 0 the alternating +-90 deg twists cancel
  // pairwise and the offsets of joints 3 and 5 (180 deg each) cancel, leaving Tz(0.34 + 0.4 + 0.4 + 0.126).
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/iiwa7.yaml"));
  REQUIRE(arm.convention == DhConvention::kStandard);
  const Eigen::Isometry3d T = forwardKinematics(arm, Eigen::VectorXd::Zero(7));
  CHECK((T.translation() - Eigen::Vector3d(0, 0, 1.266)).norm() < kExactTol);
  CHECK((T.linear() - Eigen::Matrix3d::Identity()).norm() < kExactTol);
}

TEST_CASE("forward kinematics equals the composition of elementary motions", "[sim][fk]") {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> angle(-3.0, 3.0);
  for (const char* file : {"scenes/ssrms.yaml", "scenes/iiwa7.yaml", "scenes/ssrms_hayati.yaml"}) {
    Arm arm = loadArm(orbcal::test::sourcePath(file));
    // Hayati: non-zero betas, so that Ry(beta) is exercised.
    for (int j = 0; j < arm.numJoints() && arm.convention == DhConvention::kHayati; ++j) arm.joints[j].beta_rad = 0.1 * (j - 3);
    for (int n = 0; n < 20; ++n) {
      Eigen::VectorXd q(arm.numJoints());
      for (int j = 0; j < arm.numJoints(); ++j) q[j] = angle(rng);
      Eigen::Isometry3d expected = arm.base_T_first;
      for (int j = 0; j < arm.numJoints(); ++j) expected = expected * elementary(arm.convention, arm.joints[j], q[j]);
      expected = expected * arm.last_T_flange;
      CAPTURE(file, q.transpose());
      CHECK((forwardKinematics(arm, q).matrix() - expected.matrix()).norm() < kExactTol);
    }
  }
}

TEST_CASE("parameter errors move the DH rows they name", "[sim][fk]") {
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/ssrms.yaml"));
  Eigen::VectorXd y = Eigen::VectorXd::Zero(28);
  y[paramIndex(arm, 3, kA)] = 0.002;         // a of row 4 (the upper boom, l3)
  y[paramIndex(arm, 6, kTheta)] = 0.001;     // theta offset of joint 7
  const Arm err = withErrors(arm, y);
  CHECK(err.joints[3].a_m == Approx(7.112).epsilon(1e-15));
  CHECK(err.joints[6].theta_rad == Approx(arm.joints[6].theta_rad + 0.001).margin(1e-15));
  CHECK(paramName(arm, paramIndex(arm, 3, kA)) == "a4");
  CHECK(paramName(arm, paramIndex(arm, 0, kTheta)) == "theta1");
  CHECK(paramName(arm, 27) == "d7");
  // A theta offset and the joint angle are the same motion.
  Eigen::VectorXd q = Eigen::VectorXd::Constant(7, 0.3);
  Eigen::VectorXd q2 = q;
  q2[6] += 0.001;
  CHECK((forwardKinematics(err, q).matrix() - forwardKinematics(withErrors(arm, y - 0.001 * Eigen::VectorXd::Unit(28, paramIndex(arm, 6, kTheta))), q2).matrix()).norm() < kExactTol);
}

TEST_CASE("poseMinus and posePlus are inverse, and logSO3 is exact near pi", "[sim][se3]") {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> n01;
  for (int i = 0; i < 50; ++i) {
    Vector6d e;
    for (int k = 0; k < 6; ++k) e[k] = n01(rng);
    if (e.tail<3>().norm() >= kPi) e.tail<3>() *= 3.0 / e.tail<3>().norm();
    const Eigen::Isometry3d T0 = fromXyzRpy(Eigen::Vector3d(n01(rng), n01(rng), n01(rng)),
                                            Eigen::Vector3d(n01(rng), n01(rng), n01(rng)));
    CHECK((poseMinus(posePlus(T0, e), T0) - e).norm() < 1e-12);
  }
  const Eigen::Vector3d axis = Eigen::Vector3d(1, 2, 3).normalized();
  const Eigen::Vector3d w = axis * (kPi - 1e-9);
  CHECK((logSO3(expSO3(w)) - w).norm() < 1e-8);  // near pi the axis sign is fixed by the angle < pi
}

TEST_CASE("joint and parameter vectors are checked", "[sim][fk]") {
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/ssrms.yaml"));
  CHECK_THROWS_WITH(forwardKinematics(arm, Eigen::VectorXd::Zero(6)),
                    Catch::Contains("expected 7 joint angles, got 6"));
  Eigen::VectorXd q = Eigen::VectorXd::Zero(7);
  q[2] = std::nan("");
  CHECK_THROWS_WITH(forwardKinematics(arm, q), Catch::Contains("joint angles[2] is not a finite number"));
  CHECK_THROWS_WITH(withErrors(arm, Eigen::VectorXd::Zero(27)), Catch::Contains("expected 28 parameter errors"));
}

TEST_CASE("Hayati DH: beta = 0 is standard DH, beta != 0 Liu et al. 2012's eq. 2", "[sim][fk]") {
  const Arm hayati = loadArm(orbcal::test::sourcePath("scenes/ssrms_hayati.yaml"));
  REQUIRE(hayati.convention == DhConvention::kHayati);
  REQUIRE(hayati.paramsPerJoint() == 5);
  REQUIRE(hayati.numParams() == 35);
  Arm standard = hayati;
  standard.convention = DhConvention::kStandard;
  REQUIRE(standard.numParams() == 28);
  std::mt19937_64 rng(43);
  std::uniform_real_distribution<double> angle(-3.0, 3.0);
  for (int n = 0; n < 20; ++n) {
    const Eigen::VectorXd q = Eigen::VectorXd::NullaryExpr(7, [&] { return angle(rng); });
    CHECK((forwardKinematics(hayati, q).matrix() - forwardKinematics(standard, q).matrix()).norm() < kExactTol);
  }
  // Liu et al. 2012 eq. 2, written out here independently of linkTransform.
  DhRow r;
  r.a_m = 0.7;
  r.alpha_rad = 0.4;
  r.d_m = -0.3;
  r.theta_rad = 0.2;
  r.beta_rad = -0.25;
  const double q = 1.1;
  const double ct = std::cos(r.theta_rad + q), st = std::sin(r.theta_rad + q);
  const double ca = std::cos(r.alpha_rad), sa = std::sin(r.alpha_rad), cb = std::cos(r.beta_rad), sb = std::sin(r.beta_rad);
  Eigen::Matrix4d M;
  M << ct * cb - st * sa * sb, -st * ca, ct * sb + st * sa * cb, r.a_m * ct,  //
      st * cb + ct * sa * sb, ct * ca, st * sb - ct * sa * cb, r.a_m * st,    //
      -ca * sb, sa, ca * cb, r.d_m,                                           //
      0, 0, 0, 1;
  CHECK((linkTransform(DhConvention::kHayati, r, q).matrix() - M).norm() < 1e-15);
  CHECK((elementary(DhConvention::kHayati, r, q).matrix() - M).norm() < 1e-15);
}

TEST_CASE("Hayati DH: 5 parameters per joint, beta last", "[sim][fk]") {
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/ssrms_hayati.yaml"));
  CHECK(paramIndex(arm, 1, kBeta) == 9);
  CHECK(paramName(arm, paramIndex(arm, 1, kBeta)) == "beta2");
  CHECK(paramName(arm, paramIndex(arm, 2, kA)) == "a3");
  CHECK(paramName(arm, 34) == "beta7");
  CHECK(isAngleParam(arm, paramIndex(arm, 4, kBeta)));
  CHECK_FALSE(isAngleParam(arm, paramIndex(arm, 4, kD)));
  Eigen::VectorXd y = Eigen::VectorXd::Zero(35);
  y[paramIndex(arm, 2, kBeta)] = 0.001;
  y[paramIndex(arm, 3, kA)] = 0.002;
  const Arm err = withErrors(arm, y);
  CHECK(err.joints[2].beta_rad == 0.001);
  CHECK(err.joints[3].a_m == Approx(4.002).epsilon(1e-15));
  CHECK_THROWS_WITH(withErrors(arm, Eigen::VectorXd::Zero(28)), "withErrors: expected 35 parameter errors, got 28");
}
