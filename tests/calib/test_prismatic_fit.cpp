// A mobile manipulator (scenes/mobile_manipulator.urdf: a prismatic torso lift + a 7-DOF arm) measured
// by a simulated tracker: hidden errors on the prismatic joint (its zero offset, a scale error of its
// lead screw) and on an arm joint are recovered within 3 sigma; diagnose names an effect hidden on the
// prismatic joint.
#include <catch2/catch.hpp>
#include <algorithm>

#include "orbcal/calib/diagnose.hpp"
#include "orbcal/calib/measured_fit.hpp"
#include "orbcal/sim/identifiability.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/simulate.hpp"
#include "test_util.hpp"

using namespace orbcal;

namespace {

// Tracker noise 0.05 mm per axis (a laser tracker), as in test_measured_fit.cpp.
constexpr double kNoisePosition = 0.05e-3;

sim::Arm mobileArm() { return sim::loadArm(test::sourcePath("scenes/mobile_manipulator.urdf")); }

/// 400 samples, 2 sessions (payloads 0 and 1.25 kg), the tracker's frame known (a fixed mocap frame
/// registered to the base: so that the torso's zero offset is not a translation of that frame), the
/// marker estimated per session; random geometric errors (0.5 mm, 0.05 deg).
sim::SimulatedData simulate(const std::vector<sim::Effect>& effects, const Eigen::VectorXd& values, std::uint64_t seed) {
  sim::SimulationSpec spec;
  spec.samples = 400;
  spec.sessions = 2;
  spec.payload_kg = {0.0, 1.25};
  spec.seed = seed;
  spec.geometry.seed = seed;
  spec.base = sim::FrameSharing::kKnown;
  spec.effects = effects;
  spec.effect_values = values;
  spec.noise_position_m = kNoisePosition;
  return sim::simulateMeasured(mobileArm(), spec);
}

}  // namespace

TEST_CASE("mobile manipulator: the torso's offset and scale and an arm joint's scale recovered within 3 sigma",
          "[calib][prismatic]") {
  // Scales of 500 ppm on the torso (0.2 mm at its 0.4 m travel: 4 x the noise) and on joint 4 (the
  // elbow: 500 ppm of ~1 rad at 0.5 m lever is 0.25 mm).
  const std::vector<sim::Effect> effects = {sim::Scale{{0}}, sim::Scale{{3}}};
  const sim::SimulatedData s = simulate(effects, (Eigen::VectorXd(2) << 5e-4, -5e-4).finished(), 31);
  const sim::Arm& arm = s.data.arm;
  const std::vector<calib::MarkerObservation> obs = calib::observationsFrom(s.data, false);
  calib::FitOptions o;
  o.sigma_position_m = s.data.noise_position_m;
  o.sigma_rotation_rad = s.data.noise_rotation_rad;
  const calib::Fit fit = calib::fitMarkerModel(calib::startingModel(s.data, obs, effects), obs, o);

  // The effects' parameters, each within 3 sigma of the truth.
  for (const sim::ParamBlock& b : fit.model.layout.blocks()) {
    if (b.effect != "scale") continue;
    const int t = s.truth.layout.find(b.effect) + (b.joints.front() == 0 ? 0 : 1);
    REQUIRE(s.truth.layout.block(t).joints == b.joints);
    const double truth = s.p_true[s.truth.layout.block(t).offset], sigma = std::sqrt(fit.estimate.covariance(b.offset, b.offset));
    CAPTURE(b.params[0].name, fit.p[b.offset], truth, sigma);
    CHECK(sigma < 1e-4);  // determined to a fifth of the hidden value at least
    CHECK(std::abs(fit.p[b.offset] - truth) < 3.0 * sigma);
  }

  // The torso's zero offset: a slide along the vertical axis after T(xyz), which every vertical
  // translation of the chain above it repeats (its origin's z, and the z of each origin up the vertical
  // stack of the arm's first joint): parameters with the same Jacobian column at every posture, of which
  // the data determine the sum.
  const int g_fit = fit.model.layout.block(fit.model.layout.find("geometry")).offset;
  const int g_true = s.truth.layout.block(s.truth.layout.find("geometry")).offset;
  const int d1 = sim::jointParamIndex(arm, 0);
  REQUIRE(sim::paramName(arm, d1) == "d1");
  std::vector<Eigen::VectorXd> qs;
  for (const sim::MeasuredPose& p : s.data.poses) qs.push_back(p.sample.q_rad);
  const Eigen::MatrixXd J = sim::stackedJacobian(arm, qs);
  std::vector<int> same;
  for (int i = 0; i < arm.numParams(); ++i) {
    if ((J.col(i) - J.col(d1)).norm() < 1e-9 * J.col(d1).norm()) same.push_back(i);
  }
  CAPTURE(same.size());
  REQUIRE(std::find(same.begin(), same.end(), sim::paramIndex(arm, 0, sim::kOz)) != same.end());  // z1 among them
  double fitted = 0.0, truth = 0.0, variance = 0.0;
  for (int i : same) {
    fitted += fit.p[g_fit + i];
    truth += s.p_true[g_true + i];
    for (int k : same) variance += fit.estimate.covariance(g_fit + i, g_fit + k);
  }
  const double sigma = std::sqrt(variance);
  CAPTURE(fitted, truth, sigma);
  CHECK(std::abs(truth) > 3.0 * sigma);  // a real error, not one within the noise
  CHECK(std::abs(fitted - truth) < 3.0 * sigma);
}

TEST_CASE("diagnose names a scale error hidden on the prismatic torso", "[calib][prismatic][diagnose]") {
  // 1000 ppm on the torso: 0.4 mm at full travel, 8 x the tracker noise.
  const sim::SimulatedData s = simulate({sim::Scale{{0}}}, (Eigen::VectorXd(1) << 1e-3).finished(), 32);
  calib::DiagnoseOptions o;
  const calib::Diagnosis d = calib::diagnose(s.data, calib::observationsFrom(s.data, true), o);
  CAPTURE(d.verdict);
  bool named = false;
  for (const sim::Effect& e : d.selected) named = named || (e.name() == "scale" && e.joints() == std::vector<int>{0});
  CHECK(named);
}
