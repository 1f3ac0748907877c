// A calibrated model for programs outside orbcal (sim/urdf_export.hpp, sim/export.hpp): the URDF of a
// DH table reloads to the same forward kinematics and gravity torques in every DH convention; the
// frames file holds the frames; the effects file reads back to the same values and joint corrections,
// and its errors name the file and the key.
#include <catch2/catch.hpp>
#include <filesystem>
#include <random>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/export.hpp"
#include "orbcal/sim/gravity.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/sim/urdf.hpp"
#include "orbcal/sim/urdf_export.hpp"
#include "test_util.hpp"

using namespace orbcal::sim;
using orbcal::test::inputError;
using orbcal::test::sourcePath;
using Catch::Matchers::Contains;

namespace {

// Rebuilding a chain from exact decimal origins and RPY angles leaves round-off of ~1e-15 per link;
// a 10 m arm's 7 links stay below 1e-13 m. 1e-9 m and 1e-9 rad: what "the same pose" means for any use.
constexpr double kSamePoseM = 1e-9, kSamePoseRad = 1e-9;

double rotationAngle(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(Eigen::Quaterniond(a.transpose() * b)).angle();
}

/// A sample with every covariate the catalog reads, seeded.
JointSample randomSample(const Arm& arm, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  JointSample s;
  s.q_rad = Eigen::VectorXd::NullaryExpr(arm.numJoints(), [&] { return 2.0 * u(rng); });
  s.tau_Nm = Eigen::VectorXd::NullaryExpr(arm.numJoints(), [&] { return 80.0 * u(rng); });
  s.direction = Eigen::VectorXd::NullaryExpr(arm.numJoints(), [&] { return u(rng) < 0.0 ? -1.0 : 1.0; });
  s.temperature_C = 20.0 + 5.0 * u(rng);
  s.time_s = 3600.0 * (1.0 + u(rng));
  s.session = u(rng) < 0.0 ? 0 : 1;
  return s;
}

}  // namespace

TEST_CASE("a DH table's URDF has the table's forward kinematics and gravity torques", "[sim][urdf][export]") {
  for (const char* file : {"scenes/iiwa7.yaml", "scenes/ssrms.yaml", "scenes/puma_hayati.yaml"}) {
    CAPTURE(file);
    Arm arm = withErrors(loadArm(sourcePath(file)), randomErrors(loadArm(sourcePath(file)), 1e-3, 1e-3, 5));
    // A base and a tool with every component: the URDF must carry both.
    arm.base_T_first = Eigen::Translation3d(0.1, -0.2, 0.3) * Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized());
    arm.last_T_flange = Eigen::Translation3d(-0.01, 0.02, 0.15) * Eigen::AngleAxisd(-0.7, Eigen::Vector3d(3, -1, 2).normalized());
    const Arm back = armFromUrdf(urdfFromDh(arm, "a test -- DH"), "dh.urdf");  // root link to the only leaf
    CHECK(back.urdf.base_link == "base_link");
    CHECK(back.urdf.tip_link == "flange");
    REQUIRE(back.numJoints() == arm.numJoints());
    CHECK(back.urdf.joint_names.front() == "joint1");
    CHECK(back.lower_rad == arm.lower_rad);
    CHECK(back.upper_rad == arm.upper_rad);
    double dp = 0.0, dr = 0.0;
    for (const Eigen::VectorXd& q : orbcal::test::randomConfigs(arm, 50, 17)) {
      const Eigen::Isometry3d a = forwardKinematics(arm, q), b = forwardKinematics(back, q);
      dp = std::max(dp, (a.translation() - b.translation()).norm());
      dr = std::max(dr, rotationAngle(a.linear(), b.linear()));
      if (!arm.masses.empty()) {
        CHECK((gravityTorques(arm, arm.masses, q) - gravityTorques(back, back.masses, q)).norm() < 1e-9);
      }
    }
    CHECK(dp < kSamePoseM);
    CHECK(dr < kSamePoseRad);
  }
}

TEST_CASE("a DH table's URDF with a payload: the payload rides on the flange link", "[sim][urdf][export]") {
  Arm arm = loadArm(sourcePath("scenes/iiwa7.yaml"));
  REQUIRE_FALSE(arm.masses.links.empty());
  arm.masses.payload_kg = 1.25;
  arm.masses.payload_com_flange_m = Eigen::Vector3d(0.01, 0.0, 0.05);
  const Arm back = armFromUrdf(urdfFromDh(arm), "dh.urdf");
  const Eigen::VectorXd q = orbcal::test::randomConfigs(arm, 1, 3).front();
  const Eigen::VectorXd tau = gravityTorques(arm, arm.masses, q);
  CHECK((tau - gravityTorques(back, back.masses, q)).norm() < 1e-9 * tau.norm());
  CHECK(calibratedUrdf(arm) == urdfFromDh(arm));  // no URDF behind the arm: the DH writer
}

TEST_CASE("the frames file: both frames of every session as a matrix and as xyz + quaternion", "[sim][export]") {
  const Arm arm = loadArm(sourcePath("scenes/iiwa7.yaml"));
  const Eigen::Isometry3d base = Eigen::Translation3d(1.5, -0.25, 0.75) * Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ());
  const Eigen::Isometry3d m1 = Eigen::Translation3d(0.0, 0.0, 0.1) * Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitX());
  const Eigen::Isometry3d m2 = Eigen::Translation3d(0.01, 0.0, 0.1) * Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitY());
  const KinematicModel m = makeKinematicModel(arm, 2, FrameSharing::kShared, FrameSharing::kPerSession, {base}, {m1, m2}, {});
  const std::string text = formatFramesFile(m, "a header");
  const ConfigNode root = ConfigNode::parse(text, "frames.yaml");
  CHECK(root["format"].asString() == "orbcal-frames-1");
  CHECK(root["world_T_base"]["sharing"].asString() == "shared");
  REQUIRE(root["world_T_base"]["frames"].size() == 1);
  REQUIRE(root["flange_T_marker"]["frames"].size() == 2);
  const auto check = [](const ConfigNode& f, const Eigen::Isometry3d& T) {
    Eigen::Matrix4d M;
    for (int r = 0; r < 4; ++r) M.row(r) = f["matrix"][static_cast<std::size_t>(r)].asVector(4).transpose();
    CHECK(M == T.matrix());  // numbers written exactly
    const Eigen::VectorXd xyz = f["xyz_m"].asVector(3), q = f["quaternion_xyzw"].asVector(4);
    CHECK((xyz - T.translation()).norm() == 0.0);
    // The quaternion [x, y, z, w] is the matrix's rotation (either sign is the same rotation).
    CHECK(rotationAngle(Eigen::Quaterniond(q[3], q[0], q[1], q[2]).toRotationMatrix(), T.linear()) < 1e-15);
  };
  check(root["world_T_base"]["frames"][0], base);
  CHECK(root["world_T_base"]["frames"][0]["session"].asString() == "all");
  check(root["flange_T_marker"]["frames"][0], m1);
  check(root["flange_T_marker"]["frames"][1], m2);
  CHECK(root["flange_T_marker"]["frames"][1]["session"].asInt() == 2);
  // The x axis of the marker in session 1 is the flange's, its z axis the flange's -y (Rx(90 deg)).
  CHECK(root["flange_T_marker"]["frames"][0]["quaternion_xyzw"].asVector(4).isApprox(Eigen::Vector4d(std::sqrt(0.5), 0, 0, std::sqrt(0.5))));
}

TEST_CASE("the effects file reads back to the same values and the same joint corrections", "[sim][export]") {
  const std::string dir = orbcal::test::tempDir("effects-file");
  const Arm arm = loadArm(sourcePath("tests/data/iiwa7.urdf"));
  std::vector<Effect> effects;
  for (const char* spec : {"compliance:2,4/3", "cyclic:3/3", "scale:1", "backlash:5,6", "coupling:6,5,7,1", "empirical:7,6@-1.5..2",
                           "thermal", "mount"}) {
    effects.push_back(parseEffect(spec, arm.numJoints(), "test"));
  }
  const KinematicModel m = makeKinematicModel(arm, 2, FrameSharing::kKnown, FrameSharing::kKnown, {Eigen::Isometry3d::Identity()},
                                              {Eigen::Isometry3d::Identity()}, effects, false);
  auto rng = makeRng(23);
  std::normal_distribution<double> n(0.0, 1.0);
  const Eigen::VectorXd p = m.layout.typical().unaryExpr([&](double t) { return t * n(rng); });
  orbcal::test::write(dir + "/robot.yaml", formatArm(arm));
  orbcal::test::write(dir + "/effects.yaml", formatEffectsFile(m, p, "robot.yaml", "a test"));
  const std::string text = orbcal::test::slurp(dir + "/effects.yaml");
  CHECK_THAT(text, Contains("joint_name: \"iiwa_joint_4\"") && Contains("dq4 = -(c4 * tau4 + c4_cubic * tau4^3)") &&
                       Contains("dq7 = k7_1 * q1") && Contains("applies_to: chain"));
  const LoadedEffects back = loadEffectsFile(dir + "/effects.yaml");
  REQUIRE(back.model.layout.size() == m.layout.size());
  for (int i = 0; i < m.layout.size(); ++i) {  // the same names in the same order, values written exactly
    CHECK(back.model.layout.param(i).name == m.layout.param(i).name);
    CHECK(back.p[i] == p[i]);
  }
  for (int k = 0; k < 50; ++k) {
    const JointSample s = randomSample(arm, rng);
    const Eigen::VectorXd dq = jointCorrections(m, p, s);
    REQUIRE(dq.cwiseAbs().maxCoeff() > 1e-6);  // the effects move the joints: equal zeros would prove nothing
    // The same terms added in the same order: equal to the last bit.
    CHECK(jointCorrections(back.model, back.p, s) == dq);
    CHECK(flangePose(back.model, back.p, s).isApprox(flangePose(m, p, s), 1e-14));
  }
}

TEST_CASE("effects file errors name the file and the key", "[sim][export]") {
  const std::string dir = orbcal::test::tempDir("effects-errors");
  const Arm arm = loadArm(sourcePath("scenes/iiwa7.yaml"));
  const KinematicModel m = makeKinematicModel(arm, 1, FrameSharing::kKnown, FrameSharing::kKnown, {Eigen::Isometry3d::Identity()},
                                              {Eigen::Isometry3d::Identity()}, {parseEffect("compliance:2", 7, "test")}, false);
  orbcal::test::write(dir + "/robot.yaml", formatArm(arm));
  const std::string good = formatEffectsFile(m, Eigen::VectorXd::Constant(1, 2e-5), "robot.yaml");
  const auto messageFor = [&](const std::string& from, const std::string& to) {
    orbcal::test::write(dir + "/bad.yaml", orbcal::test::edited(good, from, to));
    return inputError([&] { loadEffectsFile(dir + "/bad.yaml"); });
  };
  CHECK_THAT(messageFor("dq2 = -(c2 * tau2)", "dq2 = +(c2 * tau2)"), Contains("bad.yaml") && Contains("effects[0].formula"));
  CHECK_THAT(messageFor("unit: \"rad/(N*m)\"", "unit: \"deg/(N*m)\""), Contains("bad.yaml") && Contains("parameters[0].unit"));
  CHECK_THAT(messageFor("value: " + exactNumber(2e-5), "value: 20"), Contains("bad.yaml") && Contains("parameters[0].value"));
  CHECK_THAT(messageFor("name: \"joint3\"", "name: \"elbow\""), Contains("bad.yaml") && Contains("joints[2].name"));
  CHECK_THAT(messageFor("orbcal-effects-1", "orbcal-effects-7"), Contains("bad.yaml") && Contains("format"));
  CHECK_THAT(messageFor("joint: 2\n", "joint: 3\n"), Contains("bad.yaml") && Contains("effects[0].joint"));
  orbcal::test::write(dir + "/good.yaml", good);
  CHECK(loadEffectsFile(dir + "/good.yaml").p[0] == 2e-5);
}
