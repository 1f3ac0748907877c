// The consistency test of a fit (calib/consistency.hpp): honest noise passes, understated noise and a
// single gross error fail, and the gross sample is the one named.
#include <catch2/catch.hpp>
#include <random>

#include "orbcal/calib/consistency.hpp"
#include "orbcal/calib/estimators.hpp"
#include "orbcal/calib/planning.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "test_util.hpp"

using namespace orbcal;

namespace {

/// A pose fit of 60 iiwa7 poses whose noise is `actual` x the sigma the model assumes, sample 17 moved by
/// `gross_m` along x; returns the test at the LM estimate.
calib::Consistency fitWith(double actual, double gross_m, std::uint64_t seed) {
  const sim::Arm arm = sim::loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  const sim::KinematicModel km = sim::flangeModel(arm);
  const Eigen::VectorXd y_true = sim::randomErrors(arm, 0.1 * sim::kDegToRad, 1e-3, seed);
  calib::MeasurementSetup setup;
  setup.noise.sigma_position_m = 0.1e-3;
  setup.noise.sigma_rotation_rad = 0.01 * sim::kDegToRad;
  calib::MarkerNoise drawn = setup.noise;
  drawn.sigma_position_m *= actual;
  drawn.sigma_rotation_rad *= actual;
  std::mt19937_64 rng(seed);
  auto poses = calib::simulatePoses(km, y_true, calib::samplesOf(test::randomConfigs(arm, 60, seed)), 0.0, drawn, rng);
  poses[17].world_T_marker.translation().x() += gross_m;
  const auto model = calib::modelFromPoses(setup, km, poses);
  const calib::Estimate e = calib::runLm(*model, {});
  return calib::consistencyTest(*model, e.y, model->numParams() - static_cast<int>(e.held.size()));
}

}  // namespace

TEST_CASE("consistency: honest noise passes, in every one of 5 seeds", "[calib][consistency]") {
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    CAPTURE(seed);
    const calib::Consistency c = fitWith(1.0, 0.0, seed);
    INFO(calib::formatConsistency(c));
    // 360 rows - 28 free parameters (the iiwa7's 28 DH errors are all identifiable from full poses: no
    // consecutive axes are parallel); chi2 / dof within a few standard errors (sqrt(2 / 332) ~ 0.08) of 1.
    CHECK(c.dof == 360 - 28);
    CHECK(c.ratio() > 0.7);
    CHECK(c.ratio() < 1.3);
    CHECK(c.consistent());
  }
}

TEST_CASE("consistency: noise twice what the model assumes fails overall", "[calib][consistency]") {
  const calib::Consistency c = fitWith(2.0, 0.0, 3);
  INFO(calib::formatConsistency(c));
  CHECK(c.ratio() > 3.0);  // ~4 expected
  CHECK(c.p < c.alpha);
  CHECK_FALSE(c.consistent());
}

TEST_CASE("consistency: one gross sample is named, and only it", "[calib][consistency]") {
  // 2 mm on a 0.1 mm measurement: 20 sigma before the fit absorbs a little of it.
  const calib::Consistency c = fitWith(1.0, 2e-3, 4);
  INFO(calib::formatConsistency(c));
  REQUIRE(c.outliers.size() == 1u);
  CHECK(c.outliers[0] == 17);
  CHECK_FALSE(c.consistent());
  CHECK(calib::formatConsistency(c).find("1 of 60 samples inconsistent") != std::string::npos);
}
