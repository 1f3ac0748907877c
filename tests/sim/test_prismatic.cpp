// Prismatic joints: forward kinematics of a robot YAML (modified and standard DH) and of a URDF (the
// mobile manipulator of scenes/, a torso lift + a 7-DOF arm) against homogeneous transforms built here
// by hand from the files' numbers; the identification, manipulator and model Jacobians against central
// differences; parameter names and units; the robot file's keys and its round trip.
#include <catch2/catch.hpp>
#include <random>

#include "orbcal/sim/joint_limits.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/gravity.hpp"
#include "orbcal/sim/ik.hpp"
#include "orbcal/sim/identifiability.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/jacobian.hpp"
#include "orbcal/sim/measured.hpp"
#include "orbcal/sim/model.hpp"
#include "orbcal/sim/se3.hpp"
#include "jacobian_check.hpp"
#include "test_util.hpp"

using namespace orbcal::sim;

namespace {

// Hand-built elementary transforms (4 x 4), written out rather than taken from orbcal's se3 or DH code.
Eigen::Matrix4d Rx(double a) {
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T(1, 1) = std::cos(a), T(1, 2) = -std::sin(a), T(2, 1) = std::sin(a), T(2, 2) = std::cos(a);
  return T;
}
Eigen::Matrix4d Rz(double a) {
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T(0, 0) = std::cos(a), T(0, 1) = -std::sin(a), T(1, 0) = std::sin(a), T(1, 1) = std::cos(a);
  return T;
}
Eigen::Matrix4d Tr(double x, double y, double z) {
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T(0, 3) = x, T(1, 3) = y, T(2, 3) = z;
  return T;
}

// A three-joint arm whose middle joint slides: revolute, prismatic (d = 0.2 m + q, theta fixed at
// 90 deg), revolute; limits of the slide in metres.
const char* kSliderYaml = R"(name: slider
convention: CONVENTION
joints:
  - {a_m: 0, alpha_deg: 0, d_m: 0.3, theta_offset_deg: 0, min_deg: -170, max_deg: 170}
  - {type: prismatic, a_m: 0.1, alpha_deg: -90, d_m: 0.2, theta_offset_deg: 90, min_m: 0, max_m: 0.5}
  - {a_m: 0.4, alpha_deg: 30, d_m: 0.05, theta_offset_deg: 0, min_deg: -170, max_deg: 170}
tool: {xyz_m: [0.1, 0, 0.02], rpy_deg: [0, 0, 0]}
)";

Arm sliderArm(const std::string& convention) {
  const std::string path = orbcal::test::tempPath("slider_" + convention + ".yaml");
  orbcal::test::write(path, orbcal::test::edited(kSliderYaml, "CONVENTION", convention));
  return loadArm(path);
}

/// The slider's flange pose from its table, by hand: modified DH Rx(alpha) Tx(a) Rz(theta) Tz(d), or
/// standard DH Rz(theta) Tz(d) Tx(a) Rx(alpha), with q added to theta (revolute) or d (prismatic).
Eigen::Matrix4d sliderByHand(bool modified, const Eigen::Vector3d& q) {
  const double deg = kPi / 180.0;
  const double a[] = {0, 0.1, 0.4}, alpha[] = {0, -90 * deg, 30 * deg};
  const double d[] = {0.3, 0.2 + q[1], 0.05}, theta[] = {q[0], 90 * deg, q[2]};
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  for (int i = 0; i < 3; ++i) {
    T = T * (modified ? Eigen::Matrix4d(Rx(alpha[i]) * Tr(a[i], 0, 0) * Rz(theta[i]) * Tr(0, 0, d[i]))
                      : Eigen::Matrix4d(Rz(theta[i]) * Tr(0, 0, d[i]) * Tr(a[i], 0, 0) * Rx(alpha[i])));
  }
  return T * Tr(0.1, 0, 0.02);
}

/// scenes/mobile_manipulator.urdf's base_link_T_iiwa_link_ee by hand: the torso lift (origin z 0.35 m,
/// slide along z), the arm mount (0.1, 0, 0.45), the arm's joint origins (rpy (r, 0, y) = Rz(y) Rx(r))
/// each followed by Rz(q_i), the flange 0.126 m along z.
Eigen::Matrix4d mobileByHand(const Eigen::VectorXd& q) {
  const double h = kPi / 2;
  Eigen::Matrix4d T = Tr(0, 0, 0.35) * Tr(0, 0, q[0]) * Tr(0.1, 0, 0.45);
  const Eigen::Matrix4d origins[] = {Eigen::Matrix4d::Identity(), Tr(0, 0, 0.34) * Rx(-h), Rz(kPi) * Rx(-h), Tr(0, 0, 0.4) * Rx(-h),
                                     Rz(kPi) * Rx(-h), Tr(0, 0, 0.4) * Rx(-h), Rx(h)};
  for (int i = 0; i < 7; ++i) T = T * origins[i] * Rz(q[i + 1]);
  return T * Tr(0, 0, 0.126);
}

Arm mobileArm() { return loadArm(orbcal::test::sourcePath("scenes/mobile_manipulator.urdf")); }

// Poses built two ways agree to round-off of a few products of unit-size matrices on a ~2 m arm.
constexpr double kPoseTol = 1e-12;

/// Pose error of T against T0: in the tool frame (poseMinus), or in the base frame [dp; log(R R0^T)].
Eigen::VectorXd poseError(const Eigen::Isometry3d& T, const Eigen::Isometry3d& T0, ErrorFrame frame) {
  if (frame == ErrorFrame::kTool) return poseMinus(T, T0);
  Eigen::VectorXd e(6);
  e << T.translation() - T0.translation(), logSO3(T.linear() * T0.linear().transpose());
  return e;
}

/// The identification Jacobian (both frames) and the manipulator Jacobian at q against central
/// differences (tests/jacobian_check.hpp), parameters and joint values in units of 1 (rad, m).
void checkJacobians(const Arm& arm, const Eigen::VectorXd& q) {
  const Eigen::Isometry3d T0 = forwardKinematics(arm, q);
  for (ErrorFrame frame : {ErrorFrame::kTool, ErrorFrame::kBase}) {
    const auto f = [&](const Eigen::VectorXd& y) { return poseError(forwardKinematics(withErrors(arm, y), q), T0, frame); };
    const double largest = orbcal::test::requireJacobianMatches(f, identificationJacobian(arm, q, frame), Eigen::VectorXd::Zero(arm.numParams()),
                                                                Eigen::VectorXd::Ones(arm.numParams()), [&](int c) { return paramName(arm, c); });
    REQUIRE(largest > 0.5);  // a harness returning zeros must not pass
  }
  const auto g = [&](const Eigen::VectorXd& x) { return poseError(forwardKinematics(arm, x), T0, ErrorFrame::kBase); };
  orbcal::test::requireJacobianMatches(g, manipulatorJacobian(arm, q), q, Eigen::VectorXd::Ones(q.size()),
                                       [](int c) { return "q" + std::to_string(c + 1); });
}

}  // namespace

TEST_CASE("a prismatic joint in a robot YAML moves d: FK against hand-built transforms", "[sim][prismatic]") {
  for (const char* convention : {"modified", "standard"}) {
    const Arm arm = sliderArm(convention);
    REQUIRE(arm.isPrismatic(1));
    REQUIRE_FALSE(arm.isPrismatic(0));
    CHECK(arm.lower_rad[1] == 0.0);  // metres, not degrees converted
    CHECK(arm.upper_rad[1] == 0.5);
    for (const Eigen::VectorXd& q : orbcal::test::randomConfigs(arm, 10, 5)) {
      CAPTURE(convention, q.transpose());
      const Eigen::Matrix4d expected = sliderByHand(std::string(convention) == "modified", q);
      CHECK((forwardKinematics(arm, q).matrix() - expected).cwiseAbs().maxCoeff() < kPoseTol);
    }
    // The slide moves the flange by exactly its travel, along z of the joint's frame.
    Eigen::VectorXd q0 = Eigen::VectorXd::Zero(3), q1 = q0;
    q1[1] = 0.25;
    CHECK((forwardKinematics(arm, q1).translation() - forwardKinematics(arm, q0).translation()).norm() == Approx(0.25).epsilon(1e-12));
  }
}

TEST_CASE("a URDF prismatic joint slides along its axis: FK against hand-built transforms", "[sim][prismatic][urdf]") {
  const Arm arm = mobileArm();
  REQUIRE(arm.numJoints() == 8);
  REQUIRE(arm.isPrismatic(0));
  CHECK(arm.urdf.joint_names[0] == "torso_lift_joint");
  CHECK(arm.lower_rad[0] == 0.0);
  CHECK(arm.upper_rad[0] == 0.4);
  for (const Eigen::VectorXd& q : orbcal::test::randomConfigs(arm, 10, 6)) {
    CAPTURE(q.transpose());
    CHECK((forwardKinematics(arm, q).matrix() - mobileByHand(q)).cwiseAbs().maxCoeff() < kPoseTol);
  }
}

TEST_CASE("identification and manipulator Jacobians of prismatic joints match central differences", "[sim][prismatic][jacobian]") {
  std::mt19937_64 rng(21);
  std::normal_distribution<double> n01;
  for (const Arm& nominal : {sliderArm("modified"), sliderArm("standard"), mobileArm()}) {
    // At the nominal parameters and away from them (0.5 deg, 5 mm: where iterated estimators re-linearise).
    Eigen::VectorXd y(nominal.numParams());
    for (int i = 0; i < y.size(); ++i) y[i] = n01(rng) * (isAngleParam(nominal, i) ? 0.5 * kDegToRad : 0.005);
    for (const Arm& arm : {nominal, withErrors(nominal, y)}) {
      for (const Eigen::VectorXd& q : orbcal::test::randomConfigs(arm, 6, 22)) {
        CAPTURE(arm.name);
        checkJacobians(arm, q);
      }
    }
  }
}

TEST_CASE("the kinematic model's Jacobian holds with a prismatic joint (geometry, frames, thermal)", "[sim][prismatic][model]") {
  const Arm arm = mobileArm();
  const KinematicModel m = makeKinematicModel(arm, 1, FrameSharing::kShared, FrameSharing::kShared,
                                              {fromXyzRpy({1.5, -0.4, 0.2}, Eigen::Vector3d(10, -20, 60) * kDegToRad)},
                                              {fromXyzRpy({0.02, 0.01, 0.05}, Eigen::Vector3d(5, 0, 30) * kDegToRad)}, {Thermal{}});
  std::mt19937_64 rng(23);
  std::normal_distribution<double> n01;
  for (const Eigen::VectorXd& q : orbcal::test::randomConfigs(arm, 4, 24)) {
    JointSample s;
    s.q_rad = q;
    s.temperature_C = 35.0;
    Eigen::VectorXd p(m.layout.size());
    for (int i = 0; i < p.size(); ++i) p[i] = n01(rng) * m.layout.typical()[i];
    Eigen::MatrixXd J, J_q;
    const Eigen::Isometry3d T = predictMarkerPose(m, p, s, &J, &J_q);
    const auto f = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd { return poseMinus(predictMarkerPose(m, x, s), T); };
    const double largest = orbcal::test::requireJacobianMatches(f, J, p, m.layout.typical(), [&](int c) { return m.layout.param(c).name; });
    REQUIRE(largest > 1e-4);
    // The joint readings: the torso's column is a translation (1 m of lift: 1 m of motion, no rotation).
    const auto g = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd {
      JointSample t = s;
      t.q_rad = x;
      return poseMinus(predictMarkerPose(m, p, t), T);
    };
    orbcal::test::requireJacobianMatches(g, J_q, q, Eigen::VectorXd::Constant(q.size(), 0.01), [](int c) { return "q" + std::to_string(c + 1); });
    CHECK(J_q.col(0).head<3>().norm() == Approx(1.0).epsilon(0.01));  // thermal scales lengths, not the reading
    CHECK(J_q.col(0).tail<3>().norm() < 1e-12);
  }
}

TEST_CASE("a prismatic joint's zero offset is a length: names, units, error tables", "[sim][prismatic]") {
  const Arm urdf = mobileArm();
  const int offset = jointParamIndex(urdf, 0);
  CHECK(offset == paramIndex(urdf, 0, kTheta));
  CHECK(paramName(urdf, offset) == "d1");
  CHECK_FALSE(isAngleParam(urdf, offset));
  CHECK(paramName(urdf, jointParamIndex(urdf, 1)) == "theta2");
  CHECK(isAngleParam(urdf, jointParamIndex(urdf, 1)));
  const ParamBlock g = geometryBlock(urdf);
  CHECK(g.params[static_cast<std::size_t>(offset)].display_unit == "mm");
  CHECK(g.params[static_cast<std::size_t>(jointParamIndex(urdf, 1))].display_unit == "deg");

  const Arm dh = sliderArm("modified");
  CHECK(jointParamIndex(dh, 1) == paramIndex(dh, 1, kD));
  CHECK(jointParamIndex(dh, 0) == paramIndex(dh, 0, kTheta));
  CHECK(paramName(dh, jointParamIndex(dh, 1)) == "d2");

  // A zero-offset error of 3 mm on the torso moves the flange by 3 mm along the lift axis.
  Eigen::VectorXd y = Eigen::VectorXd::Zero(urdf.numParams());
  y[offset] = 0.003;
  const Eigen::VectorXd q = orbcal::test::randomConfigs(urdf, 1, 25)[0];
  const Eigen::Vector3d moved = forwardKinematics(withErrors(urdf, y), q).translation() - forwardKinematics(urdf, q).translation();
  CHECK((moved - Eigen::Vector3d(0, 0, 0.003)).norm() < 1e-12);
}

TEST_CASE("a joint value is labelled and scaled by its type: columns, labels, effort, messages", "[sim][prismatic]") {
  const Arm arm = mobileArm();  // joint 1 the torso (prismatic), joint 2 the arm's first (revolute)
  CHECK(jointEdgeColumn(arm, 0) == "q1_mm");
  CHECK(jointEdgeColumn(arm, 1) == "q2_deg");
  CHECK(jointEdgeLabel(arm, 0) == "joint 1 position (mm)");
  CHECK(jointEdgeLabel(arm, 1) == "joint 2 angle (deg)");
  CHECK(jointEffortColumn(arm, 0) == "tau1_N");
  CHECK(jointEffortLabel(arm, 1) == "joint 2 torque (N m)");
  CHECK(jointSiUnit(arm, 0) == std::string("m"));
  CHECK(jointSiUnit(arm, 1) == std::string("rad"));
  CHECK(formatJointValue(arm, 0, 0.25) == "250 mm");
  CHECK(formatJointValue(arm, 1, kPi / 2) == "90 deg");
  // An image dataset's reading beyond the torso's 0-0.4 m travel, in m and mm (not rad and deg).
  std::string csv = "index,image";
  for (int j = 1; j <= arm.numJoints(); ++j) csv += ",q" + std::to_string(j) + "_rad";
  csv += "\n0,a.png,0.5";
  for (int j = 2; j <= arm.numJoints(); ++j) csv += ",0";
  CHECK_THROWS_WITH(parseSamplesCsv(csv + "\n", "mine.csv", arm.numJoints(), &arm),
                    "mine.csv: line 2: q1_rad: 0.5 m (500 mm) is outside the joint limits [0, 400] mm of " + arm.source +
                        " by more than 2% of the joint's range (8 mm)");
  // 5 mm past the travel (within 2% of it, 8 mm): accepted with a warning naming the joint and the excess.
  const std::vector<DatasetSample> near =
      parseSamplesCsv(csv.substr(0, csv.find(",0.5")) + ",0.405" + csv.substr(csv.find(",0.5") + 4) + "\n", "mine.csv", arm.numJoints(), &arm);
  REQUIRE(near.size() == 1);
  const std::vector<std::string> warnings = nearLimitWarnings(arm, {near[0].q_rad});
  REQUIRE(warnings.size() == 1);
  CHECK_THAT(warnings[0], Catch::Contains("joint 1 (") && Catch::Contains("past its upper limit 400 mm") && Catch::Contains("by up to 5 mm"));
  // A configurations file (SI) names the torso's column q1_m, and reads back.
  const std::vector<Eigen::VectorXd> qs = orbcal::test::randomConfigs(arm, 3, 7);
  const std::string configs = formatConfigurationsCsv(qs, &arm);
  CHECK(configs.rfind("index,q1_m,q2_rad,", 0) == 0);
  CHECK(parseConfigurationsCsv(configs, "c.csv", arm.numJoints()) == qs);
  // A joint box beyond the torso's travel is named in mm.
  const Eigen::VectorXd lo = Eigen::VectorXd::Constant(arm.numJoints(), 0.5), hi = Eigen::VectorXd::Constant(arm.numJoints(), 0.6);
  CHECK_THROWS_WITH(withJointBox(arm, lo, hi, "box"), "box: joint 1: the box 500..600 mm leaves no travel within the robot's limits 0..400 mm");
}

TEST_CASE("identifiability: a URDF slide's offset is redundant with its origin's position along the axis", "[sim][prismatic]") {
  // Trans(axis (d + q)) after T(xyz): d and z (the axis is z) move the chain the same way.
  const Arm arm = mobileArm();
  const IdentifiabilityReport r = analyzeIdentifiability(arm, orbcal::test::randomConfigs(arm, 60, 26));
  bool found = false;
  for (const Redundancy& g : r.redundancies) {
    const bool has_d1 = std::find(g.names.begin(), g.names.end(), "d1") != g.names.end();
    const bool has_z1 = std::find(g.names.begin(), g.names.end(), "z1") != g.names.end();
    found = found || (has_d1 && has_z1);
  }
  CHECK(found);
  CHECK(r.rank < arm.numParams());
}

TEST_CASE("robot YAML: prismatic joints round-trip, wrong limit keys are one-line errors", "[sim][prismatic][io]") {
  for (const Arm& arm : {sliderArm("standard"), mobileArm()}) {
    CAPTURE(arm.name);
    const std::string path = orbcal::test::tempPath("prismatic_back.yaml");
    orbcal::test::write(path, formatArm(arm, "written by a test"));
    const Arm back = loadArm(path);
    REQUIRE(back.numJoints() == arm.numJoints());
    for (int j = 0; j < arm.numJoints(); ++j) CHECK(back.isPrismatic(j) == arm.isPrismatic(j));
    CHECK(back.lower_rad == arm.lower_rad);
    CHECK(back.upper_rad == arm.upper_rad);
    const Eigen::VectorXd q = orbcal::test::randomConfigs(arm, 1, 27)[0];
    CHECK((forwardKinematics(back, q).matrix() - forwardKinematics(arm, q).matrix()).cwiseAbs().maxCoeff() < kPoseTol);
  }
  const std::string bad = orbcal::test::tempPath("slider_bad.yaml");
  orbcal::test::write(bad, orbcal::test::edited(orbcal::test::edited(kSliderYaml, "CONVENTION", "modified"), "min_m: 0, max_m: 0.5",
                                                "min_deg: 0, max_deg: 0.5"));
  const std::string msg = orbcal::test::inputError([&] { loadArm(bad); });
  CHECK_THAT(msg, Catch::Contains(bad));
  CHECK_THAT(msg, Catch::Contains("min_deg"));
  CHECK_THAT(msg, Catch::Contains("prismatic"));
  CHECK(msg.find('\n') == std::string::npos);
  const std::string typo = orbcal::test::tempPath("slider_typo.yaml");
  orbcal::test::write(typo, orbcal::test::edited(orbcal::test::edited(kSliderYaml, "CONVENTION", "modified"), "type: prismatic", "type: linear"));
  CHECK_THAT(orbcal::test::inputError([&] { loadArm(typo); }), Catch::Contains("expected 'revolute' or 'prismatic', got 'linear'"));
}

TEST_CASE("joint effects on a prismatic joint: lengths, their Jacobians, a lead screw's period", "[sim][prismatic][model]") {
  const Arm arm = mobileArm();
  const std::vector<Effect> effects = {Scale{{0}}, Backlash{{0}}, Cyclic{{0}, 2}, Compliance{{0}}, Scale{{2}}};
  const KinematicModel m = makeKinematicModel(arm, 1, FrameSharing::kShared, FrameSharing::kShared, {Eigen::Isometry3d::Identity()},
                                              {fromXyzRpy({0.02, 0.01, 0.05}, Eigen::Vector3d(5, 0, 30) * kDegToRad)}, effects);
  std::mt19937_64 rng(28);
  std::normal_distribution<double> n01;
  for (const Eigen::VectorXd& q : orbcal::test::randomConfigs(arm, 4, 29)) {
    JointSample s;
    s.q_rad = q;
    s.tau_Nm = Eigen::VectorXd::Constant(arm.numJoints(), 20.0);
    s.tau_Nm[0] = 400.0;  // N: the torso carries ~40 kg
    s.direction = Eigen::VectorXd::Constant(arm.numJoints(), 1.0);
    Eigen::VectorXd p(m.layout.size());
    for (int i = 0; i < p.size(); ++i) p[i] = n01(rng) * m.layout.typical()[i];
    Eigen::MatrixXd J;
    const Eigen::Isometry3d T = predictMarkerPose(m, p, s, &J);
    const auto f = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd { return poseMinus(predictMarkerPose(m, x, s), T); };
    REQUIRE(orbcal::test::requireJacobianMatches(f, J, p, m.layout.typical(), [&](int c) { return m.layout.param(c).name; }) > 1e-6);
  }
  // Units: the torso's backlash and cyclic amplitudes are lengths, its compliance m/N.
  for (const ParamBlock& b : m.layout.blocks()) {
    if (b.joints != std::vector<int>{0}) continue;
    CAPTURE(b.effect);
    const std::string unit = b.params[0].unit;
    CHECK(unit == (b.effect == "scale" ? "1" : b.effect == "compliance" ? "m/N" : "m"));
  }
  // Defining formulas on the torso: dq = s q + b d + a sin(2 pi q / 5 mm) - c f.
  JointSample s;
  s.q_rad = Eigen::VectorXd::Zero(arm.numJoints());
  s.q_rad[0] = 0.1234;
  s.tau_Nm = Eigen::VectorXd::Zero(arm.numJoints());
  s.tau_Nm[0] = 300.0;
  s.direction = Eigen::VectorXd::Constant(arm.numJoints(), -1.0);
  Eigen::VectorXd p = Eigen::VectorXd::Zero(m.layout.size());
  const auto at = [&](const std::string& name) {
    for (int i = 0; i < m.layout.size(); ++i) {
      if (m.layout.param(i).name == name) return i;
    }
    FAIL("no parameter " << name);
    return -1;
  };
  p[at("s1")] = 1e-3, p[at("b1")] = 2e-5, p[at("cyclic1_sin1")] = 1e-5, p[at("c1")] = 1e-7;
  const double expected = 1e-3 * 0.1234 - 2e-5 + 1e-5 * std::sin(2.0 * kPi * 0.1234 / 0.005) - 1e-7 * 300.0;
  CHECK(jointCorrections(m, p, s)[0] == Approx(expected).epsilon(1e-12));
}

TEST_CASE("effects that do not apply to a prismatic joint are refused, naming the effect and the joint", "[sim][prismatic]") {
  const Arm arm = mobileArm();
  for (const char* spec : {"coupling:1,2", "coupling:3,1"}) {
    CAPTURE(spec);
    const Effect e = parseEffect(spec, arm.numJoints(), "--effects");
    CHECK_FALSE(fitsJointTypes(e, arm));
    const std::string msg = orbcal::test::inputError([&] { effectBlocks(e, arm, 1); });
    CHECK_THAT(msg, Catch::Contains(std::string(spec) + " does not apply to joint 1, a prismatic joint"));
  }
  CHECK(fitsJointTypes(parseEffect("coupling:3,2", arm.numJoints(), "--effects"), arm));
}

TEST_CASE("gravity load of a prismatic joint is the weight above it along its axis", "[sim][prismatic]") {
  const Arm arm = mobileArm();
  // Everything the lift carries: the URDF's link masses after the base (torso 15 kg + the arm's).
  double mass = 0.0;
  for (const LinkMass& l : arm.masses.links) mass += l.mass_kg;
  REQUIRE(mass > 15.0);
  for (const Eigen::VectorXd& q : orbcal::test::randomConfigs(arm, 5, 30)) {
    const Eigen::VectorXd tau = gravityTorques(arm, arm.masses, q);
    CHECK(tau[0] == Approx(mass * 9.80665).epsilon(1e-12));  // the actuator pushes up (axis z, gravity -z)
  }
}

TEST_CASE("IK reaches poses with the torso free, and with it locked", "[sim][prismatic][ik]") {
  const Arm arm = mobileArm();
  for (int locked : {-1, 0, 3}) {
    for (const Eigen::VectorXd& q_true : orbcal::test::randomConfigs(arm, 5, 31 + static_cast<std::uint64_t>(locked))) {
      Eigen::VectorXd q_start = q_true;
      for (int j = 0; j < arm.numJoints(); ++j) {
        if (j != locked) q_start[j] += j == 0 ? 0.05 : 0.2;  // 5 cm of lift, 0.2 rad elsewhere
      }
      IkOptions o;
      o.locked_joint = locked;
      const IkResult r = inverseKinematics(arm, forwardKinematics(arm, q_true), q_start, o);
      CAPTURE(locked, q_true.transpose(), r.q.transpose());
      REQUIRE(r.converged);
      CHECK((forwardKinematics(arm, r.q).matrix() - forwardKinematics(arm, q_true).matrix()).cwiseAbs().maxCoeff() < 1e-9);
      if (locked >= 0) CHECK(r.q[locked] == q_start[locked]);
      CHECK(r.q[0] >= arm.lower_rad[0]);
      CHECK(r.q[0] <= arm.upper_rad[0]);
    }
  }
}

TEST_CASE("measurement descriptions: prismatic_unit is required for an arm with a slide, mm read as mm", "[sim][prismatic][measured]") {
  const std::string dir = orbcal::test::tempDir("prismatic-measured");
  const std::string robot = orbcal::test::sourcePath("scenes/mobile_manipulator.urdf");
  const std::string header = "torso,q1,q2,q3,q4,q5,q6,q7,x,y,z\n";
  orbcal::test::write(dir + "/data.csv", header + "250,10,-20,30,-40,50,-60,70,1000,2000,3000\n");
  const std::string desc = "format: orbcal-measurements-1\nrobot: \"" + robot +
                           "\"\nfiles: [data.csv]\n"
                           "joints: {columns: [torso, q1, q2, q3, q4, q5, q6, q7], unit: deg, prismatic_unit: mm}\n"
                           "pose: {position: [x, y, z], length_unit: mm}\n"
                           "registration: {base: shared, marker: shared}\n";
  orbcal::test::write(dir + "/desc.yaml", desc);
  const MeasuredData d = loadMeasuredData(dir + "/desc.yaml");
  REQUIRE(d.poses.size() == 1);
  CHECK(d.poses[0].sample.q_rad[0] == Approx(0.25).epsilon(1e-15));  // 250 mm of lift
  CHECK(d.poses[0].sample.q_rad[1] == Approx(10.0 * kDegToRad).epsilon(1e-15));

  orbcal::test::write(dir + "/missing.yaml", orbcal::test::edited(desc, ", prismatic_unit: mm", ""));
  const std::string msg = orbcal::test::inputError([&] { loadMeasuredData(dir + "/missing.yaml"); });
  CHECK_THAT(msg, Catch::StartsWith(dir + "/missing.yaml: joints"));
  CHECK_THAT(msg, Catch::Contains("prismatic_unit (m or mm) is required"));

  // A torso reading beyond its 0.4 m: named with the column and the file's unit.
  orbcal::test::write(dir + "/data.csv", header + "450,10,-20,30,-40,50,-60,70,1000,2000,3000\n");
  CHECK_THAT(orbcal::test::inputError([&] { loadMeasuredData(dir + "/desc.yaml"); }),
             Catch::Contains("torso: 450 mm is outside the joint limits [0, 400] mm"));

  // What orbcal writes (SI: q1_m for the slide, prismatic_unit: m) reads back bit for bit.
  MeasuredData w = d;
  w.poses[0].sample.q_rad[0] = 0.123456789012345;
  const std::string back = writeMeasuredData(w, dir + "/written", robot, "measurements.yaml");
  CHECK_THAT(orbcal::test::slurp(back), Catch::Contains("prismatic_unit: m}"));
  CHECK(loadMeasuredData(back).poses[0].sample.q_rad == w.poses[0].sample.q_rad);
}
