// Recovery of hidden effects from simulated tracker data: for each catalog effect, data simulated with
// it (seeded joints and magnitudes, random DH errors, unknown tracker and marker frames) and fitted
// with it returns the injected parameters within 3 sigma, and the fitted model predicts the true
// marker poses to a fraction of the tracker noise. Also: fitting without the effect leaves it visible.
#include <catch2/catch.hpp>
#include <random>

#include "orbcal/calib/marker_model.hpp"
#include "orbcal/calib/measured_fit.hpp"
#include "orbcal/sim/identifiability.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/sim/simulate.hpp"
#include "test_util.hpp"

using namespace orbcal;

namespace {

// Magnitudes (the catalog's typical values, sim/src/model.cpp; the simulator draws each parameter
// from N(0, typical) with |value| >= typical / 2): compliance 1e-4 rad/(N m), a joint stiffness of
// 1e4 N m/rad as in the iiwa's harmonic drives; cyclic 0.01 deg, about the 1 arcmin transmission error
// of a harmonic drive; scale 200 ppm; backlash 0.01 deg; thermal 23 ppm/K (aluminium) over the
// simulator's 10 K warm-up; drift 1 mm/h and 0.01 deg/h; mount 10 mm and 1 deg between sessions.
// Tracker noise 0.05 mm and 0.01 deg per axis (a laser tracker or a good optical system).
constexpr double kNoisePosition = 0.05e-3;

struct Case {
  std::string inject;
  std::uint64_t seed;
};

sim::SimulatedData simulate(const sim::Arm& arm, const std::vector<sim::Effect>& effects, std::uint64_t seed,
                            sim::FrameSharing marker = sim::FrameSharing::kPerSession, double joint_noise_rad = 0.0,
                            int samples = 200) {
  sim::SimulationSpec spec;
  spec.joint_noise_rad = joint_noise_rad;
  spec.marker = marker;
  spec.samples = samples;
  spec.sessions = 2;
  spec.payload_kg = {0.0, 1.25};
  spec.seed = seed;
  spec.geometry.seed = seed;
  spec.effects = effects;
  spec.noise_position_m = kNoisePosition;
  return sim::simulateMeasured(arm, spec);
}

/// Largest |fitted - true| / sigma over the effect parameters, and the RMS of the fitted model's
/// position error against the true model on noise-free samples of the same sessions.
struct Recovery {
  double worst_sigma = 0.0;
  double prediction_rms_m = 0.0;
  double chi2 = 0.0;
};

Recovery recover(const sim::SimulatedData& s, const std::vector<sim::Effect>& fit_effects) {
  const std::vector<calib::MarkerObservation> obs = calib::observationsFrom(s.data, calib::needsTorque(fit_effects));
  const sim::KinematicModel start = calib::startingModel(s.data, obs, fit_effects);
  calib::FitOptions o;
  o.sigma_position_m = s.data.noise_position_m;
  o.sigma_rotation_rad = s.data.noise_rotation_rad;
  const calib::Fit fit = calib::fitMarkerModel(start, obs, o);
  Recovery r;
  for (const sim::ParamBlock& b : fit.model.layout.blocks()) {
    if (b.effect == "base" || b.effect == "marker" || b.effect == "geometry") continue;
    const int t = s.truth.layout.find(b.effect, b.session);
    REQUIRE(t >= 0);
    for (int i = 0; i < b.size(); ++i) {
      const int k = b.offset + i;
      REQUIRE_FALSE(std::binary_search(fit.estimate.held.begin(), fit.estimate.held.end(), k));
      const double sigma = std::sqrt(fit.estimate.covariance(k, k));
      const double truth = s.p_true[s.truth.layout.block(t).offset + i];
      CAPTURE(b.params[static_cast<std::size_t>(i)].name, fit.p[k], truth, sigma);
      r.worst_sigma = std::max(r.worst_sigma, std::abs(fit.p[k] - truth) / sigma);
    }
  }
  double sum = 0.0;
  for (const calib::MarkerObservation& x : obs) {
    const Eigen::Isometry3d truth = sim::predictMarkerPose(s.truth, s.p_true, x.sample);
    const Eigen::Isometry3d fitted = sim::predictMarkerPose(fit.model, fit.p, x.sample);
    sum += (truth.translation() - fitted.translation()).squaredNorm();
  }
  r.prediction_rms_m = std::sqrt(sum / static_cast<double>(obs.size()));
  r.chi2 = fit.chi2;
  return r;
}

}  // namespace

TEST_CASE("each hidden effect is recovered within 3 sigma from unknown tracker and marker frames", "[measured]") {
  const sim::Arm arm = sim::loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  REQUIRE_FALSE(arm.masses.empty());  // torques come from the robot file's masses
  std::mt19937_64 rng(8);
  const auto joint = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
  // Seeded draws of the joint; the magnitude is drawn by the simulator from its seed. Compliance on
  // the joints that carry load (2, 4, 6: the others hold ~0 N m about vertical-ish axes); the angle
  // effects on joints 1..6 (joint 7 turns the marker about the flange axis at a 0.1 m lever: 0.01 deg
  // moves it by 17 um, a third of the tracker noise).
  const std::vector<sim::Effect> cases = {
      sim::Compliance{{2 * joint(0, 2) + 1}}, sim::Cyclic{{joint(0, 5)}, 2}, sim::Scale{{joint(0, 5)}},
      sim::Backlash{{joint(0, 5)}},           sim::Thermal{},               sim::Drift{},
      sim::Mount{}};
  std::uint64_t seed = 100;
  for (const sim::Effect& e : cases) {
    CAPTURE(sim::formatEffect(e));
    // A mount change is a change of a marker shared by the sessions.
    const bool mount = e.name() == "mount";
    // 400 samples: an angle effect of joint 6 (0.2 m from the marker) at half its typical 0.01 deg moves
    // the marker by about a third of the noise, which 200 samples detect only at the edge of the test below.
    const sim::SimulatedData s =
        simulate(arm, {e}, ++seed, mount ? sim::FrameSharing::kShared : sim::FrameSharing::kPerSession, 0.0, 400);
    const Recovery r = recover(s, {e});
    CHECK(r.worst_sigma < 3.0);
    // A consistent fit predicts to ~ noise x sqrt(parameters / rows) ~ 0.2 x the per-axis noise; the
    // bound is the per-axis noise itself.
    CHECK(r.prediction_rms_m < kNoisePosition);
    // Without the effect the fit is significantly worse: a chi-square increase of 25 for the effect's
    // 1..12 parameters has a probability below 2e-3 (12 dof) to 6e-7 (1 dof) where the effect is absent.
    const Recovery without = recover(s, {});
    CHECK(without.chi2 - r.chi2 > 25.0);
  }
}

TEST_CASE("effects compose: compliance + cyclic + thermal recovered together", "[measured]") {
  const sim::Arm arm = sim::loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  const std::vector<sim::Effect> effects = {sim::Compliance{{1, 3}}, sim::Cyclic{{4}, 2}, sim::Thermal{}};
  const sim::SimulatedData s = simulate(arm, effects, 42);
  const Recovery r = recover(s, effects);
  CHECK(r.worst_sigma < 3.0);
  CHECK(r.prediction_rms_m < kNoisePosition);
}

TEST_CASE("position-only tracker data: frames from the point-set start, compliance recovered", "[measured]") {
  const sim::Arm arm = sim::loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  sim::SimulationSpec spec;
  spec.samples = 200;
  spec.seed = 5;
  spec.rotation = false;
  spec.marker = sim::FrameSharing::kShared;
  spec.payload_kg = {1.0};
  spec.effects = {sim::Compliance{{1, 3}}};
  const sim::SimulatedData s = sim::simulateMeasured(arm, spec);
  const Recovery r = recover(s, spec.effects);
  CHECK(r.worst_sigma < 3.0);
  CHECK(r.prediction_rms_m < kNoisePosition);
}

TEST_CASE("a starting model made from another's frames is the one startingModel makes", "[measured]") {
  // startingModelFrom keeps the closed-form frames of a start with other effects (diagnose guesses them
  // once); the effects adapted to the observations as startingModel adapts them (a compliance's torque
  // scale: its joints' RMS torque). Two sessions with a marker each; position-only data; three marker points.
  const sim::Arm arm = sim::loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  const std::vector<sim::Effect> effects = {sim::Compliance{{2, 4}}, sim::Thermal{}};
  struct Case {
    int sessions, markers;
    bool rotation;
  };
  for (const Case c : {Case{2, 0, true}, Case{1, 0, false}, Case{1, 3, false}}) {
    sim::SimulationSpec spec;
    spec.samples = 60;
    spec.sessions = c.sessions;
    spec.payload_kg = {0.0};
    spec.marker = c.sessions > 1 ? sim::FrameSharing::kPerSession : sim::FrameSharing::kShared;
    spec.rotation = c.rotation;
    spec.markers = c.markers;
    spec.seed = 8;
    spec.effects = effects;
    const sim::SimulatedData s = sim::simulateMeasured(arm, spec);
    const std::vector<calib::MarkerObservation> obs = calib::observationsFrom(s.data, true);
    const sim::KinematicModel direct = calib::startingModel(s.data, obs, effects);
    const sim::KinematicModel from = calib::startingModelFrom(calib::startingModel(s.data, obs, {sim::Scale{{1}}}), obs, effects);
    CAPTURE(c.sessions, c.markers, c.rotation);
    REQUIRE(from.layout.size() == direct.layout.size());
    for (int i = 0; i < direct.layout.size(); ++i) CHECK(from.layout.param(i).name == direct.layout.param(i).name);
    REQUIRE(from.effects.size() == effects.size());
    for (std::size_t k = 0; k < effects.size(); ++k) {
      CHECK(from.effects[k].spec() == direct.effects[k].spec());
      CHECK(from.effects[k].reference() == direct.effects[k].reference());
    }
    CHECK(direct.effects[0].reference() != sim::Effect(sim::Compliance{{2, 4}}).reference());  // adapted: not the catalog's 50 N m
    REQUIRE(from.world_T_base.size() == direct.world_T_base.size());
    REQUIRE(from.flange_T_marker.size() == direct.flange_T_marker.size());
    REQUIRE(from.marker_points.size() == static_cast<std::size_t>(c.markers));
    for (std::size_t k = 0; k < direct.world_T_base.size(); ++k) CHECK(from.world_T_base[k].matrix() == direct.world_T_base[k].matrix());
    for (std::size_t k = 0; k < direct.flange_T_marker.size(); ++k) {
      CHECK(from.flange_T_marker[k].matrix() == direct.flange_T_marker[k].matrix());
    }
    for (std::size_t k = 0; k < direct.marker_points.size(); ++k) CHECK(from.marker_points[k] == direct.marker_points[k]);
    // The guess is a real one (not the data's identity frames): the tracker stands metres from the base.
    CHECK(direct.world_T_base[0].translation().norm() > 1.0);
  }
}

TEST_CASE("a model with all-joint compliance says which compliances this data cannot identify", "[measured]") {
  // Joint 1 is vertical: tau_1 is the torque sensor's noise alone, so c1 is numerically identifiable
  // but determined no better than its typical magnitude.
  const sim::Arm arm = sim::loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  const sim::SimulatedData s = simulate(arm, {}, 9);
  const std::vector<sim::Effect> effects = {sim::Compliance{{0, 1, 2, 3, 4, 5, 6}}};
  const std::vector<calib::MarkerObservation> obs = calib::observationsFrom(s.data, true);
  const calib::Fit fit = calib::fitMarkerModel(calib::startingModel(s.data, obs, effects), obs, {});
  std::vector<std::string> weak;
  for (int i : fit.weak) weak.push_back(fit.model.layout.param(i).name);
  CAPTURE(weak);
  CHECK(std::find(weak.begin(), weak.end(), "c1") != weak.end());
  CHECK(std::find(weak.begin(), weak.end(), "c2") == weak.end());  // joint 2 carries the arm
  // The noise was estimated from the residuals: within 20% of the simulated 0.05 mm.
  CHECK(fit.noise_estimated);
  CHECK(fit.noise.sigma_position_m == Approx(kNoisePosition).epsilon(0.2));
}

TEST_CASE("joint reading noise is estimated as a variance component beside the tracker's", "[measured]") {
  // Encoders whose readings differ from the true angles by N(0, 0.01 deg) (Wang et al. 2023's control
  // noise) put a configuration-dependent share into every residual: about 0.17 mm at 1 m of reach,
  // three times the tracker's 0.05 mm. The truth is the simulator's sigma; 200 samples of 6 rows
  // estimate a standard deviation to a few percent (sd of a variance estimate ~ sqrt(2 / n)).
  const sim::Arm arm = sim::loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  const double joint_sigma = 0.01 * sim::kDegToRad;
  for (const std::uint64_t seed : {31u, 32u}) {
    const sim::SimulatedData s = simulate(arm, {}, seed, sim::FrameSharing::kPerSession, joint_sigma);
    const std::vector<calib::MarkerObservation> obs = calib::observationsFrom(s.data, false);
    const sim::KinematicModel start = calib::startingModel(s.data, obs, {});
    CAPTURE(seed);
    // The tracker's sigmas given (as the description states them), the joint noise estimated.
    calib::FitOptions given;
    given.sigma_position_m = s.data.noise_position_m;
    given.sigma_rotation_rad = s.data.noise_rotation_rad;
    given.estimate_joint_noise = true;
    const calib::Fit a = calib::fitMarkerModel(start, obs, given);
    CHECK(a.noise.joint_noise_sigma_rad == Approx(joint_sigma).epsilon(0.15));
    CHECK(a.noise.sigma_position_m == *s.data.noise_position_m);
    // Every component estimated: the tracker's too.
    calib::FitOptions all;
    all.estimate_joint_noise = true;
    const calib::Fit b = calib::fitMarkerModel(start, obs, all);
    CHECK(b.noise.joint_noise_sigma_rad == Approx(joint_sigma).epsilon(0.15));
    CHECK(b.noise.sigma_position_m == Approx(kNoisePosition).epsilon(0.25));
    CHECK(b.noise.sigma_rotation_rad == Approx(*s.data.noise_rotation_rad).epsilon(0.25));
    // Whitened with the estimate, the fit is consistent: chi-square per degree of freedom near 1,
    // where the tracker's noise alone makes it several times too large.
    CHECK(a.chi2 / a.dof == Approx(1.0).margin(0.15));
    calib::FitOptions tracker_only = given;
    tracker_only.estimate_joint_noise = false;
    const calib::Fit c = calib::fitMarkerModel(start, obs, tracker_only);
    CHECK(c.chi2 / c.dof > 3.0);
  }
  // Without joint noise in the data the component stays small (well below the 0.01 deg above).
  const sim::SimulatedData clean = simulate(arm, {}, 33);
  const std::vector<calib::MarkerObservation> obs = calib::observationsFrom(clean.data, false);
  calib::FitOptions o;
  o.sigma_position_m = clean.data.noise_position_m;
  o.sigma_rotation_rad = clean.data.noise_rotation_rad;
  o.estimate_joint_noise = true;
  const calib::Fit f = calib::fitMarkerModel(calib::startingModel(clean.data, obs, {}), obs, o);
  CHECK(f.noise.joint_noise_sigma_rad < 0.002 * sim::kDegToRad);
}

TEST_CASE("every estimator keeps a held parameter at its starting value", "[measured][hold]") {
  // A prediction with a calibrated model (calib::predictWithModel) holds the geometry and the effects
  // at the model's values and refits the frames alone: an estimator that let a held parameter move
  // would change the model it is asked to evaluate. The held parameter starts 1 mm off its nominal
  // value; left free, the data (random DH errors of typical size 5 mm) move it, so each check can fail.
  const sim::Arm arm = sim::loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  const sim::SimulatedData s = simulate(arm, {sim::Compliance{{1, 3}}}, 77);
  const std::vector<sim::Effect> effects = {sim::Compliance{{1, 3}}};
  const std::vector<calib::MarkerObservation> obs = calib::observationsFrom(s.data, true);
  const sim::KinematicModel start = calib::startingModel(s.data, obs, effects);
  const sim::ParamLayout& L = start.layout;
  const int geometry = L.find("geometry", -1);
  REQUIRE(geometry >= 0);
  const sim::ParamBlock& g = L.block(geometry);
  // The second joint's length parameter: moved by the data (checked below), not a round-off column.
  int held = -1;
  for (int i = 0; i < g.size() && held < 0; ++i) {
    const sim::ParamInfo& p = g.params[static_cast<std::size_t>(i)];
    if (p.quantity == sim::Quantity::kLength && i >= 4) held = g.offset + i;
  }
  REQUIRE(held >= 0);
  CAPTURE(L.param(held).name);
  Eigen::VectorXd p0 = Eigen::VectorXd::Zero(L.size());
  p0[held] = 1e-3;
  for (const char* method : {"LM", "LSE", "EKF"}) {
    CAPTURE(method);
    calib::FitOptions o;
    o.method = method;
    o.sigma_position_m = s.data.noise_position_m;
    o.sigma_rotation_rad = s.data.noise_rotation_rad;
    const calib::Fit free = calib::fitMarkerModel(start, obs, o, p0);
    CHECK(std::abs(free.p[held] - p0[held]) > 1e-5);  // 10 um: the data do move it
    o.hold = {held};
    const calib::Fit fit = calib::fitMarkerModel(start, obs, o, p0);
    CHECK(fit.p[held] == p0[held]);
    CHECK(std::binary_search(fit.estimate.held.begin(), fit.estimate.held.end(), held));
  }
}

TEST_CASE("the LM on normal equations accumulated per block of samples stops where Ceres's QR solve stops", "[measured][long-log]") {
  // LmOptions::normal_equations solves with J^T J and J^T f summed a block of samples at a time (no
  // stacked Jacobian: a long log's is gigabytes); Ceres's DENSE_QR solve of the stacked Jacobian is the
  // independent reference. Both minimize one cost to a function tolerance of 1e-10 of it, so the
  // estimates agree to a small fraction of their standard deviations and the costs to ~1e-10.
  const sim::Arm arm = sim::loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  const std::vector<sim::Effect> effects = {sim::Compliance{{1, 3}}, sim::Cyclic{{4}, 2}};
  const sim::SimulatedData s = simulate(arm, effects, 77, sim::FrameSharing::kPerSession, 0.0, 300);
  const std::vector<calib::MarkerObservation> obs = calib::observationsFrom(s.data, true);
  const sim::KinematicModel start = calib::startingModel(s.data, obs, effects);
  calib::FitOptions o;
  o.sigma_position_m = s.data.noise_position_m;
  o.sigma_rotation_rad = s.data.noise_rotation_rad;
  const calib::Fit qr = calib::fitMarkerModel(start, obs, o);
  o.normal_equations = true;
  const calib::Fit streamed = calib::fitMarkerModel(start, obs, o);
  REQUIRE(qr.estimate.converged);
  REQUIRE(streamed.estimate.converged);
  REQUIRE(streamed.estimate.held == qr.estimate.held);
  CHECK(streamed.chi2 == Approx(qr.chi2).epsilon(1e-8));
  int compared = 0;
  for (int i = 0; i < start.layout.size(); ++i) {
    if (std::binary_search(qr.estimate.held.begin(), qr.estimate.held.end(), i)) continue;
    const double sigma = std::sqrt(qr.estimate.covariance(i, i));
    CAPTURE(start.layout.param(i).name, qr.p[i], streamed.p[i], sigma);
    CHECK(std::abs(streamed.p[i] - qr.p[i]) < 0.01 * sigma);
    // The covariance from the R factor of the whitened Jacobian, accumulated per sample.
    CHECK(std::sqrt(streamed.estimate.covariance(i, i)) == Approx(sigma).epsilon(1e-6));
    ++compared;
  }
  CHECK(compared > 40);
  // The identifiability analysis from that R factor against the stacked whitened Jacobian's SVD.
  const calib::MarkerPoseModel m(start, obs, qr.noise, qr.p0);
  const Eigen::MatrixXd J = calib::whitenedJacobian(m, Eigen::VectorXd::Zero(m.numParams()));
  const sim::ScaledSvd svd = sim::scaledSvd(J, sim::kRankTolerance, false);
  CHECK(streamed.identifiability.num_rows == J.rows());
  CHECK(streamed.identifiability.rank == svd.rank);
  REQUIRE(streamed.identifiability.singular_values.size() == svd.singular_values.size());
  for (int i = 0; i < svd.rank; ++i) {
    CHECK(streamed.identifiability.singular_values[i] == Approx(svd.singular_values[i]).epsilon(1e-8));
  }
}
