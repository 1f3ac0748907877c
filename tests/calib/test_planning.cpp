// Every measurement kind built in one place (calib/planning.hpp): names, planning models with zero
// innovation, what position-only data cannot see, agreement of two independent pose models'
// observability indices, and the pose simulator's noise.
#include <catch2/catch.hpp>
#include <random>

#include "orbcal/calib/observability.hpp"
#include "orbcal/calib/parameter_classes.hpp"
#include "orbcal/calib/planning.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "test_util.hpp"

using namespace orbcal;
using calib::MeasurementKind;

namespace {


bool ineffective(const calib::ParameterClasses& c, const std::string& name) {
  for (int p : c.ineffective) {
    if (c.names[static_cast<std::size_t>(p)] == name) return true;
  }
  return false;
}

}  // namespace

TEST_CASE("measurement kinds: names round-trip, an unknown one names the option and the choices", "[calib][planning]") {
  for (MeasurementKind k : {MeasurementKind::kPose, MeasurementKind::kPosition, MeasurementKind::kDistance,
                            MeasurementKind::kRotation, MeasurementKind::kDistanceRotation, MeasurementKind::kRange}) {
    CHECK(calib::parseMeasurementKind(calib::measurementKindName(k), "--model") == k);
    CHECK_FALSE(calib::measurementKindDescription(k).empty());
  }
  CHECK_THROWS_WITH(calib::parseMeasurementKind("laser", "--model"),
                    "--model: 'laser' is not a measurement kind (one of pose, position, distance, rotation, dr, range)");
  CHECK(calib::isRelativeKind(MeasurementKind::kDistanceRotation));
  CHECK_FALSE(calib::isRelativeKind(MeasurementKind::kPosition));
  CHECK_FALSE(calib::isPoseKind(MeasurementKind::kRange));
}

TEST_CASE("planning models: every kind predicts its own observations exactly at the start", "[calib][planning]") {
  const sim::Arm arm = sim::loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  const sim::KinematicModel km = sim::flangeModel(arm);
  const auto samples = calib::samplesOf(test::randomConfigs(arm, 20, 3));
  for (MeasurementKind k : {MeasurementKind::kPose, MeasurementKind::kPosition, MeasurementKind::kDistance,
                            MeasurementKind::kRotation, MeasurementKind::kDistanceRotation, MeasurementKind::kRange}) {
    CAPTURE(calib::measurementKindName(k));
    calib::MeasurementSetup setup;
    setup.kind = k;
    const auto m = calib::planningModel(setup, km, samples);
    // Pose kinds: one sample per configuration, or per pair against the first (19); range: the
    // configurations whose beam is not parallel to the plane (all of them, to round-off).
    const int expected = calib::isRelativeKind(k) ? 19 : 20;
    CHECK(m->numSamples() <= expected);
    CHECK(m->numSamples() >= expected - 2);  // the relative guard may drop a pair with a tiny angle
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(m->numParams());
    for (int s = 0; s < m->numSamples(); ++s) CHECK(m->linearize(s, zero).innovation.cwiseAbs().maxCoeff() < 1e-9);
  }
}

TEST_CASE("position only: rotations about the measured point are invisible, the full pose sees them", "[calib][planning]") {
  // The iiwa7's flange is frame 7 (no tool), on joint 7's axis (a7 = 0): theta7 turns the flange about
  // that axis and alpha7 about its own x axis, both through the flange origin, so neither moves the point.
  const sim::Arm arm = sim::loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  const sim::KinematicModel km = sim::flangeModel(arm);
  const auto samples = calib::samplesOf(test::randomConfigs(arm, 40, 5));
  calib::MeasurementSetup setup;
  setup.kind = MeasurementKind::kPosition;
  const auto position = calib::planningModel(setup, km, samples);
  setup.kind = MeasurementKind::kPose;
  const auto pose = calib::planningModel(setup, km, samples);
  const calib::ParameterClasses P = calib::classifyParameters(*position, Eigen::VectorXd::Zero(position->numParams()));
  const calib::ParameterClasses F = calib::classifyParameters(*pose, Eigen::VectorXd::Zero(pose->numParams()));
  INFO(P.describe());
  CHECK(ineffective(P, "theta7"));
  CHECK(ineffective(P, "alpha7"));
  CHECK_FALSE(ineffective(F, "theta7"));
  CHECK_FALSE(ineffective(F, "alpha7"));
  CHECK(F.rank > P.rank);
}

TEST_CASE("observability: the marker model of a pose kind and Wang et al. 2023's pose model agree", "[calib][planning]") {
  // Two independent implementations of the same measurement (MarkerPoseModel over the kinematic model,
  // pose model over the identification Jacobian) must give the same whitened Jacobian's
  // singular values, so the same O1-O5.
  const sim::Arm arm = sim::loadArm(test::sourcePath("scenes/ssrms.yaml"));
  const auto configs = test::randomConfigs(arm, 30, 11);
  calib::MeasurementSetup setup;
  setup.noise.sigma_position_m = 0.3e-3;
  setup.noise.sigma_rotation_rad = 0.5 * sim::kDegToRad;
  const auto marker = calib::planningModel(setup, sim::flangeModel(arm), calib::samplesOf(configs));
  calib::PoseNoiseModel noise;
  noise.sigma_position_m = setup.noise.sigma_position_m;
  noise.sigma_orientation_rad = setup.noise.sigma_rotation_rad;
  const calib::MarkerPoseModel seed000 = calib::posePlanningModel(arm, configs, noise);
  REQUIRE(marker->numParams() == seed000.numParams());
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(seed000.numParams());
  const std::vector<int> held = calib::unidentifiableToFix(seed000, zero);
  CHECK(calib::unidentifiableToFix(*marker, zero) == held);
  const calib::ObservabilityIndices a = calib::observability(*marker, zero, held);
  const calib::ObservabilityIndices b = calib::observability(seed000, zero, held);
  CHECK(a.rank == b.rank);
  CHECK(a.o1 == Approx(b.o1).epsilon(1e-9));
  CHECK(a.o3 == Approx(b.o3).epsilon(1e-9));
  CHECK(a.o5 == Approx(b.o5).epsilon(1e-9));
  CHECK(a.o3 > 0.0);
}

TEST_CASE("simulated poses: exact without noise, the asked sigmas with it", "[calib][planning]") {
  const sim::Arm arm = sim::loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  const sim::KinematicModel km = sim::flangeModel(arm);
  const Eigen::VectorXd p = Eigen::VectorXd::Zero(km.layout.size());
  const auto samples = calib::samplesOf(test::randomConfigs(arm, 2000, 17));
  std::mt19937_64 rng(23);
  calib::MarkerNoise none;
  none.sigma_position_m = none.sigma_rotation_rad = 0.0;
  const auto exact = calib::simulatePoses(km, p, samples, 0.0, none, rng);
  for (std::size_t k = 0; k < 5; ++k) {
    CHECK((exact[k].world_T_marker.matrix() - sim::predictMarkerPose(km, p, samples[k]).matrix()).cwiseAbs().maxCoeff() < 1e-15);
  }
  calib::MarkerNoise noise;
  noise.sigma_position_m = 0.2e-3;
  noise.sigma_rotation_rad = 0.05 * sim::kDegToRad;
  const auto noisy = calib::simulatePoses(km, p, samples, 0.0, noise, rng);
  Eigen::VectorXd sum2 = Eigen::VectorXd::Zero(6);
  for (std::size_t k = 0; k < samples.size(); ++k) {
    CHECK(noisy[k].sample.q_rad == samples[k].q_rad);  // the observation keeps the commanded joints
    sum2 += sim::poseMinus(noisy[k].world_T_marker, sim::predictMarkerPose(km, p, samples[k])).cwiseAbs2();
  }
  // 2000 draws per axis: the sample sigma is within 5% of the truth (about 3 standard errors).
  const Eigen::VectorXd sigma = (sum2 / static_cast<double>(samples.size())).cwiseSqrt();
  for (int i = 0; i < 6; ++i) {
    CHECK(sigma[i] == Approx(i < 3 ? noise.sigma_position_m : noise.sigma_rotation_rad).epsilon(0.05));
  }
}
