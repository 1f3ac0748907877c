// Open-world datasets (sim/open_world.hpp): deterministic per seed, the requested SNR reached (the
// cause's position effect recomputed here with the header's formulas, not the generator's functions),
// each cause's formula at a hand-worked configuration, and the written files read back.
#include <catch2/catch.hpp>
#include <cmath>
#include <fstream>

#include "orbcal/sim/gravity.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/measured.hpp"
#include "orbcal/sim/open_world.hpp"
#include "test_util.hpp"

using namespace orbcal::sim;

namespace {

const Arm& iiwa7() {
  static const Arm arm = loadArm("builtin:iiwa7.yaml");
  return arm;
}
const Arm& ssrms() {
  static const Arm arm = loadArm("builtin:ssrms.yaml");
  return arm;
}

OpenWorldSpec smallSpec(const Arm& arm, OpenCauseKind cause, std::uint64_t seed) {
  OpenWorldSpec spec;
  spec.arm = arm;
  spec.cause = cause;
  spec.samples = 40;
  spec.seed = seed;
  return spec;
}

/// dq of the cause, written out here from the header's formulas (independent of causeJointOffsets).
Eigen::VectorXd offsetsByHand(const OpenCause& c, const Eigen::VectorXd& q, const Eigen::VectorXd& tau) {
  Eigen::VectorXd dq = Eigen::VectorXd::Zero(q.size());
  const int i = c.joint_a, j = c.joint_b;
  if (c.kind == OpenCauseKind::kHarmonic3) dq[i] = c.a * std::sin(3.0 * q[i] + c.phase_rad);
  if (c.kind == OpenCauseKind::kHarmonic4) dq[i] = c.a * std::sin(4.0 * q[i] + c.phase_rad);
  if (c.kind == OpenCauseKind::kCoupling) dq[i] = c.a * q[j];
  if (c.kind == OpenCauseKind::kStiffening) dq[i] = c.a * tau[i] + c.b * std::pow(tau[i], 3);
  if (c.kind == OpenCauseKind::kTwoCatalog) {
    dq[i] = c.a * tau[i];
    dq[j] = c.b * std::sin(q[j] + c.phase_rad);
  }
  return dq;
}

/// The marker's position with the cause, in the world, recomputed in the base frame: joint causes as
/// forwardKinematics at q + dq; link bending as the rigid motion of everything beyond the link's far
/// end e (from sim::chainFrames), p -> e + delta + R (p - e), delta and R from the cantilever formulas.
Eigen::Vector3d positionByHand(const OpenWorldTruth& t, const Eigen::VectorXd& q, const Eigen::VectorXd& tau) {
  const Eigen::VectorXd q_true = q + offsetsByHand(t.cause, q, tau);
  const Eigen::Vector3d p_base = (forwardKinematics(t.arm, q_true) * t.flange_T_marker).translation();
  if (t.cause.kind != OpenCauseKind::kLinkBending) return t.world_T_base * p_base;
  const int r = t.cause.joint_a;
  const std::vector<Eigen::Isometry3d> frames = chainFrames(t.arm, q);
  const Eigen::Vector3d o = frames[static_cast<std::size_t>(r + 1)].translation();
  const Eigen::Vector3d e = frames[static_cast<std::size_t>(r + 2)].translation();
  double carried = t.masses.payload_kg;
  for (std::size_t k = static_cast<std::size_t>(r) + 1; k < t.masses.links.size(); ++k) carried += t.masses.links[k].mass_kg;
  const Eigen::Vector3d F = carried * t.masses.gravity_base;
  const double L = (e - o).norm();
  const Eigen::Vector3d u = (e - o) / L;
  const Eigen::Vector3d F_perp = F - F.dot(u) * u;
  const double EI = 1.0 / t.cause.a;
  const Eigen::Vector3d delta = F_perp * std::pow(L, 3) / (3.0 * EI);
  const double tilt = F_perp.norm() * L * L / (2.0 * EI);
  const Eigen::Matrix3d R(Eigen::AngleAxisd(tilt, u.cross(F_perp).normalized()));
  return t.world_T_base * (e + delta + R * (p_base - e));
}

}  // namespace

TEST_CASE("open world: the same seed draws the same dataset, another seed another", "[sim][open_world]") {
  for (OpenCauseKind kind : openCauseKinds()) {
    CAPTURE(openCauseName(kind));
    const OpenWorldDataset a = generateOpenWorld(smallSpec(iiwa7(), kind, 7));
    const OpenWorldDataset b = generateOpenWorld(smallSpec(iiwa7(), kind, 7));
    const OpenWorldDataset c = generateOpenWorld(smallSpec(iiwa7(), kind, 8));
    REQUIRE(a.data.poses.size() == 40);
    for (std::size_t k = 0; k < a.data.poses.size(); ++k) {
      REQUIRE(a.data.poses[k].sample.q_rad == b.data.poses[k].sample.q_rad);
      REQUIRE(a.data.poses[k].world_T_marker.matrix() == b.data.poses[k].world_T_marker.matrix());
    }
    REQUIRE(a.truth.cause.a == b.truth.cause.a);
    REQUIRE(a.truth.cause.joint_a == b.truth.cause.joint_a);
    REQUIRE(a.truth.dh_errors == b.truth.dh_errors);
    REQUIRE(a.data.poses[0].sample.q_rad != c.data.poses[0].sample.q_rad);
    REQUIRE(a.truth.world_T_base.matrix() != c.truth.world_T_base.matrix());
  }
}

TEST_CASE("open world: the cause's raw position effect has the requested SNR", "[sim][open_world]") {
  // The generator scales until within 1e-10 relative; the recomputation here (base frame instead of the
  // link's frame for the bending) differs from it by rounding only: 1e-8 relative.
  constexpr double kRelTol = 1e-8;
  for (const Arm* arm : {&iiwa7(), &ssrms()}) {
    for (OpenCauseKind kind : openCauseKinds()) {
      for (double snr : {2.0, 20.0}) {
        CAPTURE(arm->name, openCauseName(kind), snr);
        OpenWorldSpec spec = smallSpec(*arm, kind, 3);
        spec.snr = snr;
        const OpenWorldDataset d = generateOpenWorld(spec);
        const OpenWorldTruth& t = d.truth;
        double sum = 0.0;
        for (const MeasuredPose& m : d.data.poses) {
          const Eigen::Vector3d without =
              t.world_T_base * (forwardKinematics(t.arm, m.sample.q_rad) * t.flange_T_marker).translation();
          sum += (positionByHand(t, m.sample.q_rad, m.sample.tau_Nm) - without).squaredNorm();
        }
        const double rms = std::sqrt(sum / static_cast<double>(d.data.poses.size()));
        const double target = snr * std::sqrt(3.0) * spec.noise_position_m;
        REQUIRE(rms == Approx(target).epsilon(kRelTol));
        REQUIRE(t.effect_rms_m == Approx(target).epsilon(kRelTol));
        if (kind == OpenCauseKind::kStiffening) {  // the cubic term carries at least half at the largest torque
          double tau_max = 0.0;
          for (const MeasuredPose& m : d.data.poses) tau_max = std::max(tau_max, std::abs(m.sample.tau_Nm[t.cause.joint_a]));
          REQUIRE(t.cause.a * t.cause.b > 0.0);
          REQUIRE(std::abs(t.cause.b) * std::pow(tau_max, 3) >= std::abs(t.cause.a) * tau_max);
        }
        if (kind == OpenCauseKind::kCoupling || kind == OpenCauseKind::kTwoCatalog) REQUIRE(t.cause.joint_a != t.cause.joint_b);
      }
    }
  }
}

TEST_CASE("open world: joint-space causes at a hand-worked configuration", "[sim][open_world]") {
  constexpr double kTol = 1e-15;  // one multiplication and a sine: rounding of O(1e-3) numbers
  Eigen::VectorXd q(7), tau(7);
  q << 0.1, 0.4, -0.2, 1.0, 0.0, -0.5, 0.3;
  tau << 0.0, 50.0, 0.0, -20.0, 0.0, 5.0, 0.0;
  OpenCause c;
  c.kind = OpenCauseKind::kHarmonic3;
  c.harmonic = 3;
  c.joint_a = 1;
  c.a = 2e-3;
  c.phase_rad = 0.3;
  Eigen::VectorXd expected = Eigen::VectorXd::Zero(7);
  expected[1] = 2e-3 * std::sin(1.5);  // 3 * 0.4 + 0.3
  REQUIRE((causeJointOffsets(c, q, tau) - expected).norm() < kTol);

  c.kind = OpenCauseKind::kHarmonic4;
  c.harmonic = 4;
  expected[1] = 2e-3 * std::sin(1.9);  // 4 * 0.4 + 0.3
  REQUIRE((causeJointOffsets(c, q, tau) - expected).norm() < kTol);

  c = OpenCause{};
  c.kind = OpenCauseKind::kCoupling;
  c.joint_a = 5;
  c.joint_b = 3;
  c.a = -4e-3;
  expected.setZero();
  expected[5] = -4e-3;  // k q_4 = -4e-3 * 1.0
  REQUIRE((causeJointOffsets(c, q, tau) - expected).norm() < kTol);

  c = OpenCause{};
  c.kind = OpenCauseKind::kStiffening;
  c.joint_a = 1;
  c.a = 1e-5;
  c.b = 2e-9;
  expected.setZero();
  expected[1] = 5e-4 + 2.5e-4;  // 1e-5 * 50 + 2e-9 * 125000
  REQUIRE((causeJointOffsets(c, q, tau) - expected).norm() < kTol);

  c = OpenCause{};
  c.kind = OpenCauseKind::kTwoCatalog;
  c.joint_a = 3;
  c.joint_b = 0;
  c.a = 1e-5;
  c.b = -1e-3;
  c.phase_rad = 0.2;
  expected.setZero();
  expected[3] = -2e-4;                      // 1e-5 * -20
  expected[0] = -1e-3 * std::sin(0.3);      // A sin(q_1 + phi)
  REQUIRE((causeJointOffsets(c, q, tau) - expected).norm() < kTol);

  c.kind = OpenCauseKind::kLinkBending;
  REQUIRE(causeJointOffsets(c, q, tau).norm() == 0.0);
}

TEST_CASE("open world: a horizontal cantilever deflects by F L^3 / 3EI and tilts by F L^2 / 2EI", "[sim][open_world]") {
  // Two joints about vertical axes (modified DH); the link of joint 1 is horizontal, L = 2.5 m, along x of
  // frame 1 to joint 2, which carries 3 kg at its axis; the flange is at joint 2's origin.
  constexpr double L = 2.5, EI = 1e5, m = 3.0, g = 9.80665;
  Arm arm;
  arm.convention = DhConvention::kModified;
  arm.joints.resize(2);
  arm.joints[1].a_m = L;
  arm.lower_rad = Eigen::Vector2d(-3.0, -3.0);
  arm.upper_rad = Eigen::Vector2d(3.0, 3.0);
  OpenWorldTruth t;
  t.arm = arm;
  t.masses.links = {{0.0, Eigen::Vector3d::Zero()}, {m, Eigen::Vector3d::Zero()}};
  t.cause.kind = OpenCauseKind::kLinkBending;
  t.cause.joint_a = 0;
  t.cause.a = 1.0 / EI;
  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(2);
  constexpr double kRel = 1e-9;  // the brief's bar; exact formulas, so only rounding remains
  for (double q1 : {0.0, 0.7}) {  // a turn about the vertical keeps the link horizontal
    CAPTURE(q1);
    const Eigen::Vector2d q(q1, -0.4);
    const Eigen::Isometry3d bent = openWorldMarkerPose(t, q, tau, true);
    const Eigen::Isometry3d straight = openWorldMarkerPose(t, q, tau, false);
    const Eigen::Vector3d d = bent.translation() - straight.translation();
    const double expected = m * g * L * L * L / (3.0 * EI);
    REQUIRE(d.z() == Approx(-expected).epsilon(kRel));
    REQUIRE(d.head<2>().norm() < kRel * expected);
    const Eigen::AngleAxisd tilt(bent.linear() * straight.linear().transpose());
    REQUIRE(tilt.angle() == Approx(m * g * L * L / (2.0 * EI)).epsilon(kRel));
    // About the horizontal axis L^ x (-z): the tip turns down.
    const Eigen::Vector3d along(std::cos(q1), std::sin(q1), 0.0);
    REQUIRE((tilt.axis() - along.cross(-Eigen::Vector3d::UnitZ())).norm() < 1e-9);
  }
  t.cause.a = 0.0;  // no bending: the rows composed by the generator are sim::forwardKinematics
  const Eigen::Vector2d q(0.3, 1.1);
  REQUIRE((openWorldMarkerPose(t, q, tau, true).matrix() - forwardKinematics(arm, q).matrix()).norm() < 1e-15);
}

TEST_CASE("open world: the written files read back to the in-memory data", "[sim][open_world]") {
  const OpenWorldDataset d = generateOpenWorld(smallSpec(iiwa7(), OpenCauseKind::kCoupling, 11));
  const std::string folder = orbcal::test::tempDir("open_world_io");
  const std::string path = writeOpenWorld(d, folder, "builtin:iiwa7.yaml");
  const MeasuredData r = loadMeasuredData(path);
  REQUIRE(r.poses.size() == d.data.poses.size());
  REQUIRE(r.has_torque);
  REQUIRE(r.base == FrameSharing::kShared);
  REQUIRE(r.marker == FrameSharing::kShared);
  constexpr double kNoiseRel = 1e-15;  // through mm and deg: one multiplication each way
  REQUIRE(r.noise_position_m);
  REQUIRE(*r.noise_position_m == Approx(*d.data.noise_position_m).epsilon(kNoiseRel));
  REQUIRE(r.noise_rotation_rad);
  REQUIRE(*r.noise_rotation_rad == Approx(*d.data.noise_rotation_rad).epsilon(kNoiseRel));
  REQUIRE(r.noise_joint_rad);
  REQUIRE(*r.noise_joint_rad == 0.0);
  constexpr double kRotationTol = 1e-15 * 10;  // through a quaternion written with 17 digits
  for (std::size_t k = 0; k < r.poses.size(); ++k) {
    CAPTURE(k);
    const MeasuredPose& a = d.data.poses[k];
    const MeasuredPose& b = r.poses[k];
    REQUIRE(b.sample.q_rad == a.sample.q_rad);    // %.17g: bit for bit
    REQUIRE(b.sample.tau_Nm == a.sample.tau_Nm);
    REQUIRE(b.world_T_marker.translation() == a.world_T_marker.translation());
    REQUIRE((b.world_T_marker.linear() - a.world_T_marker.linear()).cwiseAbs().maxCoeff() < kRotationTol);
    REQUIRE(b.sample.direction == a.sample.direction);
    REQUIRE(b.sample.session == 0);
  }
  std::ifstream truth(folder + "/truth.yaml");
  std::stringstream text;
  text << truth.rdbuf();
  REQUIRE_THAT(text.str(), Catch::Contains("cause: coupling"));
}
