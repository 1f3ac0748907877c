// Measurement models beside the absolute pose: position only (MarkerPoseModel), distance and
// rotation between pairs of configurations (RelativePoseModel, Jia et al. 2019) and laser range to a
// plane (PlaneRangeModel, Liu et al. 2012): analytic H against central differences in both DH conventions,
// every estimator on each, and the identifiability classes of each model.
#include <catch2/catch.hpp>
#include <random>

#include "orbcal/calib/estimators.hpp"
#include "orbcal/calib/marker_model.hpp"
#include "orbcal/calib/parameter_classes.hpp"
#include "orbcal/calib/relative_models.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "jacobian_check.hpp"
#include "test_util.hpp"

using namespace orbcal;

namespace {


const char* const kArms[] = {"scenes/ssrms.yaml", "scenes/iiwa7.yaml"};

sim::JointSample randomSample(const sim::Arm& arm, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  sim::JointSample s;
  s.q_rad.resize(arm.numJoints());
  for (int j = 0; j < arm.numJoints(); ++j) s.q_rad[j] = arm.lower_rad[j] + u(rng) * (arm.upper_rad[j] - arm.lower_rad[j]);
  return s;
}

/// Random parameters: `scale` x the typical magnitudes.
Eigen::VectorXd randomParams(const sim::ParamLayout& layout, std::mt19937_64& rng, double scale = 1.0) {
  std::normal_distribution<double> n01(0.0, 1.0);
  const Eigen::VectorXd t = layout.typical();
  Eigen::VectorXd p(t.size());
  for (Eigen::Index i = 0; i < p.size(); ++i) p[i] = scale * n01(rng) * t[i];
  return p;
}

/// Every sample's H against central differences of its innovation (tests/jacobian_check.hpp):
/// H = d h / d y = -d nu / d y.
void checkH(const calib::MeasurementModel& m, const Eigen::VectorXd& y) {
  double largest = 0.0;
  for (int k = 0; k < m.numSamples(); ++k) {
    const calib::Linearization lin = m.linearize(k, y);
    REQUIRE(lin.H.rows() == m.rows(k));
    REQUIRE(lin.H.cols() == m.numParams());
    CAPTURE(k);
    const auto f = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd { return -m.linearize(k, x).innovation; };
    largest = std::max(largest, test::requireJacobianMatches(f, lin.H, y, m.layout().typical(), [&](int c) { return m.paramName(c); }));
  }
  REQUIRE(largest > 1e-4);  // the harness is not comparing zeros
}

/// Poses of `model` at p for n random samples, with pose noise (right perturbation in the marker frame).
std::vector<calib::MarkerObservation> poses(const sim::KinematicModel& model, const Eigen::VectorXd& p, int n,
                                            std::mt19937_64& rng, double sigma_p = 0.0, double sigma_r = 0.0) {
  std::normal_distribution<double> n01(0.0, 1.0);
  std::vector<calib::MarkerObservation> out;
  for (int i = 0; i < n; ++i) {
    calib::MarkerObservation o;
    o.sample = randomSample(model.arm, rng);
    sim::Vector6d e;
    for (int r = 0; r < 6; ++r) e[r] = n01(rng) * (r < 3 ? sigma_p : sigma_r);
    o.world_T_marker = sim::posePlus(sim::predictMarkerPose(model, p, o.sample), e);
    out.push_back(o);
  }
  return out;
}

// The beam of the range tests: off the flange axis and tilted, so that the last joint's rotation moves
// the hit point (Liu et al. 2012's tool offset).
calib::LaserBeam offsetBeam() { return {Eigen::Vector3d(0.05, -0.02, 0.1), Eigen::Vector3d(0.3, 0.0, 1.0).normalized()}; }

/// Ranges of configurations whose beam meets the plane at 0.05 m < h < 40 m with |n^ . b| > 0.3, from
/// the model at p (the plane's coefficients included), each the mean of `repeats` noisy readings.
std::vector<calib::RangeObservation> ranges(const sim::KinematicModel& km, const calib::LaserBeam& beam,
                                            const calib::Plane& plane, const Eigen::VectorXd& p, int n, std::mt19937_64& rng,
                                            double sigma = 0.0, int repeats = 1) {
  const calib::PlaneRangeModel probe(km, beam, plane, {});
  calib::RangeConfigurationSettings settings;
  settings.min_range_m = 0.05;
  settings.max_range_m = 40.0;
  settings.min_singular_value = 0.0;
  const auto samples = calib::rangeConfigurations(probe, p, n, rng, settings);
  return calib::simulateRanges(probe, p, samples, sigma > 0.0 ? sigma : 1e-4, repeats, rng, sigma > 0.0);
}

}  // namespace

TEST_CASE("relative pose model: H matches central differences, both DH conventions, frames unknown", "[calib][relative]") {
  for (const char* file : kArms) {
    CAPTURE(file);
    const sim::Arm arm = sim::loadArm(test::sourcePath(file));
    std::mt19937_64 rng(101);
    // Unknown base and marker frames: their columns are part of the check too.
    const sim::KinematicModel km = sim::makeKinematicModel(
        arm, 1, sim::FrameSharing::kShared, sim::FrameSharing::kShared,
        {sim::fromXyzRpy({1.2, -0.4, 0.3}, Eigen::Vector3d(10, -30, 60) * sim::kDegToRad)},
        {sim::fromXyzRpy({0.03, -0.05, 0.11}, Eigen::Vector3d(5, -8, 40) * sim::kDegToRad)}, {});
    const Eigen::VectorXd p_true = randomParams(km.layout, rng);
    for (const calib::Pairing pairing : {calib::Pairing::kReference, calib::Pairing::kConsecutive}) {
      const auto pairs = calib::relativePairs(poses(km, p_true, 6, rng, 1e-4, 1e-3), pairing, 2);
      CHECK(pairs.size() == 5u);
      for (const calib::RelativeRows rows : {calib::RelativeRows::kDistance, calib::RelativeRows::kRotation, calib::RelativeRows::kBoth}) {
        const calib::RelativePoseModel m(km, pairs, rows);
        CHECK(m.rows(0) == (rows == calib::RelativeRows::kBoth ? 2 : 1));
        checkH(m, randomParams(km.layout, rng));
      }
    }
  }
}

TEST_CASE("relative pairs: measured distance and angle, the guard on small angles", "[calib][relative]") {
  const sim::Arm arm = sim::loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  const sim::KinematicModel km = sim::flangeModel(arm);
  std::mt19937_64 rng(5);
  auto obs = poses(km, Eigen::VectorXd::Zero(km.layout.size()), 3, rng);
  // Pose 1 rotated by 0.5 deg about a point 0.2 m away from pose 0: no rotation row, a distance row.
  obs[1].world_T_marker = obs[0].world_T_marker * sim::posePlus(Eigen::Isometry3d::Identity(),
                                                                (sim::Vector6d() << 0.2, 0, 0, 0, 0, 0.5 * sim::kDegToRad).finished());
  const auto pairs = calib::relativePairs(obs, calib::Pairing::kConsecutive);
  REQUIRE(pairs.size() == 2u);
  CHECK(pairs[0].distance_m == Approx(0.2).epsilon(1e-12));
  CHECK(pairs[0].angle_rad == Approx(0.5 * sim::kDegToRad).epsilon(1e-9));
  CHECK(pairs[0].has_distance);
  CHECK_FALSE(pairs[0].has_rotation);
  CHECK(calib::RelativePoseModel(km, pairs, calib::RelativeRows::kRotation).numSamples() == 1);  // pair 0 keeps no row
  CHECK(pairs[0].sigma_distance_m == Approx(std::sqrt(2.0) * calib::MarkerNoise{}.sigma_position_m));
  CHECK_THROWS(calib::relativePairs(obs, calib::Pairing::kReference, 3));
}

TEST_CASE("plane range model: H matches central differences, both DH conventions, plane identified", "[calib][plane]") {
  for (const char* file : kArms) {
    CAPTURE(file);
    const sim::Arm arm = sim::loadArm(test::sourcePath(file));
    std::mt19937_64 rng(202);
    const sim::KinematicModel km = sim::flangeModel(arm);
    for (const calib::Plane& plane : {calib::Plane::seed004(), calib::Plane{Eigen::Vector3d(0.2, -0.1, 1.0), 0.5, {0, 1, 3}}}) {
      const calib::PlaneRangeModel probe(km, offsetBeam(), plane, {});
      CHECK(probe.numParams() == km.layout.size() + static_cast<int>(plane.identified.size()));
      CHECK(probe.layout().block(probe.layout().blocks().size() - 1).effect == "plane");
      const Eigen::VectorXd p = randomParams(probe.layout(), rng);
      const calib::PlaneRangeModel m(km, offsetBeam(), plane, ranges(km, offsetBeam(), plane, p, 6, rng, 2e-4, 10));
      CHECK(m.linearize(0, p).R(0, 0) == Approx(4e-8 / 10.0));  // the mean of 10 readings: sigma^2 / 10
      checkH(m, randomParams(probe.layout(), rng));
    }
  }
}

TEST_CASE("plane range: the hit point lies on the plane and on the beam", "[calib][plane]") {
  const sim::Arm arm = sim::loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  const sim::KinematicModel km = sim::flangeModel(arm);
  std::mt19937_64 rng(9);
  const calib::Plane plane = calib::Plane::seed004();
  const calib::PlaneRangeModel m(km, offsetBeam(), plane, {});
  const Eigen::VectorXd p = Eigen::VectorXd::Zero(m.numParams());
  const auto obs = ranges(km, offsetBeam(), plane, p, 3, rng);
  for (const auto& o : obs) {
    const Eigen::Isometry3d T = sim::predictMarkerPose(km, p.head(km.layout.size()), o.sample);
    const Eigen::Vector3d hit = T * offsetBeam().origin + o.range_m * (T.linear() * offsetBeam().direction);
    CHECK(std::abs(hit.y() + 4.6 * hit.z() - 0.69) < 1e-12);
  }
  CHECK(calib::averagedRange({}, {1.0, 2.0, 4.5}, 1e-3).range_m == Approx(2.5));
}

namespace {

/// Every estimator on `m` (built on data from parameters p_true) reduces the weighted cost from y = 0
/// to noise level: below 2 x the number of rows (its expectation at the truth is rows / 2).
void everyEstimatorReducesCost(const calib::MeasurementModel& m) {
  const double start = calib::weightedCost(m, Eigen::VectorXd::Zero(m.numParams()));
  int rows = 0;
  for (int k = 0; k < m.numSamples(); ++k) rows += m.rows(k);
  REQUIRE(start > 50.0 * rows);  // the injected errors are far above the noise
  calib::LseOptions lse;
  lse.weighted = true;
  for (const calib::Estimate& e : {calib::runLm(m, {}), calib::runLse(m, lse), calib::runEkf(m, {})}) {
    CAPTURE(e.method, start, e.cost, rows, e.rank);
    CHECK(std::isfinite(e.cost));
    CHECK(e.cost < 0.05 * start);
    if (e.method != "EKF") CHECK(e.cost < 2.0 * rows);
  }
}

}  // namespace

TEST_CASE("every estimator runs on every new model and reduces the cost to noise level", "[calib][relative][plane]") {
  for (const char* file : kArms) {
    CAPTURE(file);
    const sim::Arm arm = sim::loadArm(test::sourcePath(file));
    const sim::KinematicModel km = sim::flangeModel(arm);
    std::mt19937_64 rng(303);
    // DH errors of 0.3 typical (0.3 deg, 1.5 mm) in the true arm.
    const Eigen::VectorXd p_true = randomParams(km.layout, rng, 0.3);
    const calib::MarkerNoise noise{0.05e-3, 0.005 * sim::kDegToRad};
    const auto measured = poses(km, p_true, 80, rng, noise.sigma_position_m, noise.sigma_rotation_rad);
    {
      INFO("position only (MarkerPoseModel, has_rotation = false)");
      auto positions = measured;
      for (auto& o : positions) o.has_rotation = false;
      everyEstimatorReducesCost(calib::MarkerPoseModel(km, positions, noise));
    }
    for (const calib::RelativeRows rows : {calib::RelativeRows::kDistance, calib::RelativeRows::kRotation, calib::RelativeRows::kBoth}) {
      CAPTURE(static_cast<int>(rows));
      everyEstimatorReducesCost(calib::RelativePoseModel(km, calib::relativePairs(measured, calib::Pairing::kReference, 0, noise), rows));
    }
    {
      INFO("plane range, 10 readings averaged");
      const calib::Plane plane = calib::Plane::seed004();
      const calib::PlaneRangeModel probe(km, offsetBeam(), plane, {});
      Eigen::VectorXd p = Eigen::VectorXd::Zero(probe.numParams());
      p.head(km.layout.size()) = p_true;
      p.tail(1)[0] = 0.005;  // Liu et al. 2012: c = 4.6 perturbed by 0.005
      everyEstimatorReducesCost(calib::PlaneRangeModel(km, offsetBeam(), plane, ranges(km, offsetBeam(), plane, p, 120, rng, 0.2e-3, 10)));
    }
  }
}

namespace {

calib::ParameterClasses classesOf(const calib::MeasurementModel& m) {
  const calib::ParameterClasses c = calib::classifyParameters(m, Eigen::VectorXd::Zero(m.numParams()));
  INFO(c.describe());
  // Every parameter in one class; the minimal set is as large as the rank, and held + minimal = all.
  CHECK(c.ineffective.size() + c.relative.size() + c.independent.size() == static_cast<std::size_t>(m.numParams()));
  CHECK(static_cast<int>(c.minimal.size()) == c.rank);
  CHECK(c.held.size() + c.minimal.size() == static_cast<std::size_t>(m.numParams()));
  return c;
}

std::vector<std::string> namesOf(const calib::ParameterClasses& c, const std::vector<int>& idx) {
  std::vector<std::string> out;
  for (int i : idx) out.push_back(c.names[static_cast<std::size_t>(i)]);
  return out;
}

bool isClass(const calib::ParameterClasses& c, const std::string& name, calib::ParamClass k) {
  for (std::size_t i = 0; i < c.names.size(); ++i) {
    if (c.names[i] == name) return c.classes[i] == k;
  }
  FAIL("no parameter " << name);
  return false;
}

/// The axis of joint 1 in the arm's base frame: z of frame 1 (modified DH) or of frame 0 (standard).
Eigen::Vector3d firstAxis(const sim::Arm& arm) {
  if (arm.convention == sim::DhConvention::kStandard) return arm.base_T_first.linear().col(2);
  return (arm.base_T_first * sim::linkTransform(arm.convention, arm.joints[0], 0.0)).linear().col(2);
}

}  // namespace

TEST_CASE("identifiability classes: distance, rotation, and both", "[calib][classes]") {
  using calib::ParamClass;
  for (const char* file : kArms) {
    CAPTURE(file);
    const sim::Arm arm = sim::loadArm(test::sourcePath(file));
    const bool modified = arm.convention == sim::DhConvention::kModified;
    std::mt19937_64 rng(404);
    // The measuring system's frame unknown (a shared base frame); the marker is the flange.
    const sim::KinematicModel km = sim::makeKinematicModel(arm, 1, sim::FrameSharing::kShared, sim::FrameSharing::kKnown,
                                                           {sim::fromXyzRpy({1.2, -0.4, 0.3}, Eigen::Vector3d(10, -30, 60) * sim::kDegToRad)},
                                                           {Eigen::Isometry3d::Identity()}, {});
    const auto pairs = calib::relativePairs(poses(km, Eigen::VectorXd::Zero(km.layout.size()), 60, rng), calib::Pairing::kReference);
    const calib::ParameterClasses D = classesOf(calib::RelativePoseModel(km, pairs, calib::RelativeRows::kDistance));
    const calib::ParameterClasses R = classesOf(calib::RelativePoseModel(km, pairs, calib::RelativeRows::kRotation));
    const calib::ParameterClasses DR = classesOf(calib::RelativePoseModel(km, pairs, calib::RelativeRows::kBoth));
    INFO("distance:\n" << D.describe() << "rotation:\n" << R.describe() << "both:\n" << DR.describe());
    // Distance: blind to every rigid motion of the whole chain: the base frame, and joint 1's theta and
    // d (Rz(theta1 + q1) Tz(d1) precede or commute with q1 in both conventions; in modified DH also
    // alpha1 and a1, Rx(alpha_0) Tx(a_0) before q1). Blind to theta7 (the flange origin lies on the last
    // axis) and, in standard DH, to alpha7 (a rotation about x at the flange origin).
    std::vector<std::string> expected{"base_x", "base_y", "base_z", "base_rx", "base_ry", "base_rz", "theta1"};
    if (modified) expected.insert(expected.end(), {"alpha1", "a1", "d1", "theta7"});
    else expected.insert(expected.end(), {"d1", "theta7", "alpha7"});
    CHECK(namesOf(D, D.ineffective) == expected);
    // Rotation angle: blind to every length (a and d translate, never rotate) and to what the distance
    // is blind to by rigid motion or conjugation (the base frame, theta1, the suffix after q7).
    for (int j = 0; j < arm.numJoints(); ++j) {
      CHECK(isClass(R, "a" + std::to_string(j + 1), ParamClass::kIneffective));
      CHECK(isClass(R, "d" + std::to_string(j + 1), ParamClass::kIneffective));
    }
    for (const char* name : {"base_x", "base_rx", "base_rz", "theta1", "theta7"}) CHECK(isClass(R, name, ParamClass::kIneffective));
    // Together: more than either alone, and nothing ineffective that the distance sees; everything
    // independent under one of them stays independent.
    CHECK(DR.rank > std::max(D.rank, R.rank));
    CHECK(DR.ineffective == D.ineffective);
    for (const auto* one : {&D, &R}) {
      for (int p : one->independent) CHECK(DR.classes[static_cast<std::size_t>(p)] == ParamClass::kIndependent);
    }
    // What the distance alone loses at the wrist and the rotation rows restore (a6, alpha6).
    const std::vector<std::string> restored =
        modified ? std::vector<std::string>{"theta6", "d6", "alpha7", "a7"} : std::vector<std::string>{"theta6", "alpha6", "a6", "d6"};
    for (const std::string& name : restored) {
      CHECK(isClass(D, name, ParamClass::kRelative));
      CHECK(isClass(DR, name, ParamClass::kIndependent));
    }
    // The SSRMS's parallel joints 3, 4, 5: d3 + d4 + d5 (distance), theta3 + theta4 + theta5 (rotation).
    if (modified) {
      REQUIRE(!D.groups.empty());
      CHECK(D.groups[0].names == std::vector<std::string>{"d3", "d4", "d5"});
      CHECK(D.groups[0].describe() == "d3, d4, d5: 2 directions lost; observable only as d3 + d4 + d5");
      REQUIRE(R.groups.size() == 1u);
      CHECK(R.groups[0].names == std::vector<std::string>{"theta3", "theta4", "theta5"});
    }
    // LSE and LM hold the ineffective ones and one per lost direction: the minimal set is estimated.
    const calib::Estimate lm = calib::runLm(calib::RelativePoseModel(km, pairs, calib::RelativeRows::kDistance), {});
    CHECK(lm.held == D.held);
  }
}

TEST_CASE("identifiability classes: range to a plane", "[calib][classes]") {
  using calib::ParamClass;
  for (const char* file : kArms) {
    CAPTURE(file);
    const sim::Arm arm = sim::loadArm(test::sourcePath(file));
    const sim::KinematicModel km = sim::flangeModel(arm);
    std::mt19937_64 rng(505);
    // A plane perpendicular to joint 1's axis (horizontal for the iiwa7: z + f = 0), offset f identified.
    const calib::Plane across{firstAxis(arm), 0.2, {3}};
    const calib::PlaneRangeModel probe(km, offsetBeam(), across, {});
    const calib::ParameterClasses H = classesOf(
        calib::PlaneRangeModel(km, offsetBeam(), across, ranges(km, offsetBeam(), across, Eigen::VectorXd::Zero(probe.numParams()), 100, rng)));
    INFO(H.describe());
    // theta1 rotates every hit point about the plane's normal: the range does not change.
    CHECK(isClass(H, "theta1", ParamClass::kIneffective));
    // d1 moves everything along the normal, as the offset f does: only d1 + f is observable.
    REQUIRE(H.groups.size() >= 1u);
    const auto g = std::find_if(H.groups.begin(), H.groups.end(),
                                [](const sim::Redundancy& r) { return r.names == std::vector<std::string>{"d1", "plane_f"}; });
    REQUIRE(g != H.groups.end());
    CHECK(g->describe() == "d1, plane_f: 1 direction lost; observable only as d1 + plane_f");
    // Liu et al. 2012's plane y + c z + f0 = 0 (c identified) is not perpendicular to joint 1: theta1 is seen.
    const calib::Plane tilted = calib::Plane::seed004();
    const calib::PlaneRangeModel probe2(km, offsetBeam(), tilted, {});
    const calib::ParameterClasses T = classesOf(
        calib::PlaneRangeModel(km, offsetBeam(), tilted, ranges(km, offsetBeam(), tilted, Eigen::VectorXd::Zero(probe2.numParams()), 100, rng)));
    INFO(T.describe());
    CHECK_FALSE(isClass(T, "theta1", ParamClass::kIneffective));
  }
}
