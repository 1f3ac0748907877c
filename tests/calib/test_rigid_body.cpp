// A rigid body of marker points on the tool (motion capture), used as measured: the point prediction's
// Jacobians against central differences; four markers, some missing in some rows, recover injected
// geometry errors and the points' offsets within 3 sigma; and with few postures and much noise the
// level chosen by cross-validation is a smaller one that predicts new postures better than the full set.
// The data are made here from a hand-built true model (not by orbcal simulate): an independent check.
#include <catch2/catch.hpp>
#include <random>

#include "jacobian_check.hpp"
#include "orbcal/calib/levels.hpp"
#include "orbcal/calib/measured_fit.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/marker_points.hpp"
#include "orbcal/sim/se3.hpp"
#include "test_util.hpp"

using namespace orbcal;

namespace {

const std::vector<Eigen::Vector3d> kPoints = {{0.08, 0.0, 0.05}, {-0.05, 0.07, 0.06}, {0.0, -0.09, 0.04}, {0.03, 0.03, 0.12}};

/// The true model: the iiwa7 seen from a tracker 2 m away (base frame unknown to the fit), four points
/// on the tool, and DH errors on the given parameters (by name; SI).
struct Truth {
  sim::KinematicModel model;
  Eigen::VectorXd p;
};
Truth makeTruth(const std::vector<std::pair<std::string, double>>& errors) {
  const sim::Arm arm = sim::loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  const Eigen::Isometry3d W = sim::fromXyzRpy({2.0, -0.5, 0.3}, Eigen::Vector3d(10, -100, 60) * sim::kDegToRad);
  Truth t{sim::makeKinematicModel(arm, 1, sim::FrameSharing::kShared, sim::FrameSharing::kKnown, {W},
                                  {Eigen::Isometry3d::Identity()}, {}, true, kPoints),
          {}};
  t.p = Eigen::VectorXd::Zero(t.model.layout.size());
  for (const auto& [name, value] : errors) {
    bool found = false;
    for (int i = 0; i < t.model.layout.size(); ++i) {
      if (t.model.layout.param(i).name == name) t.p[i] = value, found = true;
    }
    REQUIRE(found);
  }
  return t;
}

/// Rigid-body data of the truth at `postures` configurations (within 80% of each joint's range):
/// every point's position plus noise (sigma per axis), each point missing with probability `missing`
/// (a row keeps one at least), as loadMeasuredData would give it.
sim::MeasuredData measure(const Truth& t, int postures, double sigma_m, double missing, std::uint64_t seed) {
  sim::MeasuredData d;
  d.description = "rigid-body.yaml";
  d.arm = t.model.arm;
  d.robot_file = "scenes/iiwa7.yaml";
  d.files = {"session.csv"};
  d.base = sim::FrameSharing::kShared;
  d.marker = sim::FrameSharing::kShared;
  d.points = static_cast<int>(kPoints.size());
  d.noise_position_m = sigma_m;
  d.noise_rotation_rad = 0.01 * sim::kDegToRad;  // unused by positions; stated so that nothing is estimated
  auto rng = sim::makeRng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int r = 0; r < postures; ++r) {
    sim::MeasuredPose row;
    row.sample.session = 0;
    row.sample.q_rad.resize(d.arm.numJoints());
    for (int j = 0; j < d.arm.numJoints(); ++j) {
      const double mid = 0.5 * (d.arm.lower_rad[j] + d.arm.upper_rad[j]), half = 0.4 * (d.arm.upper_rad[j] - d.arm.lower_rad[j]);
      row.sample.q_rad[j] = mid + half * (2.0 * u(rng) - 1.0);
    }
    row.where = "session.csv: line " + std::to_string(r + 2);
    std::vector<int> seen;
    for (int k = 0; k < d.points; ++k) {
      if (u(rng) >= missing) seen.push_back(k);
    }
    if (seen.empty()) seen.push_back(r % d.points);
    for (const int k : seen) {
      sim::MeasuredPose p = row;
      p.point = k;
      p.has_rotation = false;
      Eigen::Vector3d e;
      for (int a = 0; a < 3; ++a) e[a] = sigma_m * n01(rng);
      p.world_T_marker.translation() = sim::predictMarkerPoint(t.model, t.p, p.sample, k) + e;
      d.poses.push_back(p);
    }
  }
  sim::fillApproachDirections(d.poses);
  return d;
}

calib::FitOptions statedNoise(const sim::MeasuredData& d) {
  calib::FitOptions o;
  o.sigma_position_m = d.noise_position_m;
  o.sigma_rotation_rad = d.noise_rotation_rad;
  return o;
}

/// Position RMS of a fitted model against the truth at `n` new postures (every point, noise-free).
double newPostureRms(const calib::Fit& fit, const Truth& t, int n) {
  double sum = 0.0;
  int count = 0;
  for (const Eigen::VectorXd& q : test::randomConfigs(t.model.arm, n, 99)) {
    sim::JointSample s;
    s.q_rad = q;
    s.direction = Eigen::VectorXd::Zero(q.size());
    for (int k = 0; k < static_cast<int>(kPoints.size()); ++k, ++count) {
      sum += (sim::predictMarkerPoint(fit.model, fit.p, s, k) - sim::predictMarkerPoint(t.model, t.p, s, k)).squaredNorm();
    }
  }
  return std::sqrt(sum / count);
}

}  // namespace

TEST_CASE("a marker point's Jacobians over the parameters and the joint readings match central differences", "[measured][jacobian]") {
  Truth t = makeTruth({{"theta3", 0.2 * sim::kDegToRad}, {"d5", 1e-3}});
  t.model = sim::makeKinematicModel(t.model.arm, 1, sim::FrameSharing::kShared, sim::FrameSharing::kKnown, t.model.world_T_base,
                                    t.model.flange_T_marker, {sim::Compliance{{1}}, sim::Thermal{}}, true, kPoints);
  Eigen::VectorXd p = Eigen::VectorXd::Zero(t.model.layout.size());
  auto rng = sim::makeRng(7);
  std::normal_distribution<double> n01(0.0, 1.0);
  const Eigen::VectorXd typical = t.model.layout.typical();
  for (int i = 0; i < p.size(); ++i) p[i] = 0.5 * typical[i] * n01(rng);  // every block away from zero (frames, points)
  for (const Eigen::VectorXd& q : test::randomConfigs(t.model.arm, 4, 11)) {
    sim::JointSample s;
    s.q_rad = q;
    s.tau_Nm = Eigen::VectorXd::Constant(q.size(), 20.0);
    s.temperature_C = 31.0;
    for (int k = 0; k < 4; ++k) {
      CAPTURE(q.transpose(), k);
      Eigen::MatrixXd J_p, J_q;
      sim::predictMarkerPoint(t.model, p, s, k, &J_p, &J_q);
      const auto f = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd { return sim::predictMarkerPoint(t.model, x, s, k); };
      const auto name = [&](int c) { return t.model.layout.param(c).name; };
      REQUIRE(test::requireJacobianMatches(f, J_p, p, typical, name) > 1e-4);  // not comparing zeros
      const auto g = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd {
        sim::JointSample sx = s;
        sx.q_rad = x;
        return sim::predictMarkerPoint(t.model, p, sx, k);
      };
      const Eigen::VectorXd one_deg = Eigen::VectorXd::Constant(q.size(), sim::kDegToRad);
      REQUIRE(test::requireJacobianMatches(g, J_q, q, one_deg, [](int c) { return "q" + std::to_string(c + 1); }) > 1e-4);
    }
  }
}

TEST_CASE("four markers, some missing: geometry errors and the points' offsets recovered within 3 sigma", "[measured]") {
  // Errors a few tenths of a degree and of a millimetre on joints the data identifies (the first
  // joint's and the last joint's parameters trade with the base frame and with the points).
  const std::vector<std::pair<std::string, double>> errors = {
      {"theta2", 0.05 * sim::kDegToRad}, {"theta4", -0.04 * sim::kDegToRad}, {"alpha3", 0.03 * sim::kDegToRad},
      {"d3", 0.4e-3}, {"d5", -0.3e-3}};
  const Truth t = makeTruth(errors);
  // 120 postures of a motion-capture system with 0.1 mm noise per axis; a quarter of the points missing.
  const sim::MeasuredData d = measure(t, 120, 0.1e-3, 0.25, 5);
  REQUIRE(d.poses.size() < 120u * 4u);  // some are missing
  const std::vector<calib::MarkerObservation> obs = calib::observationsFrom(d, false);
  const calib::Fit fit = calib::fitMarkerModel(calib::startingModel(d, obs, {}), obs, statedNoise(d));
  const sim::ParamLayout& L = fit.model.layout;
  double worst = 0.0, injected = 1e9;
  for (int i = 0; i < L.size(); ++i) {
    const std::string& name = L.param(i).name;
    const int b = L.blockOf(i);
    if (L.block(b).effect != "geometry") continue;
    int ti = 0;
    while (t.model.layout.param(ti).name != name) ++ti;
    const bool held = std::binary_search(fit.estimate.held.begin(), fit.estimate.held.end(), i);
    CAPTURE(name, fit.p[i], t.p[ti], held);
    if (held) {
      CHECK(t.p[ti] == 0.0);  // an injected error must be identifiable here
      continue;
    }
    const double sigma = std::sqrt(fit.estimate.covariance(i, i));
    worst = std::max(worst, std::abs(fit.p[i] - t.p[ti]) / sigma);
    if (t.p[ti] != 0.0) injected = std::min(injected, std::abs(t.p[ti]) / sigma);
  }
  CHECK(worst < 3.0);
  CHECK(injected > 5.0);  // the nominal arm (zero) would fail the 3-sigma check: the data resolves every injected error
  const std::vector<Eigen::Vector3d> points = sim::foldedMarkerPoints(fit.model, fit.p);
  for (int k = 0; k < 4; ++k) {
    const int o = L.block(sim::pointBlockIndex(fit.model, k)).offset;
    for (int a = 0; a < 3; ++a) {
      const double sigma = std::sqrt(fit.estimate.covariance(o + a, o + a));
      CAPTURE(k, a, points[k][a], kPoints[k][a], sigma);
      CHECK(std::abs(points[k][a] - kPoints[k][a]) < 3.0 * sigma);
    }
  }
  // And the calibrated model predicts new postures to a fraction of the noise (0.17 mm RMS of a 3-D error).
  CHECK(newPostureRms(fit, t, 50) < 0.05e-3);
}

TEST_CASE("with 37 noisy postures cross-validation picks a smaller level, which predicts new postures better", "[measured][level]") {
  // Joint zero offsets wrong by a tenth of a degree, the rest of the geometry exact; 37 postures of a
  // motion-capture system at 1 mm per axis: 40-odd free parameters of the full set fit much of that noise.
  const Truth t = makeTruth({{"theta2", 0.1 * sim::kDegToRad}, {"theta3", -0.1 * sim::kDegToRad}, {"theta4", 0.12 * sim::kDegToRad},
                             {"theta5", -0.08 * sim::kDegToRad}, {"theta6", 0.1 * sim::kDegToRad}});
  const sim::MeasuredData d = measure(t, 37, 1e-3, 0.1, 21);
  const std::vector<calib::MarkerObservation> obs = calib::observationsFrom(d, false);
  const calib::LevelChoice c = calib::chooseLevel(d, obs, {}, statedNoise(d), 1);
  INFO(calib::levelSentence(c));
  REQUIRE(c.scores.size() == 4);
  REQUIRE(c.configurations == 37);
  // The premise, measured on 200 new postures of the truth: the full set predicts worse than the chosen.
  const sim::KinematicModel start = calib::startingModel(d, obs, {});
  const auto fitAt = [&](calib::LevelKind kind) {
    return calib::fitMarkerModel(start, obs, calib::levelOptions(statedNoise(d), start, {kind, {}}, "level"));
  };
  const double full = newPostureRms(fitAt(calib::LevelKind::kFull), t, 200);
  const double chosen = newPostureRms(fitAt(c.chosen.kind), t, 200);
  CAPTURE(full, chosen);
  CHECK(c.chosen.kind != calib::LevelKind::kFull);
  CHECK(chosen < full);
}
