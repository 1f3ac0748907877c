// The kinematic model of geometry + registration + effects: every effect's analytic Jacobian against
// central differences, alone and composed, in both DH conventions, at random parameters; the effects'
// forward models against their defining formulas; folding parameters into the model.
#include <catch2/catch.hpp>
#include <random>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/model.hpp"
#include "orbcal/sim/se3.hpp"
#include "jacobian_check.hpp"
#include "test_util.hpp"

using namespace orbcal::sim;

namespace {


JointSample randomSample(const Arm& arm, int session, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  JointSample s;
  const int n = arm.numJoints();
  s.q_rad.resize(n);
  s.tau_Nm.resize(n);
  s.direction.resize(n);
  for (int j = 0; j < n; ++j) {
    s.q_rad[j] = arm.lower_rad[j] + u(rng) * (arm.upper_rad[j] - arm.lower_rad[j]);
    s.tau_Nm[j] = -60.0 + 120.0 * u(rng);
    s.direction[j] = u(rng) < 0.5 ? -1.0 : 1.0;
  }
  s.temperature_C = 15.0 + 20.0 * u(rng);
  s.time_s = 3600.0 * u(rng);
  s.session = session;
  return s;
}

Eigen::VectorXd randomParams(const KinematicModel& m, std::mt19937_64& rng) {
  std::normal_distribution<double> n01(0.0, 1.0);
  const Eigen::VectorXd t = m.layout.typical();
  Eigen::VectorXd p(t.size());
  for (Eigen::Index i = 0; i < p.size(); ++i) p[i] = n01(rng) * t[i];
  return p;
}

/// predictMarkerPose's Jacobian against central differences (tests/jacobian_check.hpp), in the
/// chart poseMinus(., T) around the pose T at p.
void checkJacobian(const KinematicModel& m, const JointSample& s, const Eigen::VectorXd& p) {
  Eigen::MatrixXd J;
  const Eigen::Isometry3d T = predictMarkerPose(m, p, s, &J);
  REQUIRE(J.rows() == 6);
  REQUIRE(J.cols() == m.layout.size());
  const auto f = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd { return poseMinus(predictMarkerPose(m, x, s), T); };
  const double largest = orbcal::test::requireJacobianMatches(f, J, p, m.layout.typical(), [&](int c) { return m.layout.param(c).name; });
  REQUIRE(largest > 1e-4);  // the harness is not comparing zeros
}

KinematicModel modelWith(const Arm& arm, std::vector<Effect> effects, FrameSharing base = FrameSharing::kShared,
                         FrameSharing marker = FrameSharing::kPerSession) {
  const int sessions = 2;
  const Eigen::Isometry3d W = fromXyzRpy({2.1, -0.7, 0.4}, Eigen::Vector3d(20, -110, 65) * kDegToRad);
  const Eigen::Isometry3d M = fromXyzRpy({0.03, -0.05, 0.11}, Eigen::Vector3d(5, -8, 40) * kDegToRad);
  const auto frames = [&](FrameSharing f, const Eigen::Isometry3d& T) {
    return std::vector<Eigen::Isometry3d>(f == FrameSharing::kPerSession ? sessions : 1, T);
  };
  return makeKinematicModel(arm, sessions, base, marker, frames(base, W), frames(marker, M), std::move(effects));
}

/// The index of the parameter called `name` in m's layout (fails the test when there is none).
int paramIndexOf(const KinematicModel& m, const std::string& name) {
  for (int i = 0; i < m.layout.size(); ++i) {
    if (m.layout.param(i).name == name) return i;
  }
  FAIL("no parameter " << name);
  return -1;
}

std::vector<Effect> everyEffect(int n) {
  return {Compliance{{1, 3}}, Cyclic{{0, n - 1}, 2}, Scale{{2}}, Backlash{{1, 4}}, Thermal{}, Drift{}, Mount{},
          Compliance{{5}, 3}, Cyclic{{4}, 6}, parseEffect("coupling:4,2,7,6", n, "test"),
          parseEffect("link_bending:2," + std::to_string(n), n, "test")};  // the last: its far end is the flange
}

}  // namespace

TEST_CASE("each effect's Jacobian matches central differences, alone and composed", "[model]") {
  for (const char* file : {"scenes/iiwa7.yaml", "scenes/ssrms.yaml"}) {
    const Arm arm = loadArm(orbcal::test::sourcePath(file));
    std::mt19937_64 rng(20261123);
    std::vector<std::vector<Effect>> cases;
    cases.push_back({});  // geometry + registration alone
    for (const Effect& e : everyEffect(arm.numJoints())) cases.push_back({e});
    cases.push_back(everyEffect(arm.numJoints()));
    for (const auto& effects : cases) {
      const KinematicModel m = modelWith(arm, effects);
      for (int trial = 0; trial < 4; ++trial) {
        CAPTURE(file, effects.size() == 1 ? formatEffect(effects[0]) : std::to_string(effects.size()) + " effects", trial);
        checkJacobian(m, randomSample(arm, trial % 2, rng), randomParams(m, rng));
      }
    }
    // Per-session bases and a shared marker; known frames.
    checkJacobian(modelWith(arm, everyEffect(arm.numJoints()), FrameSharing::kPerSession, FrameSharing::kShared),
                  randomSample(arm, 1, rng), randomParams(modelWith(arm, everyEffect(arm.numJoints()), FrameSharing::kPerSession, FrameSharing::kShared), rng));
    const KinematicModel known = modelWith(arm, {Compliance{{1}}}, FrameSharing::kKnown, FrameSharing::kKnown);
    checkJacobian(known, randomSample(arm, 0, rng), randomParams(known, rng));
  }
}

TEST_CASE("two effects of one kind on different joints keep their own parameters, a repeated one is refused", "[model]") {
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/iiwa7.yaml"));
  const KinematicModel m = modelWith(arm, {Compliance{{1}}, Cyclic{{2}, 1}, Compliance{{3}}});
  std::mt19937_64 rng(3);
  checkJacobian(m, randomSample(arm, 0, rng), randomParams(m, rng));
  JointSample s = randomSample(arm, 0, rng);
  Eigen::VectorXd p = Eigen::VectorXd::Zero(m.layout.size());
  p[m.layout.block(m.effect_blocks[2][0]).offset] = 1e-4;  // c4 only
  const Eigen::VectorXd dq = jointCorrections(m, p, s);
  CHECK(dq[1] == 0.0);
  CHECK(dq[3] == Approx(-1e-4 * s.tau_Nm[3]).epsilon(1e-14));  // yields to its load: against the actuator's torque
  CHECK_THROWS_WITH(modelWith(arm, {Compliance{{1, 3}}, Compliance{{3}}}), Catch::Contains("compliance:4 is given twice"));
}

TEST_CASE("joint effects follow their defining formulas", "[model]") {
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/iiwa7.yaml"));
  const KinematicModel m = modelWith(arm, {Compliance{{1}}, Cyclic{{2}, 1}, Scale{{3}}, Backlash{{4}}});
  std::mt19937_64 rng(7);
  const JointSample s = randomSample(arm, 0, rng);
  Eigen::VectorXd p = Eigen::VectorXd::Zero(m.layout.size());
  const auto at = [&](const std::string& name) { return paramIndexOf(m, name); };
  p[at("c2")] = 2e-5;
  p[at("cyclic3_sin1")] = 3e-4;
  p[at("cyclic3_cos1")] = -1e-4;
  p[at("s4")] = 5e-4;
  p[at("b5")] = 2e-4;
  const Eigen::VectorXd dq = jointCorrections(m, p, s);
  CHECK(dq[0] == 0.0);
  CHECK(dq[1] == Approx(-2e-5 * s.tau_Nm[1]).epsilon(1e-14));
  CHECK(dq[2] == Approx(3e-4 * std::sin(s.q_rad[2]) - 1e-4 * std::cos(s.q_rad[2])).epsilon(1e-14));
  CHECK(dq[3] == Approx(5e-4 * s.q_rad[3]).epsilon(1e-14));
  CHECK(dq[4] == Approx(2e-4 * s.direction[4]).epsilon(1e-14));
  // The flange pose is the nominal arm's at the corrected joints.
  const Eigen::Isometry3d F = flangePose(m, p, s);
  CHECK((F.matrix() - forwardKinematics(arm, s.q_rad + dq).matrix()).cwiseAbs().maxCoeff() < 1e-15);
}

TEST_CASE("thermal expansion scales every DH length", "[model]") {
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/iiwa7.yaml"));
  const KinematicModel m = modelWith(arm, {Thermal{20.0}});
  Eigen::VectorXd p = Eigen::VectorXd::Zero(m.layout.size());
  p[m.layout.block(m.layout.find("thermal")).offset] = 2.3e-5;
  JointSample s;
  s.q_rad = Eigen::VectorXd::Zero(arm.numJoints());
  s.temperature_C = 30.0;
  const Arm warm = effectiveArm(m, p, s);
  for (int j = 0; j < arm.numJoints(); ++j) CHECK(warm.joints[j].d_m == Approx(arm.joints[j].d_m * (1.0 + 2.3e-5 * 10.0)));
  // At q = 0 the iiwa stands straight up: the flange rises by alpha dT (d1 + d3 + d5 + d7).
  const double dz = flangePose(m, p, s).translation().z() - forwardKinematics(arm, s.q_rad).translation().z();
  CHECK(dz == Approx(2.3e-4 * (0.34 + 0.4 + 0.4 + 0.126)).epsilon(1e-9));
}

TEST_CASE("folding parameters into the model keeps its predictions", "[model]") {
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/ssrms.yaml"));
  const KinematicModel m = modelWith(arm, everyEffect(arm.numJoints()));
  std::mt19937_64 rng(11);
  const Eigen::VectorXd p = randomParams(m, rng);
  const FoldedModel f = foldParameters(m, p);
  for (int k = 0; k < 5; ++k) {
    const JointSample s = randomSample(arm, k % 2, rng);
    const Eigen::Isometry3d a = predictMarkerPose(m, p, s), b = predictMarkerPose(f.model, f.p, s);
    CHECK((a.matrix() - b.matrix()).cwiseAbs().maxCoeff() < 1e-12);
  }
  CHECK(f.p.segment(f.model.layout.block(f.model.layout.find("geometry")).offset, arm.numParams()).isZero());
}

TEST_CASE("effect specifications parse and print back, bad ones are errors naming the option", "[model]") {
  for (const char* spec : {"compliance:2,4", "compliance:3/3", "cyclic:2", "cyclic:1,7/3", "scale:3", "backlash:1", "thermal",
                           "drift", "mount", "coupling:3,2", "coupling:3,2,6,5", "link_bending:2,4"}) {
    CHECK(formatEffect(parseEffect(spec, 7, "--effects")) == spec);
  }
  const auto message = [](const std::string& spec) {
    try {
      parseEffect(spec, 7, "--effects");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  CHECK_THAT(message("compliance:8"), Catch::Contains("--effects") && Catch::Contains("joint 8"));
  CHECK_THAT(message("compliance"), Catch::Contains("needs joints"));
  CHECK_THAT(message("thermal:2"), Catch::Contains("takes no joints"));
  CHECK_THAT(message("bend:2"), Catch::Contains("unknown effect"));
  CHECK_THAT(message("cyclic:2/0"), Catch::Contains("order"));
  CHECK_THAT(message("compliance:2/2"), Catch::Contains("1 (linear) or 3"));
  CHECK_THAT(message("coupling:3"), Catch::Contains("pairs"));
  CHECK_THAT(message("coupling:3,3"), Catch::Contains("scale:3"));
  CHECK_THAT(message("scale:3/2"), Catch::Contains("takes no /K"));
}

TEST_CASE("coupling and a stiffening compliance follow their defining formulas", "[model]") {
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/iiwa7.yaml"));
  const KinematicModel m = modelWith(arm, {parseEffect("coupling:3,2", 7, "test"), Compliance{{4}, 3}});
  std::mt19937_64 rng(17);
  const JointSample s = randomSample(arm, 0, rng);
  Eigen::VectorXd p = Eigen::VectorXd::Zero(m.layout.size());
  const auto at = [&](const std::string& name) { return paramIndexOf(m, name); };
  p[at("k3_2")] = 4e-4;
  p[at("c5")] = 1e-4;
  p[at("c5_cubic")] = -2e-8;
  const Eigen::VectorXd dq = jointCorrections(m, p, s);
  CHECK(dq[2] == Approx(4e-4 * s.q_rad[1]).epsilon(1e-14));
  CHECK(dq[1] == 0.0);
  const double t = s.tau_Nm[4];
  CHECK(dq[4] == Approx(-(1e-4 * t - 2e-8 * t * t * t)).epsilon(1e-14));  // against the actuator's torque
  CHECK((dq.array() != 0.0).count() == 2);
}

TEST_CASE("a bending link deflects its far end by F L^3 / 3EI and tilts it by F L^2 / 2EI", "[model]") {
  // Two joints about vertical axes (standard DH): link 1 is a horizontal beam of L = 0.8 m along x of
  // frame 1; link 2 has no length, so the flange sits at the beam's far end. 3 kg sit there (link 2's
  // mass) and 2 kg of payload: F = 5 kg x 9.80665 m/s^2, straight down, across the beam; link 1's own
  // 1 kg sits at its middle (a = 0.4 m): P a^2 (3L - a) / 6EI at the far end, P a^2 / 2EI of tilt.
  Arm arm;
  arm.name = "beam";
  arm.convention = DhConvention::kStandard;
  arm.joints.resize(2);
  arm.joints[0].a_m = 0.8;
  arm.lower_rad = Eigen::Vector2d::Constant(-3.0);
  arm.upper_rad = Eigen::Vector2d::Constant(3.0);
  arm.masses.links = {LinkMass{1.0, Eigen::Vector3d(-0.4, 0, 0)}, LinkMass{3.0, Eigen::Vector3d::Zero()}};
  arm.masses.payload_kg = 2.0;
  const KinematicModel m =
      makeKinematicModel(arm, 1, FrameSharing::kKnown, FrameSharing::kKnown, {Eigen::Isometry3d::Identity()},
                         {Eigen::Isometry3d::Identity()}, {parseEffect("link_bending:1", 2, "test")}, false);
  const double EI = 2.0e5, L = 0.8, F = 5.0 * 9.80665, P = 1.0 * 9.80665, a = 0.4;
  Eigen::VectorXd p(1);
  p << 1.0 / EI;
  JointSample s;
  s.q_rad = Eigen::Vector2d(0.7, -1.1);
  const Eigen::Isometry3d bent = flangePose(m, p, s), straight = forwardKinematics(arm, s.q_rad);
  const Eigen::Vector3d drop = bent.translation() - straight.translation();
  CHECK(drop.z() == Approx(-(F * L * L * L / 3.0 + P * a * a * (3.0 * L - a) / 6.0) / EI).epsilon(1e-12));
  CHECK(drop.head<2>().norm() < 1e-15);
  // The tilt: about the horizontal axis across the beam, u x F (the far end dips).
  const Eigen::Vector3d tilt = logSO3(straight.linear().transpose() * bent.linear());
  CHECK(tilt.norm() == Approx((F * L * L + P * a * a) / (2.0 * EI)).epsilon(1e-12));
  const Eigen::Vector3d u(std::cos(0.7), std::sin(0.7), 0.0);
  CHECK((straight.linear() * tilt).normalized().dot(u.cross(Eigen::Vector3d(0, 0, -1))) == Approx(1.0).epsilon(1e-12));
  checkJacobian(m, s, p);
}
