// Static gravity torques (sim/gravity.hpp) against virtual work with a numeric COM Jacobian, a hand
// case, the upright iiwa7, and the robot file's `masses:` section (round trip and bad input).
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <fstream>
#include <random>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/gravity.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "test_util.hpp"

using namespace orbcal::sim;

namespace {

// Central differences of COM positions (|c| ~ 1 m) with h = 1e-5 rad: truncation h^2/6 |c'''| ~ 2e-11 m
// and round-off ~ 1e-16 m / h = 1e-11 m per unit q, times m g <= 50 N and 6 bodies: ~ 1e-8 N m at
// worst (measured: 1.0e-9 and 1.2e-9 N m, modified and standard DH). A wrong axis, lever arm, body
// frame or sign errs by O(1..100) N m.
constexpr double kStep = 1e-5;
constexpr double kTorqueTol = 1e-8;

Eigen::Isometry3d pose(const Eigen::Vector3d& xyz, const Eigen::Vector3d& rpy_deg) { return fromXyzRpy(xyz, rpy_deg * kDegToRad); }

/// A 5-joint arm of either convention with every DH entry, the base and the tool nonzero, a mass
/// model with COMs off the link axes, a payload off the flange axis, and tilted gravity.
Arm testArm(DhConvention convention) {
  Arm arm;
  arm.name = "gravity test arm";
  arm.convention = convention;
  arm.base_T_first = pose({0.1, -0.2, 0.3}, {10.0, -20.0, 30.0});
  arm.joints = {{0.05, 0.4, 0.30, 0.1}, {0.45, -1.2, 0.02, -0.3}, {0.40, 0.7, -0.05, 0.2},
                {0.03, 1.5707963267948966, 0.25, 0.0}, {0.01, -1.1, 0.12, 0.5}};
  arm.last_T_flange = pose({0.02, 0.01, 0.08}, {5.0, 15.0, -25.0});
  arm.lower_rad = Eigen::VectorXd::Constant(5, -3.0);
  arm.upper_rad = Eigen::VectorXd::Constant(5, 3.0);
  arm.masses.links = {{4.0, {0.10, -0.02, 0.05}}, {3.0, {-0.20, 0.03, 0.01}}, {2.5, {-0.15, 0.01, -0.04}},
                      {1.2, {0.00, 0.06, 0.02}}, {0.8, {0.01, -0.01, 0.03}}};
  arm.masses.payload_kg = 1.5;
  arm.masses.payload_com_flange_m = Eigen::Vector3d(0.03, -0.04, 0.10);
  arm.masses.gravity_base = Eigen::Vector3d(0.3, -0.2, -9.81);
  return arm;
}

/// Every mass point (mass, position in the base frame) at q: link i's COM in its body frame (frame i,
/// chainFrames[i + 1], in both conventions) and the payload in the flange frame.
std::vector<std::pair<double, Eigen::Vector3d>> massPoints(const Arm& arm, const Eigen::VectorXd& q) {
  const auto frames = chainFrames(arm, q);
  std::vector<std::pair<double, Eigen::Vector3d>> points;
  for (int i = 0; i < arm.numJoints(); ++i) {
    const LinkMass& l = arm.masses.links[static_cast<std::size_t>(i)];
    points.emplace_back(l.mass_kg, frames[static_cast<std::size_t>(i + 1)] * l.com_m);
  }
  points.emplace_back(arm.masses.payload_kg, frames.back() * arm.masses.payload_com_flange_m);
  return points;
}

/// Virtual work: holding torque tau = dV/dq with V = -sum m g . c, i.e. tau = -sum J_c^T (m g), with the
/// COM Jacobians J_c by central differences. Independent of any joint axis or sign convention.
Eigen::VectorXd virtualWorkTorques(const Arm& arm, const Eigen::VectorXd& q) {
  const Eigen::Vector3d& g = arm.masses.gravity_base;
  Eigen::VectorXd tau = Eigen::VectorXd::Zero(arm.numJoints());
  for (int j = 0; j < arm.numJoints(); ++j) {
    Eigen::VectorXd qp = q, qm = q;
    qp[j] += kStep;
    qm[j] -= kStep;
    const auto plus = massPoints(arm, qp), minus = massPoints(arm, qm);
    for (std::size_t k = 0; k < plus.size(); ++k) {
      const Eigen::Vector3d dc_dq = (plus[k].second - minus[k].second) / (2.0 * kStep);
      tau[j] -= dc_dq.dot(plus[k].first * g);
    }
  }
  return tau;
}

/// A one-joint arm: joint axis along `axis_base` (horizontal), link COM at L along the link's x.
Arm singleLink(DhConvention convention, const Eigen::Matrix3d& base_rotation, double mass, double L) {
  Arm arm;
  arm.convention = convention;
  arm.base_T_first.linear() = base_rotation;
  arm.joints = {DhRow{}};
  arm.lower_rad = Eigen::VectorXd::Constant(1, -3.0);
  arm.upper_rad = Eigen::VectorXd::Constant(1, 3.0);
  arm.masses.links = {{mass, Eigen::Vector3d(L, 0.0, 0.0)}};
  arm.masses.gravity_base = Eigen::Vector3d(0.0, 0.0, -9.81);
  return arm;
}

using orbcal::test::inputError;
using orbcal::test::write;

}  // namespace

TEST_CASE("gravity torques equal virtual work with numeric COM Jacobians (both DH conventions)", "[sim][gravity]") {
  for (const DhConvention convention : {DhConvention::kModified, DhConvention::kStandard}) {
    const Arm arm = testArm(convention);
    std::mt19937_64 rng(convention == DhConvention::kModified ? 21 : 22);
    std::uniform_real_distribution<double> angle(-3.0, 3.0);
    double worst = 0.0;
    for (int k = 0; k < 10; ++k) {
      const Eigen::VectorXd q = Eigen::VectorXd::NullaryExpr(5, [&] { return angle(rng); });
      const Eigen::VectorXd tau = gravityTorques(arm, arm.masses, q);
      const Eigen::VectorXd tau_vw = virtualWorkTorques(arm, q);
      CAPTURE(convention == DhConvention::kModified, q.transpose(), tau.transpose(), tau_vw.transpose());
      REQUIRE(tau_vw.norm() > 1.0);  // a harness returning zeros must not pass
      CHECK((tau - tau_vw).cwiseAbs().maxCoeff() < kTorqueTol);
      worst = std::max(worst, (tau - tau_vw).cwiseAbs().maxCoeff());
    }
    INFO("worst difference " << worst << " N m");
    CHECK(worst < kTorqueTol);
  }
}

TEST_CASE("gravity torques: a horizontal link held about a horizontal axis", "[sim][gravity]") {
  const double m = 2.0, L = 0.5, g = 9.81;
  // Base rotations putting joint 1's axis (z of frame 0 in standard DH, of frame 1 in modified DH:
  // both the rotated base z at q = 0 here, as the row is all zero) along -y or +y; link x stays +x.
  const Eigen::Matrix3d axis_minus_y = Eigen::AngleAxisd(0.5 * kPi, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Matrix3d axis_plus_y = Eigen::AngleAxisd(-0.5 * kPi, Eigen::Vector3d::UnitX()).toRotationMatrix();
  REQUIRE((axis_minus_y.col(2) - Eigen::Vector3d(0, -1, 0)).norm() < 1e-15);
  REQUIRE((axis_plus_y.col(2) - Eigen::Vector3d(0, 1, 0)).norm() < 1e-15);
  const Eigen::VectorXd q0 = Eigen::VectorXd::Zero(1);
  for (const DhConvention convention : {DhConvention::kModified, DhConvention::kStandard}) {
    CAPTURE(convention == DhConvention::kModified);
    // Axis -y: positive q turns x towards +z, lifting the COM, so holding it takes a positive torque
    // of m g L (a joint torque sensor reads +m g L).
    const Arm lift = singleLink(convention, axis_minus_y, m, L);
    CHECK(gravityTorques(lift, lift.masses, q0)[0] == Approx(m * g * L).epsilon(1e-14));
    // Axis +y: positive q lowers the COM; the hold is -m g L.
    const Arm lower = singleLink(convention, axis_plus_y, m, L);
    CHECK(gravityTorques(lower, lower.masses, q0)[0] == Approx(-m * g * L).epsilon(1e-14));
    // Turned 60 deg up, the lever arm is L cos 60.
    CHECK(gravityTorques(lift, lift.masses, Eigen::VectorXd::Constant(1, kPi / 3))[0] == Approx(0.5 * m * g * L));
    // Straight up: nothing to hold.
    CHECK(std::abs(gravityTorques(lift, lift.masses, Eigen::VectorXd::Constant(1, 0.5 * kPi))[0]) < 1e-14);
    // The same mass as a payload at the flange, with the flange at L along x: the same torque.
    Arm payload = lift;
    payload.masses.links = {LinkMass{}};
    payload.last_T_flange.translation() = Eigen::Vector3d(L, 0.0, 0.0);
    payload.masses.payload_kg = m;
    CHECK(gravityTorques(payload, payload.masses, q0)[0] == Approx(m * g * L).epsilon(1e-14));
    // No mass model: no torque.
    CHECK(gravityTorques(lift, MassModel{}, q0).norm() == 0.0);
  }
}

TEST_CASE("gravity torques of the iiwa7: a vertical first axis carries nothing, upright holds almost nothing",
          "[sim][gravity]") {
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/iiwa7.yaml"));
  REQUIRE(arm.masses.links.size() == 7);
  double total = 0.0;
  for (const LinkMass& l : arm.masses.links) total += l.mass_kg;
  CHECK(total == Approx(15.2233));
  // Upright (q = 0): the COMs' offsets from the axis line are along the horizontal axes 2, 4, 6
  // (base y), so only link 5's 0.1 mm x offset leaves a torque (~1.7 mN m).
  const Eigen::VectorXd up = gravityTorques(arm, arm.masses, Eigen::VectorXd::Zero(7));
  CAPTURE(up.transpose());
  CHECK(std::abs(up[0]) < 1e-12);
  CHECK(up.cwiseAbs().maxCoeff() < 0.01);
  // Joint 1's axis is vertical, so gravity has no moment about it in any pose.
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> angle(-2.0, 2.0);
  for (int k = 0; k < 10; ++k) {
    const Eigen::VectorXd q = Eigen::VectorXd::NullaryExpr(7, [&] { return angle(rng); });
    const Eigen::VectorXd tau = gravityTorques(arm, arm.masses, q);
    CAPTURE(q.transpose(), tau.transpose());
    CHECK(std::abs(tau[0]) < 1e-12);
    CHECK(tau.norm() > 1.0);
  }
  // Shoulder at 90 deg (the arm horizontal along base +x): joint 2 holds the whole outboard mass,
  // 12.5 kg with its COM about 0.43 m from the shoulder: ~ 53 N m.
  Eigen::VectorXd q = Eigen::VectorXd::Zero(7);
  q[1] = 0.5 * kPi;
  const Eigen::VectorXd flat = gravityTorques(arm, arm.masses, q);
  CAPTURE(flat.transpose());
  CHECK(std::abs(flat[1]) > 40.0);
  CHECK(std::abs(flat[1]) < 60.0);
  CHECK(std::abs(flat[0]) < 1e-12);
}

TEST_CASE("robot files: the masses section round-trips exactly", "[sim][gravity][io]") {
  const std::string dir = orbcal::test::tempDir("robot-masses");
  // The shipped iiwa7 file.
  const Arm iiwa = loadArm(orbcal::test::sourcePath("scenes/iiwa7.yaml"));
  const std::string iiwa_text = formatArm(iiwa, "round trip");
  CHECK(iiwa_text.find("masses:") != std::string::npos);
  write(dir + "/iiwa.yaml", iiwa_text);
  const Arm iiwa_back = loadArm(dir + "/iiwa.yaml");
  orbcal::test::checkSameMasses(iiwa_back.masses, iiwa.masses);

  // Numbers without a short decimal form, a payload and tilted gravity.
  Arm arm = testArm(DhConvention::kStandard);
  arm.masses.links[1].mass_kg = 1.0 / 3.0;
  arm.masses.links[2].com_m = Eigen::Vector3d(1e-17, -2.0 / 7.0, 0.1 + 0.2);
  arm.masses.payload_kg = 0.7;
  arm.masses.payload_com_flange_m = Eigen::Vector3d(std::sqrt(2.0), 0.0, -1e-3);
  arm.masses.gravity_base = Eigen::Vector3d(0.1, std::nextafter(-0.2, 0.0), -9.8);
  write(dir + "/arm.yaml", formatArm(arm));
  const Arm back = loadArm(dir + "/arm.yaml");
  REQUIRE(back.masses.links.size() == arm.masses.links.size());
  for (std::size_t i = 0; i < arm.masses.links.size(); ++i) {
    CHECK(back.masses.links[i].mass_kg == arm.masses.links[i].mass_kg);
    CHECK(back.masses.links[i].com_m == arm.masses.links[i].com_m);
  }
  CHECK(back.masses.payload_kg == arm.masses.payload_kg);
  CHECK(back.masses.payload_com_flange_m == arm.masses.payload_com_flange_m);
  CHECK(back.masses.gravity_base == arm.masses.gravity_base);
  const Eigen::VectorXd q = Eigen::VectorXd::LinSpaced(5, -1.0, 1.5);
  // Base and tool go through rpy angles, exact only to rounding: the torques agree to ~1e-14 N m.
  CHECK((gravityTorques(back, back.masses, q) - gravityTorques(arm, arm.masses, q)).cwiseAbs().maxCoeff() < 1e-12);

  // A payload-only model (no links) and a file without the section.
  Arm payload_only = arm;
  payload_only.masses.links.clear();
  write(dir + "/payload.yaml", formatArm(payload_only));
  const Arm payload_back = loadArm(dir + "/payload.yaml");
  CHECK(payload_back.masses.links.empty());
  CHECK(payload_back.masses.payload_kg == 0.7);
  const Arm ssrms = loadArm(orbcal::test::sourcePath("scenes/ssrms.yaml"));
  CHECK(ssrms.masses.empty());
  CHECK(formatArm(ssrms).find("masses") == std::string::npos);
}

TEST_CASE("robot files: a bad masses section names the file and the key", "[sim][gravity][io][badinput]") {
  const std::string dir = orbcal::test::tempDir("robot-masses-bad");
  const std::string f = dir + "/robot.yaml";
  const std::string good = orbcal::test::slurp(orbcal::test::sourcePath("scenes/iiwa7.yaml"));
  const auto with = [&](const std::string& from, const std::string& to) {
    std::string t = good;
    const auto at = t.find(from);
    REQUIRE(at != std::string::npos);
    write(f, t.replace(at, from.size(), to));
  };
  const std::string link3 = "    - {mass_kg: 3.175,  com_m: [0, 0.0890, -0.0296]}";

  with("  links:", "  linkz:");
  CHECK_THAT(inputError([&] { loadArm(f); }),
             Catch::StartsWith(f + ": masses.linkz: unknown key (expected one of: gravity_m_s2, links, payload)"));
  with(link3, "    - {mass_kg: 3.175,  com: [0, 0.0890, -0.0296]}");
  CHECK_THAT(inputError([&] { loadArm(f); }), Catch::StartsWith(f + ": masses.links[2].com: unknown key"));
  with(link3, "");
  CHECK(inputError([&] { loadArm(f); }) == f + ": masses.links: expected one entry per joint (7), got 6");
  with(link3, link3 + "\n" + link3);
  CHECK(inputError([&] { loadArm(f); }) == f + ": masses.links: expected one entry per joint (7), got 8");
  with("mass_kg: 3.175,", "mass_kg: -3.175,");
  CHECK(inputError([&] { loadArm(f); }) == f + ": masses.links[2].mass_kg: '-3.175' is outside 0 kg to 1e6 kg");
  with("mass_kg: 3.175,", "mass_kg: .inf,");
  CHECK(inputError([&] { loadArm(f); }) == f + ": masses.links[2].mass_kg: expected a finite number, got '.inf'");
  with("mass_kg: 3.175,", "mass_kg: .nan,");
  CHECK(inputError([&] { loadArm(f); }) == f + ": masses.links[2].mass_kg: expected a finite number, got '.nan'");
  with(link3, "    - {com_m: [0, 0.0890, -0.0296]}");
  CHECK(inputError([&] { loadArm(f); }) == f + ": masses.links[2].mass_kg: missing");
  with("gravity_m_s2: [0, 0, -9.80665]", "gravity_m_s2: [0, -9.80665]");
  CHECK(inputError([&] { loadArm(f); }) == f + ": masses.gravity_m_s2: expected a sequence of 3 numbers");
  with("  links:", "  payload: {mass_kg: -1}\n  links:");
  CHECK(inputError([&] { loadArm(f); }) == f + ": masses.payload.mass_kg: '-1' is outside 0 kg to 1e6 kg");
  with("  links:", "  payload: {mass_kg: 1, com_mm: [0, 0, 1]}\n  links:");
  CHECK_THAT(inputError([&] { loadArm(f); }), Catch::StartsWith(f + ": masses.payload.com_mm: unknown key"));
  with("masses:", "massses:");
  CHECK_THAT(inputError([&] { loadArm(f); }), Catch::StartsWith(f + ": massses: unknown key"));
}
