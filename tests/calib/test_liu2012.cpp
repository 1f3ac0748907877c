// Liu et al. 2012 (laser ranger to a plane, 6R PUMA-like arm in Hayati's convention):
// the identifiability the paper states on scenes/puma_hayati.yaml, the range-configuration generator
// and range simulator (relative_models.hpp), and the `liu2012` preset's machinery at reduced size
// (range_experiment.hpp).
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "orbcal/calib/marker_model.hpp"
#include "orbcal/calib/parameter_classes.hpp"
#include "orbcal/calib/range_experiment.hpp"
#include "orbcal/calib/relative_models.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/io.hpp"
#include "test_util.hpp"

using namespace orbcal;

namespace {

sim::Arm puma() { return sim::loadArm(test::sourcePath("scenes/puma_hayati.yaml")); }

/// The classes over `count` beam-hitting configurations (seeded) of the nominal arm, exact ranges.
calib::ParameterClasses classesOver(const sim::Arm& arm, const calib::Plane& plane, int count, std::uint64_t seed) {
  const sim::KinematicModel km = sim::flangeModel(arm);
  const calib::PlaneRangeModel probe(km, calib::LaserBeam{}, plane, {});
  auto rng = sim::makeRng(seed);
  const auto samples = calib::rangeConfigurations(probe, {}, count, rng);
  const Eigen::VectorXd p0 = Eigen::VectorXd::Zero(probe.numParams());
  const calib::PlaneRangeModel m(km, calib::LaserBeam{}, plane, calib::simulateRanges(probe, p0, samples, 0.2e-3, 10, rng, false));
  REQUIRE(m.numSamples() == count);
  return calib::classifyParameters(m, Eigen::VectorXd::Zero(m.numParams()));
}

calib::ParamClass classOf(const calib::ParameterClasses& c, const std::string& name) {
  for (std::size_t i = 0; i < c.names.size(); ++i) {
    if (c.names[i] == name) return c.classes[i];
  }
  FAIL("no parameter " << name);
  return calib::ParamClass::kIndependent;
}

}  // namespace

TEST_CASE("liu2012: the beam-hitting configurations satisfy every condition, averaged readings have sigma / sqrt(m)",
          "[calib][liu2012]") {
  const sim::Arm arm = puma();
  const sim::KinematicModel km = sim::flangeModel(arm);
  const calib::Plane plane = calib::Plane::seed004();
  const calib::PlaneRangeModel probe(km, calib::LaserBeam{}, plane, {});
  auto rng = sim::makeRng(7);
  const calib::RangeConfigurationSettings settings;  // h in [0.2, 3] m, |n^ . b| >= 0.3, non-singular
  const auto samples = calib::rangeConfigurations(probe, {}, 400, rng, settings);
  REQUIRE(samples.size() == 400u);
  const Eigen::VectorXd p0 = Eigen::VectorXd::Zero(probe.numParams());
  const Eigen::Vector3d n = Eigen::Vector3d(0, 1, 4.6).normalized();
  for (const auto& s : samples) {
    CHECK(sim::withinLimits(arm, s.q_rad));
    CHECK(sim::singularityMeasure(arm, s.q_rad, -1) >= settings.min_singular_value);
    const Eigen::Isometry3d T = sim::forwardKinematics(arm, s.q_rad);
    const double h = probe.predictRange(p0, s);
    CHECK(h >= 0.2);
    CHECK(h <= 3.0);
    CHECK(std::abs(n.dot(T.linear().col(2))) >= 0.3);  // the beam is +Z6
    // The hit point is on the plane y + 4.6 z - 0.69 = 0.
    const Eigen::Vector3d hit = T.translation() + h * T.linear().col(2);
    CHECK(std::abs(hit.y() + 4.6 * hit.z() - 0.69) < 1e-12);
  }
  // Readings: exact without noise; with 0.2 mm noise averaged over 10, the error's spread is
  // 0.2 / sqrt(10) = 0.0632 mm (400 samples: the sample deviation is within ~7% of it, 2 sigma).
  const auto exact = calib::simulateRanges(probe, p0, samples, 0.2e-3, 10, rng, false);
  const auto noisy = calib::simulateRanges(probe, p0, samples, 0.2e-3, 10, rng, true);
  double ss = 0.0;
  for (std::size_t k = 0; k < samples.size(); ++k) {
    CHECK(exact[k].range_m == Approx(probe.predictRange(p0, samples[k])).epsilon(1e-14));  // the mean of 10 equal readings
    CHECK(noisy[k].repeats == 10);
    ss += std::pow(noisy[k].range_m - exact[k].range_m, 2);
  }
  const double spread = std::sqrt(ss / static_cast<double>(samples.size()));
  CHECK(spread == Approx(0.2e-3 / std::sqrt(10.0)).epsilon(0.1));
  // The whole configuration space cannot satisfy an impossible range window.
  calib::RangeConfigurationSettings impossible;
  impossible.min_range_m = 100.0;
  impossible.max_range_m = 101.0;
  impossible.max_attempts = 500;
  CHECK_THROWS(calib::rangeConfigurations(probe, {}, 1, rng, impossible));
}

TEST_CASE("liu2012: 25 robot parameters and the plane coefficient c are identifiable (rank 26 of 31)", "[calib][liu2012]") {
  // Liu et al. 2012 section 3: full-pose measurement determines C = 4R + 2P + 6 = 30 parameters; the
  // ranger loses 5 constraints, so at most 25 robot parameters are identifiable, and the paper
  // identifies those 25 and the plane coefficient (Table 2, "identifiable parameters amount to 25").
  // Liu et al. 2012's plane y + c z - 0.69 = 0 with c identified, the tool offset a6 = 0.1 m, alpha6 = 30 deg
  // (our choice), 101 beam-hitting configurations (section 4.5).
  const calib::ParameterClasses c = classesOver(puma(), calib::Plane::seed004(), 101, 11);
  INFO(c.describe());
  REQUIRE(c.names.size() == 31u);  // 6 x 5 Hayati parameters + c
  CHECK(c.rank == 26);
  CHECK(classOf(c, "plane_nz") == calib::ParamClass::kIndependent);  // c itself is identifiable
  int robot_minimal = 0;
  for (int i : c.minimal) robot_minimal += c.names[static_cast<std::size_t>(i)] != "plane_nz";
  CHECK(robot_minimal == 25);
  CHECK(c.ineffective.empty());  // with the tool offset every parameter changes some range
  // The five lost directions are the parameterization's own (next test): the ranger loses nothing more.
  std::vector<std::vector<std::string>> groups;
  for (const auto& g : c.groups) groups.push_back(g.names);
  CHECK(groups == std::vector<std::vector<std::string>>{{"theta1", "beta1"}, {"d2", "d3"}, {"theta3", "beta3", "d4"},
                                                        {"theta4", "beta4"}, {"theta5", "beta5"}});
}

TEST_CASE("liu2012: on this arm the 5 lost directions are those full-pose data lose too", "[calib][liu2012]") {
  // By hand, five directions of the 30 Hayati parameters move no flange pose at all, so no measurement
  // sees them: beta_i turns frame i about y_i, which for alpha_i = +-90 deg is joint i's own axis (or
  // the next one's) through a point on it when a_i = 0: beta1 ~ theta1, beta4 ~ theta4, beta5 ~ theta5;
  // d2 and d3 translate along the parallel axes z1 and z2 (only d2 + d3); beta3 turns about an axis
  // parallel to joint 3's but a3 = 0.04 m off it, i.e. theta3 plus a translation a3 dtheta along z3,
  // which d4 makes (theta3, beta3, d4). Full-pose data therefore have rank 25, not Everett's 30 (which
  // counts 4 parameters per joint + 6), and the ranger's 5 lost constraints fall on these directions.
  const sim::Arm arm = puma();
  const sim::KinematicModel km = sim::flangeModel(arm);
  const calib::PlaneRangeModel probe(km, calib::LaserBeam{}, calib::Plane::seed004(), {});
  auto rng = sim::makeRng(14);
  std::vector<calib::MarkerObservation> poses;
  for (const auto& s : calib::rangeConfigurations(probe, {}, 101, rng)) poses.push_back({s, sim::forwardKinematics(arm, s.q_rad), true, {}});
  const calib::MarkerPoseModel full(km, poses, calib::MarkerNoise{});
  const calib::ParameterClasses f = calib::classifyParameters(full, Eigen::VectorXd::Zero(full.numParams()));
  INFO(f.describe());
  CHECK(f.rank == 25);
  std::vector<std::vector<std::string>> groups;
  for (const auto& g : f.groups) groups.push_back(g.names);
  CHECK(groups == std::vector<std::vector<std::string>>{{"theta1", "beta1"}, {"d2", "d3"}, {"theta3", "beta3", "d4"},
                                                        {"theta4", "beta4"}, {"theta5", "beta5"}});
}

TEST_CASE("liu2012: a horizontal plane hides theta1, a1 and d3, as the paper warns", "[calib][liu2012]") {
  // Liu et al. 2012 section 4.4: the plane must not be z + f = 0, or theta1, a1 and d3 make no
  // difference to the measured distance. By hand: theta1 rotates everything about the vertical z0;
  // a1 translates along x1 and d3 along z2, both horizontal (z1 is perpendicular to z0 as alpha1 =
  // 90 deg, and z2 is parallel to z1 as alpha2 = 0), and a horizontal plane is invariant to all three.
  const calib::Plane horizontal{Eigen::Vector3d::UnitZ(), -0.15, {}};  // z = 0.15 m, known
  const calib::ParameterClasses h = classesOver(puma(), horizontal, 101, 12);
  INFO(h.describe());
  for (const char* name : {"theta1", "a1", "d3"}) {
    CAPTURE(name);
    CHECK(classOf(h, name) != calib::ParamClass::kIndependent);
    CHECK(classOf(h, name) == calib::ParamClass::kIneffective);  // zero columns, by the argument above
  }
  // Liu et al. 2012's inclined plane sees all three (the paper's reason for choosing it).
  const calib::ParameterClasses t = classesOver(puma(), calib::Plane::seed004(), 101, 12);
  for (const char* name : {"theta1", "a1", "d3"}) CHECK(classOf(t, name) != calib::ParamClass::kIneffective);
  CHECK(h.rank < t.rank - 1);  // three parameters lost, c not identified here: at least two fewer
}

TEST_CASE("liu2012: with the beam on the joint-6 axis, theta6 is ineffective", "[calib][liu2012]") {
  // Without the tool offset (a6 = 0, alpha6 = 0) the beam starts on joint 6's axis and runs along it:
  // theta6 turns the beam about itself and no range changes (rank 25).
  sim::Arm arm = puma();
  arm.joints[5].a_m = 0.0;
  arm.joints[5].alpha_rad = 0.0;
  const calib::ParameterClasses c = classesOver(arm, calib::Plane::seed004(), 101, 13);
  INFO(c.describe());
  CHECK(classOf(c, "theta6") == calib::ParamClass::kIneffective);
  CHECK(c.rank == 25);  // one fewer than with the offset: theta6's direction
}

TEST_CASE("liu2012: the preset's machinery at reduced size identifies the arm and the plane", "[calib][liu2012]") {
  // Liu et al. 2012's protocol on 61 candidates, cases of 35 and 60, 10 validation
  // configurations: thermal length errors 1 mm/m, angles N(0, 3.49 mrad), c = 4.6 + 0.005.
  const sim::Arm arm = puma();
  const calib::PlaneRangeModel probe(sim::flangeModel(arm), calib::LaserBeam{}, calib::Plane::seed004(), {});
  Eigen::VectorXd p_true(probe.numParams());
  p_true << sim::thermalErrors(arm, 3.49e-3, 1e-3, 5), 0.005;
  calib::RangeExperimentSettings settings;
  settings.candidates = 61;
  settings.case_sizes = {35, 60};  // each more than the 26 identifiable parameters
  settings.validation = 10;
  const calib::RangeExperimentResult r = calib::runRangeExperiment(arm, p_true, settings, 5);
  REQUIRE(r.cases.size() == 2u);
  CHECK(r.rank == 26);                        // as over 101 configurations (test above)
  CHECK(r.held.size() == 5u);                 // 31 - 26
  const double sigma_mean = 0.2e-3 / std::sqrt(10.0);
  const double nominal = r.nominal_validation.position_rms_m.norm();
  for (const calib::RangeCaseResult& c : r.cases) {
    CAPTURE(c.size, c.residual_rms_before_m, c.residual_rms_after_m, c.validation.position_rms_m.norm(), nominal);
    CHECK(static_cast<int>(c.chosen.size()) == c.size);
    CHECK(c.estimate.converged);
    // The nominal model misses by far more than the noise; the fit leaves the noise (RMS of n - 26
    // degrees of freedom' worth of residuals: below sigma).
    CHECK(c.residual_rms_before_m > 50.0 * sigma_mean);
    CHECK(c.residual_rms_after_m < 1.2 * sigma_mean);
    // The plane coefficient: within 4 sigma of its true change 0.005.
    REQUIRE(c.plane_estimate.size() == 1);
    const int ic = probe.numParams() - 1;
    const double sigma_c = std::sqrt(c.estimate.covariance(ic, ic));
    CAPTURE(c.plane_estimate[0], sigma_c);
    CHECK(std::abs(c.plane_estimate[0] - 0.005) < 4.0 * sigma_c);
    CHECK(sigma_c < 0.005);  // and the data do determine it
  }
  // Case 2 (60 of 61) validates far better than the nominal model.
  CHECK(r.cases[1].validation.position_rms_m.norm() < 0.25 * nominal);
  CHECK(r.cases[1].validation.orientation_rms_rad.norm() < 0.5 * r.nominal_validation.orientation_rms_rad.norm());
  // The selection beats chance: O3 of the chosen 35 above the mean of random subsets of 35.
  CHECK(r.cases[0].indices.o3 > r.cases[0].random_o3);
  // sigma_min never falls when rows are added: the best 60 of 61 contain some superset of the 35.
  CHECK(r.cases[1].indices.o3 >= r.cases[0].indices.o3);
}
