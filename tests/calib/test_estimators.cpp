// The estimators on the paper's own setting (synthetic pose measurements).
#include <catch2/catch.hpp>

#include "orbcal/calib/estimators.hpp"
#include "orbcal/calib/experiment.hpp"
#include "orbcal/calib/synthetic.hpp"
#include "orbcal/calib/validation.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/io.hpp"

using namespace orbcal;

namespace {

struct Fixture {
  sim::Arm nominal = sim::loadArm(sim::kDefaultRobot);
  sim::Scene scene = sim::loadScene(sim::kDefaultScene);
  Eigen::VectorXd y_true = sim::paperTable3Errors();
  sim::Arm truth = sim::withErrors(nominal, y_true);
  std::vector<Eigen::VectorXd> configs(int n, std::uint64_t seed) const {
    sim::GeneratorSettings g;
    g.count = n;
    g.seed = seed;
    return sim::generateConfigurations(nominal, scene, g);
  }
};

// Indices in the SSRMS's layout (modified DH: 4 per joint, arm.hpp).
constexpr int kPerJoint = 4;
constexpr int kD3 = kPerJoint * 2 + sim::kD, kD4 = kPerJoint * 3 + sim::kD, kD5 = kPerJoint * 4 + sim::kD;

// Absolute floor for parameters whose true error is zero: 1e-12 m or rad (round-off of a 20 m chain).
constexpr double kZeroFloor = 1e-12;

/// Checks every identifiable combination of y against y_true: each parameter outside {d3, d4, d5}
/// individually, and d3 + d4 + d5 as a sum (the only combination of those three that is observable).
void checkIdentifiable(const Eigen::VectorXd& y, const Eigen::VectorXd& y_true, double rel_tol) {
  for (int i = 0; i < y.size(); ++i) {
    if (i == kD3 || i == kD4 || i == kD5) continue;
    CAPTURE(i, y[i], y_true[i]);
    CHECK(std::abs(y[i] - y_true[i]) <= rel_tol * std::abs(y_true[i]) + kZeroFloor);
  }
  const double sum = y[kD3] + y[kD4] + y[kD5], sum_true = y_true[kD3] + y_true[kD4] + y_true[kD5];
  CAPTURE(sum, sum_true);
  CHECK(std::abs(sum - sum_true) <= rel_tol * std::abs(sum_true));
}

}  // namespace

namespace {
/// LSE (unweighted and weighted) and LM on exact poses of an arm with errors y_true; checks the
/// identifiable combinations to rel_tol and that d4, d5 are reported (held) as unidentifiable.
void recoverNoiseFree(const Fixture& f, const Eigen::VectorXd& y_true, double rel_tol) {
  auto rng = sim::makeRng(1);
  const calib::PlantSamples plant = calib::simulatePlant(sim::withErrors(f.nominal, y_true), f.configs(50, 1), 0.0, rng);
  std::vector<calib::PoseObservation> obs = calib::syntheticObservations(plant, 0.0, 0.0, rng);
  for (auto& o : obs) o.covariance = sim::Matrix6d::Identity() * 1e-12;  // weights must exist; data are exact
  const calib::MarkerPoseModel model = calib::poseModel(f.nominal, obs, {});
  // The unidentifiable ones are reported as such: two of d3, d4, d5 are held, the third carries the sum.
  const std::vector<int> held = calib::unidentifiableToFix(model, Eigen::VectorXd::Zero(28));
  CHECK(held == std::vector<int>{kD4, kD5});
  calib::LseOptions lse;
  for (bool weighted : {false, true}) {
    lse.weighted = weighted;
    const calib::Estimate e = calib::runLse(model, lse);
    CAPTURE(e.method);
    CHECK(e.converged);
    CHECK(e.rank == 26);
    CHECK(e.held == held);
    checkIdentifiable(e.y, y_true, rel_tol);
  }
  const calib::Estimate lm = calib::runLm(model, {});
  CHECK(lm.converged);
  CHECK(lm.rank == 26);
  CHECK(lm.held == held);
  checkIdentifiable(lm.y, y_true, rel_tol);
}
}  // namespace

TEST_CASE("noise-free poses: every identifiable combination recovered to 1e-6 relative", "[calib][estimators]") {
  // Table 3 without its alpha errors on joints 4 and 5, which are what keep z3 || z4 || z5 in the true
  // arm: then d3, d4, d5 are exactly redundant in the truth too, and the rest is recovered exactly.
  const Fixture f;
  Eigen::VectorXd y = f.y_true;
  y[sim::paramIndex(f.nominal, 3, sim::kAlpha)] = 0.0;
  y[sim::paramIndex(f.nominal, 4, sim::kAlpha)] = 0.0;
  recoverNoiseFree(f, y, 1e-6);
}

TEST_CASE("noise-free poses with all of Table 3: within 1e-3, limited by the weakly redundant d3, d4, d5", "[calib][estimators]") {
  // Table 3's alpha errors (+-0.3 deg) tilt z4 and z5 against z3 in the true arm, so holding d4 and d5
  // at zero leaves 0.8 mm x sin(0.3 deg) ~ 4 um of unmodelled offset, which biases the rest at ~1e-4.
  const Fixture f;
  recoverNoiseFree(f, f.y_true, 1e-3);
  // The iterated EKF processes the samples one by one from a prior: close, but not exact after one pass.
  auto rng = sim::makeRng(1);
  const calib::PlantSamples plant = calib::simulatePlant(f.truth, f.configs(50, 1), 0.0, rng);
  std::vector<calib::PoseObservation> obs = calib::syntheticObservations(plant, 0.0, 0.0, rng);
  for (auto& o : obs) o.covariance = sim::Matrix6d::Identity() * 1e-12;
  calib::EkfOptions iekf;
  iekf.iterations_per_update = 3;
  checkIdentifiable(calib::runEkf(calib::poseModel(f.nominal, obs, {}), iekf).y, f.y_true, 2e-2);
}

TEST_CASE("the paper-literal EKF equals the batch information-form solution", "[calib][ekf]") {
  // With Q = 0 and J at the nominal parameters, eqs. (11)-(17) are recursive least squares: after all
  // n updates, y = (P0^-1 + sum H^T R^-1 H)^-1 sum H^T R^-1 Z and P = (P0^-1 + sum H^T R^-1 H)^-1.
  const Fixture f;
  auto rng = sim::makeRng(2);
  const calib::PlantSamples plant = calib::simulatePlant(f.truth, f.configs(30, 2), 0.01 * sim::kDegToRad, rng);
  const auto obs = calib::syntheticObservations(plant, 0.3e-3, 0.5 * sim::kDegToRad, rng);
  const calib::MarkerPoseModel model = calib::poseModel(f.nominal, obs, {});
  const calib::EkfOptions paper = calib::EkfOptions::paperLiteral();
  const calib::Estimate e = calib::runEkf(model, paper);

  Eigen::VectorXd p0(28);
  for (int i = 0; i < 28; ++i) p0[i] = sim::isAngleParam(f.nominal, i) ? paper.prior_sigma_angle_rad : paper.prior_sigma_length_m;
  Eigen::MatrixXd info = p0.array().square().inverse().matrix().asDiagonal();
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(28);
  for (int k = 0; k < model.numSamples(); ++k) {
    const calib::Linearization lin = model.linearize(k, Eigen::VectorXd::Zero(28));
    const Eigen::MatrixXd HtRi = lin.H.transpose() * lin.R.inverse();
    info += HtRi * lin.H;
    rhs += HtRi * lin.innovation;
  }
  const Eigen::VectorXd y_batch = info.ldlt().solve(rhs);
  const Eigen::MatrixXd P_batch = info.inverse();
  CHECK((e.y - y_batch).norm() <= 1e-8 * y_batch.norm());
  CHECK((e.covariance - P_batch).norm() <= 1e-6 * P_batch.norm());
}

TEST_CASE("the measurement covariance with joint noise is honest, without it, it is not", "[calib][model]") {
  // At the true parameters the innovation is measurement noise plus the joint noise seen through J_q.
  // nu^T R^-1 nu is then chi-square with 6 degrees of freedom: mean 6, and over 300 samples the mean's
  // standard deviation is sqrt(12/300) = 0.2, so [5.2, 6.8] is a +-4 sigma band.
  const Fixture f;
  auto rng = sim::makeRng(3);
  const double joint_sigma = 0.01 * sim::kDegToRad;
  const calib::PlantSamples plant = calib::simulatePlant(f.truth, f.configs(300, 3), joint_sigma, rng);
  const auto obs = calib::syntheticObservations(plant, 0.1e-3, 0.01 * sim::kDegToRad, rng);
  calib::PoseNoiseModel with_joints;
  with_joints.joint_noise_sigma_rad = joint_sigma;
  const calib::MarkerPoseModel honest = calib::poseModel(f.nominal, obs, with_joints), blind = calib::poseModel(f.nominal, obs, {});
  const double mean_honest = 2.0 * calib::weightedCost(honest, f.y_true) / 300.0;
  const double mean_blind = 2.0 * calib::weightedCost(blind, f.y_true) / 300.0;
  CHECK(mean_honest > 5.2);
  CHECK(mean_honest < 6.8);
  CHECK(mean_blind > 30.0);  // 0.01 deg on a 17 m arm is ~3 mm, against 0.1 mm of pose noise
}

TEST_CASE("Table 3 errors, paper noise: EKF and LM improve position and every orientation axis by 90%", "[calib][table4]") {
  // Wang et al. 2023 reports 90.4% (position) and 91.0 / 95.2 / 93.0% (X / Y / Z orientation) for its EKF.
  const Fixture f;
  auto rng = sim::makeRng(4);
  const double joint_sigma = 0.01 * sim::kDegToRad;
  const calib::PlantSamples ident = calib::simulatePlant(f.truth, f.configs(50, 4), joint_sigma, rng);
  const calib::PlantSamples valid = calib::simulatePlant(f.truth, f.configs(200, 5), joint_sigma, rng);
  const auto obs = calib::syntheticObservations(ident, 0.3e-3, 0.5 * sim::kDegToRad, rng);
  calib::PoseNoiseModel noise;
  noise.joint_noise_sigma_rad = joint_sigma;
  const calib::MarkerPoseModel model = calib::poseModel(f.nominal, obs, noise);
  const calib::ErrorSummary initial = calib::summarize(calib::poseErrors(f.nominal, valid));
  // The floor: what the true parameters leave on the same validation samples (the control noise alone).
  const calib::ErrorSummary floor = calib::summarize(calib::poseErrors(f.truth, valid));
  for (const calib::Estimate& e : {calib::runEkf(model, {}), calib::runLm(model, {})}) {
    const calib::ErrorSummary after = calib::summarize(calib::poseErrors(sim::withErrors(f.nominal, e.y), valid));
    CAPTURE(e.method, initial.position_avg_m, after.position_avg_m, floor.position_avg_m);
    INFO(e.method << ": after / floor = " << after.position_avg_m / floor.position_avg_m << " (position), "
                  << (after.orientation_avg_rad.array() / floor.orientation_avg_rad.array()).transpose() << " (X Y Z)");
    // Wang et al. 2023's claim, kept as stated; alone it would pass at 3.9 x the floor (initial = 39 x floor).
    CHECK(calib::improvement(initial.position_avg_m, after.position_avg_m) >= 0.90);
    // The bound with teeth: the main job's runs land at 1.02-1.09 x floor. 1.25 leaves margin for this
    // test's smaller draw (50 identification, 200 validation samples); measured 1.04 (EKF), 1.04 (LM).
    CHECK(after.position_avg_m <= 1.25 * floor.position_avg_m);
    // Orientation keeps only the 90% bar (which allows 3.8-4.9 x floor): with Wang et al. 2023's 0.5 deg
    // orientation noise, about the size of the initial orientation errors, the orientation parameters
    // come from the positions alone and land at 2.4-3.5 x the orientation floor here (1.0-1.05 x with
    // 0.05 deg of orientation noise), so a floor bound would only restate the 90% bar.
    for (int a = 0; a < 3; ++a) {
      CAPTURE(a, initial.orientation_avg_rad[a], after.orientation_avg_rad[a], floor.orientation_avg_rad[a]);
      CHECK(calib::improvement(initial.orientation_avg_rad[a], after.orientation_avg_rad[a]) >= 0.90);
    }
  }
}

TEST_CASE("validation arithmetic", "[calib][validation]") {
  // Wang et al. 2023 Table 4: EKF average position 24.2930 -> 2.3335 mm is a 90.3944% improvement.
  CHECK(calib::improvement(24.2930, 2.3335) == Approx(0.903944).margin(1e-6));
  const Fixture f;
  auto rng = sim::makeRng(6);
  const calib::PlantSamples plant = calib::simulatePlant(f.truth, f.configs(20, 6), 0.0, rng);
  const calib::ErrorSummary exact = calib::summarize(calib::poseErrors(f.truth, plant));
  CHECK(exact.position_max_m < 1e-12);
  CHECK(exact.orientation_max_rad.maxCoeff() < 1e-12);
  const calib::ErrorSummary nominal = calib::summarize(calib::poseErrors(f.nominal, plant));
  CHECK(nominal.position_avg_m > 0.01);  // Table 3's errors move a 17 m arm's flange by centimetres
  CHECK(nominal.position_max_m >= nominal.position_avg_m);
}

TEST_CASE("every estimator of the comparison keeps a held parameter at zero", "[calib][estimators][hold]") {
  // Table 3's errors move every identifiable parameter away from zero; held, a1 (0.5 mm in Table 3)
  // must stay at exactly zero whatever the estimator (the EKF through a zero prior variance, LSE and
  // LM by leaving its column out).
  const Fixture f;
  auto rng = sim::makeRng(7);
  const double joint_sigma = 0.01 * sim::kDegToRad;
  const calib::PlantSamples plant = calib::simulatePlant(f.truth, f.configs(40, 7), joint_sigma, rng);
  const auto obs = calib::syntheticObservations(plant, 0.3e-3, 0.5 * sim::kDegToRad, rng);
  const int held = sim::paramIndex(f.nominal, 1, sim::kA);
  REQUIRE(f.y_true[held] != 0.0);
  for (calib::MethodSpec m : calib::comparisonMethods(joint_sigma)) {
    CAPTURE(m.name);
    const calib::MarkerPoseModel model = calib::poseModel(f.nominal, obs, m.noise);
    const calib::Estimate free = calib::runMethod(m, model);
    CHECK(std::abs(free.y[held]) > 1e-6);  // 1 um: the data do move it
    m.ekf.hold = m.lse.hold = m.lm.hold = {held};
    const calib::Estimate e = calib::runMethod(m, model);
    CHECK(e.y[held] == 0.0);
    CHECK(std::binary_search(e.held.begin(), e.held.end(), held));
    CHECK(e.rank <= 27);
  }
}

namespace {

/// Dennis and Schnabel's (1983, example 10.2.4) slowly converging least-squares problem in u, residuals
/// u + 1 and lambda u^2 + u - 1 (minimum at u = 0, the cost's curvature 2 - 2 lambda there against
/// J^T J's 2: for lambda = -0.9 a Gauss-Newton step lands 0.9 times as far beyond the minimum as it
/// started before it), beside a linear direction v, residual v - 1. The parameters are
/// y = ((u + v), (u - v)) / sqrt(2), so that neither is one parameter's own direction.
class SlowGaussNewton : public calib::MeasurementModel {
 public:
  static constexpr double kLambda = -0.9;
  SlowGaussNewton() {
    sim::ParamBlock b;
    b.effect = "toy";
    b.kind = sim::BlockKind::kOther;
    for (const char* name : {"y0", "y1"}) b.params.push_back(sim::ParamInfo{name, "1", "1", 1.0, 1.0, sim::Quantity::kOther, -1});
    layout_.add(b);
  }
  static double u(const Eigen::VectorXd& y) { return (y[0] + y[1]) / std::sqrt(2.0); }
  static double v(const Eigen::VectorXd& y) { return (y[0] - y[1]) / std::sqrt(2.0); }
  int numSamples() const override { return 3; }
  int rows(int) const override { return 1; }
  const sim::ParamLayout& layout() const override { return layout_; }
  calib::Linearization linearize(int k, const Eigen::VectorXd& y) const override {
    const double x = u(y), s = 1.0 / std::sqrt(2.0);
    double r = 0.0, dr_du = 0.0, dr_dv = 0.0;
    if (k == 0) r = x + 1.0, dr_du = 1.0;
    if (k == 1) r = kLambda * x * x + x - 1.0, dr_du = 2.0 * kLambda * x + 1.0;
    if (k == 2) r = v(y) - 1.0, dr_dv = 1.0;
    calib::Linearization l;
    l.innovation = Eigen::VectorXd::Constant(1, r);
    l.H = Eigen::MatrixXd(1, 2);
    l.H << -(dr_du + dr_dv) * s, -(dr_du - dr_dv) * s;  // nu = z - h: H = -d nu / dy
    l.R = Eigen::MatrixXd::Identity(1, 1);
    return l;
  }

 private:
  sim::ParamLayout layout_;
};

}  // namespace

TEST_CASE("the streamed LM stops within a hundredth of a standard deviation of a minimum its steps overshoot", "[estimators][lm]") {
  // From u = 0.3 (0.6 standard deviations: 1 / sqrt(2 - 2 lambda) = 0.51) and v = 0. Its stopping rule
  // (the Gauss-Newton model's remaining decrease below 1e-6 in the noise's units) is met only within
  // about 0.0015 standard deviations of the minimum, whatever the steps' overshoot.
  const SlowGaussNewton m;
  calib::LmOptions o;
  o.normal_equations = true;
  o.fix_unidentifiable = false;
  o.covariance = false;
  o.start = Eigen::Vector2d(0.3, 0.3) / std::sqrt(2.0);
  const calib::Estimate e = calib::runLm(m, o);
  const double sigma_u = 1.0 / std::sqrt(2.0 - 2.0 * SlowGaussNewton::kLambda), sigma_v = 1.0;
  CAPTURE(SlowGaussNewton::u(e.y), SlowGaussNewton::v(e.y), e.iterations);
  CHECK(e.converged);
  CHECK(std::abs(SlowGaussNewton::u(e.y)) < 0.01 * sigma_u);
  CHECK(std::abs(SlowGaussNewton::v(e.y) - 1.0) < 0.01 * sigma_v);
  CHECK(e.cost - 1.0 < 1e-4);  // 1/2 (1 + 1) at the minimum; 1e-4 is 0.014 standard deviations along u
  CHECK(e.cost >= 1.0 - 1e-12);
}
