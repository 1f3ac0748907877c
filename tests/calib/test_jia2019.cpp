// Jia et al. 2019: what the distance, rotation and distance + rotation models can
// identify on the SSRMS-type Hayati arm (scenes/ssrms_hayati.yaml, our geometry), checked against what
// the paper states and against our own numerical check; the hemisphere configurations of the
// paper's protocol; and the joint noise carried into the pair sigmas.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <random>

#include "orbcal/calib/marker_model.hpp"
#include "orbcal/calib/parameter_classes.hpp"
#include "orbcal/calib/relative_models.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/hemisphere.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "test_util.hpp"

using namespace orbcal;

namespace {

sim::Arm hayati() { return sim::loadArm(test::sourcePath("scenes/ssrms_hayati.yaml")); }

/// The reference configuration of the `jia2019` preset (deg): within the limits, away from singularity.
Eigen::VectorXd referenceQ() {
  Eigen::VectorXd q(7);
  q << 0, 30, -60, 100, -40, 90, 0;
  return q * sim::kDegToRad;
}

std::vector<std::string> namesOf(const calib::ParameterClasses& c, const std::vector<int>& idx) {
  std::vector<std::string> out;
  for (int i : idx) out.push_back(c.names[static_cast<std::size_t>(i)]);
  return out;
}

calib::ParamClass classOf(const calib::ParameterClasses& c, const std::string& name) {
  for (std::size_t i = 0; i < c.names.size(); ++i) {
    if (c.names[i] == name) return c.classes[i];
  }
  FAIL("no parameter " << name);
  return calib::ParamClass::kIndependent;
}

/// 60 pairs against a reference: 61 random configurations (joints uniform in +-180 deg), the
/// first the reference; exact flange poses of the nominal arm (identifiability is a property of H).
std::vector<calib::RelativeObservation> referencePairs(const sim::KinematicModel& km, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> angle(-sim::kPi, sim::kPi);
  std::vector<calib::MarkerObservation> poses;
  for (int k = 0; k < 61; ++k) {
    calib::MarkerObservation o;
    o.sample.q_rad = Eigen::VectorXd::NullaryExpr(km.arm.numJoints(), [&] { return angle(rng); });
    o.world_T_marker = sim::predictMarkerPose(km, Eigen::VectorXd::Zero(km.layout.size()), o.sample);
    poses.push_back(o);
  }
  return calib::relativePairs(poses, calib::Pairing::kReference, 0);
}

}  // namespace

TEST_CASE("Jia et al. 2019: distance, rotation and D&R classes on the Hayati SSRMS, known frames, 60 pairs",
          "[calib][jia2019]") {
  using calib::ParamClass;
  const sim::KinematicModel km = sim::flangeModel(hayati());
  REQUIRE(km.layout.size() == 35);
  const auto pairs = referencePairs(km, 2019);
  REQUIRE(pairs.size() == 60u);
  const Eigen::VectorXd y0 = Eigen::VectorXd::Zero(35);
  const calib::ParameterClasses D = calib::classifyParameters(calib::RelativePoseModel(km, pairs, calib::RelativeRows::kDistance), y0);
  const calib::ParameterClasses R = calib::classifyParameters(calib::RelativePoseModel(km, pairs, calib::RelativeRows::kRotation), y0);
  const calib::ParameterClasses DR = calib::classifyParameters(calib::RelativePoseModel(km, pairs, calib::RelativeRows::kBoth), y0);
  INFO("distance:\n" << D.describe() << "rotation:\n" << R.describe() << "both:\n" << DR.describe());

  // The paper's text: the distance cannot see theta1 and d1 (a rigid motion of
  // everything downstream of joint 1) nor alpha7 and beta7 (rotations at the end-effector origin).
  for (const char* name : {"theta1", "d1", "alpha7", "beta7"}) {
    CAPTURE(name);
    CHECK(classOf(D, name) == ParamClass::kIneffective);
  }
  // The rotation angle sees no length (a translation never rotates) and, being invariant under
  // conjugation, neither theta1 nor the suffix Rz(theta7) Rx(alpha7) Ry(beta7).
  for (int j = 1; j <= 7; ++j) {
    CHECK(classOf(R, "a" + std::to_string(j)) == ParamClass::kIneffective);
    CHECK(classOf(R, "d" + std::to_string(j)) == ParamClass::kIneffective);
  }
  for (const char* name : {"theta1", "theta7", "alpha7", "beta7"}) {
    CAPTURE(name);
    CHECK(classOf(R, name) == ParamClass::kIneffective);
  }
  // Combined, the rows restore what either loses alone: a higher rank than both, and a6 and alpha6,
  // which the distance alone determines only in combination with others, become independent (the
  // paper: "the rotation error model ... a6 and alpha6").
  CHECK(DR.rank > std::max(D.rank, R.rank));
  for (const char* name : {"a6", "alpha6"}) {
    CAPTURE(name);
    CHECK(classOf(D, name) == ParamClass::kRelative);
    CHECK(classOf(DR, name) == ParamClass::kIndependent);
  }
  // Every parameter independent under one model alone stays independent with both.
  for (const auto* one : {&D, &R}) {
    for (int p : one->independent) CHECK(DR.classes[static_cast<std::size_t>(p)] == ParamClass::kIndependent);
  }

  // Our independent numerical check (docs/methods.md): ranks 22 / 11 / 24 of 35, and the
  // zero columns theta1, d1, beta1, theta7, alpha7, beta7 (beta1 turns frame 1 about z0 through a point of
  // z0 when alpha1 = 90 deg and a1 = 0, a rigid motion like theta1); the rotation adds every a and d.
  CHECK(D.rank == 22);
  CHECK(R.rank == 11);
  CHECK(DR.rank == 24);
  const std::vector<std::string> zero{"theta1", "d1", "beta1", "theta7", "alpha7", "beta7"};
  auto sorted = [](std::vector<std::string> v) {
    std::sort(v.begin(), v.end());
    return v;
  };
  CHECK(sorted(namesOf(D, D.ineffective)) == sorted(zero));
  CHECK(sorted(namesOf(DR, DR.ineffective)) == sorted(zero));
  std::vector<std::string> zero_r = zero;
  for (int j = 1; j <= 7; ++j) {
    for (const char* k : {"a", "d"}) {
      const std::string n = k + std::to_string(j);
      if (std::find(zero_r.begin(), zero_r.end(), n) == zero_r.end()) zero_r.push_back(n);
    }
  }
  CHECK(sorted(namesOf(R, R.ineffective)) == sorted(zero_r));
}

TEST_CASE("Fibonacci hemisphere: unit vectors, upper side, uniform over the area", "[calib][jia2019][hemisphere]") {
  const int n = 51;
  const auto u = sim::fibonacciHemisphere(n);
  REQUIRE(u.size() == static_cast<std::size_t>(n));
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& v : u) {
    CHECK(std::abs(v.norm() - 1.0) < 1e-12);
    CHECK(v.z() > 0.0);
    mean += v / n;
  }
  // Uniform over the hemisphere's area: E[z] = 1/2 (Archimedes: the height is uniform in [0, 1]), E[x] =
  // E[y] = 0. The lattice does better than n random points (standard error sqrt(1/3 / n) = 0.08 here).
  CHECK(std::abs(mean.z() - 0.5) < 1e-12);
  CHECK(std::abs(mean.x()) < 0.03);
  CHECK(std::abs(mean.y()) < 0.03);
  CHECK_THROWS(sim::fibonacciHemisphere(0));
}

TEST_CASE("pointing rotation: z along the target axis, nearest the reference's roll", "[calib][jia2019][hemisphere]") {
  const Eigen::Matrix3d R_ref = sim::expSO3(Eigen::Vector3d(0.3, -0.7, 1.1));
  const Eigen::Vector3d z = Eigen::Vector3d(0.4, 0.2, 0.9).normalized();
  const Eigen::Matrix3d R = sim::pointingRotation(R_ref, z);
  CHECK((R.col(2) - z).norm() < 1e-12);
  CHECK((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() < 1e-12);
  // The swing's angle is the angle between the two z axes; every other roll about z turns further.
  const double tilt = std::acos(R_ref.col(2).dot(z));
  CHECK(std::abs(sim::rotationAngle(R_ref.transpose() * R) - tilt) < 1e-12);
  for (double psi = -3.0; psi <= 3.0; psi += 0.25) {
    if (std::abs(psi) < 1e-9) continue;
    const Eigen::Matrix3d other = R * sim::expSO3(Eigen::Vector3d(0, 0, psi));
    CHECK(sim::rotationAngle(R_ref.transpose() * other) > tilt);
  }
}

TEST_CASE("hemisphere configurations: 51 poses on the sphere, pointing at the board centre, within limits",
          "[calib][jia2019][hemisphere]") {
  const sim::Arm arm = hayati();
  const Eigen::VectorXd q_ref = referenceQ();
  sim::HemisphereSettings s;  // 51 points, r = 0.5 m, c 0.5 m ahead, theta_3 locked
  const sim::HemisphereConfigurations h = sim::hemisphereConfigurations(arm, q_ref, s);
  REQUIRE(h.poses.size() == 51u);
  CHECK(h.reached.size() + h.unreachable.size() == 51u);
  CHECK(h.unreachable.empty());  // this reference reaches the whole hemisphere
  const Eigen::Vector3d p_ref = h.reference_pose.translation();
  const Eigen::Vector3d z_ref = h.reference_pose.linear().col(2);
  CHECK((h.target - (p_ref + 0.5 * z_ref)).norm() < 1e-12);
  for (std::size_t k = 0; k < h.q.size(); ++k) {
    CAPTURE(k, h.reached[k]);
    const Eigen::VectorXd& q = h.q[k];
    CHECK(sim::withinLimits(arm, q));
    CHECK(q[s.locked_joint] == q_ref[s.locked_joint]);
    const Eigen::Isometry3d T = sim::forwardKinematics(arm, q);
    const Eigen::Vector3d p = T.translation();
    CHECK(std::abs((p - p_ref).norm() - 0.5) < 1e-9);   // on the sphere
    CHECK((p - p_ref).dot(z_ref) <= 1e-9);               // on the side away from the board
    CHECK((T.linear().col(2) - (h.target - p).normalized()).norm() < 1e-9);  // z axis at c
    // The roll nearest the reference's: the rotation from R_ref is the swing, its angle the tilt.
    const double tilt = std::acos(std::clamp(T.linear().col(2).dot(z_ref), -1.0, 1.0));
    CHECK(std::abs(sim::rotationAngle(h.reference_pose.linear().transpose() * T.linear()) - tilt) < 1e-8);
  }
  // Points the arm cannot reach are reported, not dropped: joint 4 held within 0.5 deg of q_ref cannot
  // follow the 0.5 m hemisphere everywhere.
  sim::Arm tight = arm;
  tight.lower_rad[3] = q_ref[3] - 0.5 * sim::kDegToRad;
  tight.upper_rad[3] = q_ref[3] + 0.5 * sim::kDegToRad;
  const sim::HemisphereConfigurations t = sim::hemisphereConfigurations(tight, q_ref, s);
  CHECK(t.reached.size() + t.unreachable.size() == 51u);
  CHECK(!t.unreachable.empty());
  for (const auto& q : t.q) CHECK(sim::withinLimits(tight, q));
  CHECK_THROWS(sim::hemisphereConfigurations(arm, q_ref, sim::HemisphereSettings{51, -0.5, 0.5, 2}));
}

TEST_CASE("relative pairs: joint noise carried into the sigmas matches Monte Carlo", "[calib][jia2019]") {
  const sim::KinematicModel km = sim::flangeModel(hayati());
  const Eigen::VectorXd p = Eigen::VectorXd::Zero(km.layout.size());
  calib::RelativeObservation o;
  o.a.q_rad = referenceQ();
  o.b.q_rad = referenceQ() + Eigen::VectorXd::Constant(7, 5.0 * sim::kDegToRad);
  o.sigma_distance_m = 0.0;
  o.sigma_angle_rad = 0.0;
  std::vector<calib::RelativeObservation> pairs{o};
  const double sigma_q = 0.01 * sim::kDegToRad;
  calib::addRelativeJointNoise(km, p, sigma_q, pairs);
  // Empirical spread of L and phi with N(0, sigma_q) on every joint of both configurations.
  auto rng = sim::makeRng(7);
  const int n = 4000;
  double sl = 0, sl2 = 0, sp = 0, sp2 = 0;
  for (int i = 0; i < n; ++i) {
    sim::JointSample a = o.a, b = o.b;
    a.q_rad = sim::addJointNoise(a.q_rad, sigma_q, rng);
    b.q_rad = sim::addJointNoise(b.q_rad, sigma_q, rng);
    const Eigen::Vector2d z = calib::predictRelative(km, p, a, b);
    sl += z[0];
    sl2 += z[0] * z[0];
    sp += z[1];
    sp2 += z[1] * z[1];
  }
  const double std_l = std::sqrt(std::max(0.0, sl2 / n - (sl / n) * (sl / n)));
  const double std_p = std::sqrt(std::max(0.0, sp2 / n - (sp / n) * (sp / n)));
  // The sample standard deviation of 4000 draws is within 1.1% (1 sigma) of the truth: 6% is > 5 sigma.
  CHECK(pairs[0].sigma_distance_m > 1e-4);
  CHECK(std::abs(std_l / pairs[0].sigma_distance_m - 1.0) < 0.06);
  CHECK(std::abs(std_p / pairs[0].sigma_angle_rad - 1.0) < 0.06);
}
