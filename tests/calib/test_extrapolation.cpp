// Models that say where they hold: diagnose fitted on the 0 and 1.25 kg sessions of a simulated iiwa7
// predicts an unseen 5 kg session (torques well beyond the fitted range) near the noise when the truth
// is a linear compliance (it does not pick a cubic whose advantage lives inside the training range),
// and finds the cubic when the truth stiffens; the fitted ranges of the driving variables are recorded
// and the samples beyond them counted.
#include <catch2/catch.hpp>

#include <cmath>

#include "orbcal/calib/diagnose.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/simulate.hpp"
#include "test_util.hpp"

using namespace orbcal;

namespace {

/// The sessions of `all` listed in `sessions`, renumbered from 0 (their files and samples).
sim::MeasuredData sessionsOf(const sim::MeasuredData& all, const std::vector<int>& sessions) {
  sim::MeasuredData d = all;
  d.poses.clear();
  d.files.clear();
  for (std::size_t k = 0; k < sessions.size(); ++k) {
    d.files.push_back(all.files[static_cast<std::size_t>(sessions[k])]);
    for (const sim::MeasuredPose& p : all.poses) {
      if (p.sample.session != sessions[k]) continue;
      d.poses.push_back(p);
      d.poses.back().sample.session = static_cast<int>(k);
    }
  }
  return d;
}

struct World {
  sim::SimulatedData s;
  sim::MeasuredData train, heavy;  ///< 0 and 1.25 kg; 5 kg
};

/// The iiwa7 with seeded DH errors and `effect` at `values` (SI), measured by a tracker (0.05 mm, 0.01 deg,
/// stated) at 0, 1.25 and 5 kg, 100 configurations each.
World simulate(const std::string& effect, const Eigen::VectorXd& values, std::uint64_t seed) {
  const sim::Arm arm = sim::loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  sim::SimulationSpec spec;
  spec.samples = 300;
  spec.sessions = 3;
  spec.payload_kg = {0.0, 1.25, 5.0};
  spec.seed = seed;
  spec.geometry.seed = seed;
  spec.effects = {sim::parseEffect(effect, arm.numJoints(), "test")};
  spec.effect_values = values;
  World w{sim::simulateMeasured(arm, spec), {}, {}};
  w.s.data.noise_joint_rad = 0.0;
  w.train = sessionsOf(w.s.data, {0, 1});
  w.heavy = sessionsOf(w.s.data, {2});
  return w;
}

/// The position RMS of `model` predicting the 5 kg session (its marker refitted, as orbcal evaluate does).
double predictHeavy(const World& w, const calib::CalibratedModel& model) {
  calib::FitOptions fo;
  fo.sigma_position_m = w.heavy.noise_position_m;
  fo.sigma_rotation_rad = w.heavy.noise_rotation_rad;
  const auto obs = calib::observationsFrom(w.heavy, true);
  return calib::predictWithModel(model, w.heavy, obs, fo).residuals.position_rms_m;
}

/// The true model, as a calibrated one (its geometry errors folded in).
calib::CalibratedModel truthOf(const World& w) {
  sim::FoldedModel f = sim::foldParameters(w.s.truth, w.s.p_true);
  return {f.model, f.p};
}

double largestTorque(const sim::MeasuredData& d, int joint) {
  double t = 0.0;
  for (const sim::MeasuredPose& p : d.poses) t = std::max(t, std::abs(p.sample.tau_Nm[joint]));
  return t;
}

bool selects(const calib::Diagnosis& d, const std::string& spec) {
  return std::any_of(d.selected.begin(), d.selected.end(), [&](const sim::Effect& e) { return sim::formatEffect(e) == spec; });
}

}  // namespace

TEST_CASE("extrapolation: a linear compliance fitted at 0 and 1.25 kg predicts 5 kg within 1.3x the noise floor",
          "[calib][diagnose][extrapolation]") {
  // 1e-4 rad/(N m): the iiwa's harmonic drives (about 10^4 N m/rad); joints 2 and 4 carry the arm's weight.
  for (const auto& [joint, seed] : {std::pair<int, std::uint64_t>{2, 11}, {4, 12}}) {
    const std::string spec = "compliance:" + std::to_string(joint);
    const World w = simulate(spec, Eigen::VectorXd::Constant(1, 1e-4), seed);
    const auto obs = calib::observationsFrom(w.train, true);
    const calib::Diagnosis d = calib::diagnose(w.train, obs, calib::DiagnoseOptions{});
    // The truth predicts the 5 kg session at the noise floor (the tracker's noise and the refitted marker).
    const double floor = predictHeavy(w, truthOf(w));
    const calib::CalibratedModel selected = calib::calibratedModel(d.fit, obs);
    const double rms = predictHeavy(w, selected);
    CAPTURE(joint, d.verdict, floor, rms, largestTorque(w.train, joint - 1), largestTorque(w.heavy, joint - 1));
    REQUIRE(largestTorque(w.heavy, joint - 1) > 1.3 * largestTorque(w.train, joint - 1));  // a real extrapolation
    CHECK(selects(d, spec));
    CHECK_FALSE(selects(d, spec + "/3"));
    CHECK(rms < 1.3 * floor);
    // The selected compliance records the torque range it was fitted on; the 5 kg samples leave it.
    const auto it = std::find_if(selected.model.effects.begin(), selected.model.effects.end(),
                                 [&](const sim::Effect& e) { return sim::formatEffect(e) == spec; });
    REQUIRE(it != selected.model.effects.end());
    REQUIRE(it->fittedRanges().size() == 1);
    CHECK(it->fittedRanges()[0].column == "tau" + std::to_string(joint) + "_Nm");
    CHECK(it->fittedRanges()[0].hi - it->fittedRanges()[0].lo > 1.0);
    const std::vector<sim::RangeExcess> excess = calib::rangeExcesses(selected.model, calib::observationsFrom(w.heavy, true));
    const auto x = std::find_if(excess.begin(), excess.end(), [&](const sim::RangeExcess& r) { return r.effect == spec; });
    REQUIRE(x != excess.end());
    CHECK(x->outside > 0);
    CHECK(x->max_excess > 0.2 * largestTorque(w.train, joint - 1));
    CHECK(calib::rangeExcesses(selected.model, obs).front().outside == 0);  // the fitting data lie inside
  }
}

TEST_CASE("extrapolation: a true cubic stiffening fitted at 0 and 1.25 kg is found as the cubic", "[calib][diagnose][extrapolation]") {
  // As the open-world generator's stiffening joint: the cubic term c3 t^2 twice the linear one at the
  // largest training torque t, 1 mrad of deflection there in all.
  const int joint = 2;
  const World probe = simulate("compliance:2/3", Eigen::Vector2d(0.0, 0.0), 13);
  const double t = largestTorque(probe.train, joint - 1);
  const double c1 = 1e-3 / (3.0 * t), c3 = 2.0 * c1 / (t * t);
  const World w = simulate("compliance:2/3", Eigen::Vector2d(c1, c3), 13);
  const auto obs = calib::observationsFrom(w.train, true);
  const calib::Diagnosis d = calib::diagnose(w.train, obs, calib::DiagnoseOptions{});
  const double floor = predictHeavy(w, truthOf(w));
  const double rms = predictHeavy(w, calib::calibratedModel(d.fit, obs));
  CAPTURE(d.verdict, floor, rms);
  CHECK(selects(d, "compliance:2/3"));
  CHECK(rms < 1.3 * floor);
}
