// The corner-level measurement model of image datasets (calib/corner_model.hpp): its whole Jacobian
// against central differences of the innovation, with and without chain effects, at a camera with
// every distortion coefficient non-zero; every estimator runs on it; noise-free corners of a
// distorted camera give the distortion back.
#include <catch2/catch.hpp>
#include <random>

#include "orbcal/calib/corner_model.hpp"
#include "orbcal/calib/estimators.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "jacobian_check.hpp"
#include "test_util.hpp"

using namespace orbcal;

namespace {

struct Setup {
  sim::Scene scene;
  sim::KinematicModel model;
  std::vector<calib::CornerObservation> obs;
};

/// The quick scene's camera and board on the SSRMS, world = the board, marker = the camera (both
/// frames estimated), `effects` in the chain; `n` views; corners projected through `taken` (the
/// model at p_true) plus Gaussian noise of `noise_px`.
Setup makeSetup(const std::vector<sim::Effect>& effects, int n, const Eigen::VectorXd* p_true, const sim::Camera* taken,
                double noise_px, std::uint64_t seed) {
  Setup s;
  s.scene = sim::loadScene(test::sourcePath("scenes/quick_scene.yaml"));
  const sim::Arm arm = sim::loadArm(test::sourcePath("scenes/ssrms.yaml"));
  s.model = sim::makeKinematicModel(arm, 1, sim::FrameSharing::kShared, sim::FrameSharing::kShared,
                                    {s.scene.base_T_board.inverse()}, {s.scene.flange_T_camera}, effects);
  sim::GeneratorSettings g;
  g.count = n;
  g.seed = seed;
  const std::vector<Eigen::VectorXd> qs = sim::generateConfigurations(arm, s.scene, g);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> N(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const Eigen::VectorXd p = p_true ? *p_true : Eigen::VectorXd::Zero(s.model.layout.size());
  const sim::Camera cam = taken ? *taken : s.scene.camera;
  for (const Eigen::VectorXd& q : qs) {
    calib::CornerObservation o;
    o.sample.q_rad = q;
    o.sample.tau_Nm = Eigen::VectorXd::NullaryExpr(q.size(), [&] { return -60.0 + 120.0 * u(rng); });
    o.sample.direction = Eigen::VectorXd::NullaryExpr(q.size(), [&] { return u(rng) < 0.5 ? -1.0 : 1.0; });
    o.sample.temperature_C = 30.0;
    o.sample.time_s = 600.0;
    const Eigen::Isometry3d camera_T_board = sim::predictMarkerPose(s.model, p, o.sample).inverse();
    for (int i = 0; i < s.scene.board.numCorners(); ++i) {
      o.corners_px.push_back(sim::project(cam, camera_T_board * sim::cornerInBoard(s.scene.board, i)) +
                             noise_px * Eigen::Vector2d(N(rng), N(rng)));
    }
    s.obs.push_back(std::move(o));
  }
  return s;
}

/// Every view's H against central differences of its innovation (tests/jacobian_check.hpp), in
/// pixels: the column entries are 1e-3..1e2 px, round-off ~1e-16 x 1e3 px / 1e-3 = 1e-10 px, so the
/// absolute floor is 1e-8 px.
void checkJacobian(const calib::CornerMeasurementModel& m, const Eigen::VectorXd& y) {
  test::JacobianTolerance tol;
  tol.absolute = 1e-8;
  for (int k = 0; k < m.numSamples(); ++k) {
    const calib::Linearization lin = m.linearize(k, y);
    REQUIRE(lin.H.rows() == m.rows(k));
    REQUIRE(lin.H.cols() == m.numParams());
    CAPTURE(k);
    const auto f = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd { return -m.linearize(k, x).innovation; };
    const double largest = test::requireJacobianMatches(f, lin.H, y, m.layout().typical(), [&](int c) { return m.paramName(c); }, tol);
    REQUIRE(largest > 1e-3);  // a typical parameter moves some corner by more than a thousandth of a pixel
  }
}

sim::Camera distortedCamera(const sim::Camera& c) {
  sim::Camera d = c;
  d.distortion = {-0.12, 0.05, 1.5e-3, -8e-4, 0.01};  // every term of the polynomial exercised
  return d;
}

}  // namespace

TEST_CASE("corner model: the whole Jacobian matches central differences, with and without chain effects", "[calib][corner]") {
  for (const std::vector<sim::Effect>& effects :
       {std::vector<sim::Effect>{}, std::vector<sim::Effect>{sim::Cyclic{{1}, 2}, sim::Thermal{}, sim::Backlash{{3}}}}) {
    CAPTURE(effects.size());
    Setup s = makeSetup(effects, 3, nullptr, nullptr, 0.0, 11);
    s.scene.camera = distortedCamera(s.scene.camera);
    const calib::CornerMeasurementModel m(s.model, s.scene.camera, s.scene.board, s.obs, {});
    REQUIRE(m.numParams() == s.model.layout.size() + 4);
    REQUIRE(m.paramName(m.distortionOffset()) == "dk1");
    // Away from the start: every parameter at a random fraction of its typical magnitude.
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const Eigen::VectorXd y = m.layout().typical().unaryExpr([&](double t) { return t * u(rng); });
    checkJacobian(m, y);
    checkJacobian(m, Eigen::VectorXd::Zero(m.numParams()));
  }
}

TEST_CASE("corner model: eye to hand (a fixed camera, the board on the flange), its Jacobian matches central differences",
          "[calib][corner]") {
  Setup s = makeSetup({sim::Cyclic{{1}, 2}}, 1, nullptr, nullptr, 0.0, 11);
  const sim::Camera taken = s.scene.camera;  // the corners' camera
  s.scene.camera = distortedCamera(s.scene.camera);
  // world = the camera, marker = the board on the flange: the camera placed where view 0 sees the board as rendered.
  const Eigen::Isometry3d flange_T_board = s.scene.flange_T_camera;
  const Eigen::Isometry3d camera_T_board = sim::predictMarkerPose(s.model, Eigen::VectorXd::Zero(s.model.layout.size()), s.obs[0].sample).inverse();
  const Eigen::Isometry3d base_T_flange = sim::flangePose(s.model, Eigen::VectorXd::Zero(s.model.layout.size()), s.obs[0].sample);
  const sim::KinematicModel model =
      sim::makeKinematicModel(s.model.arm, 1, sim::FrameSharing::kShared, sim::FrameSharing::kShared,
                              {camera_T_board * (base_T_flange * flange_T_board).inverse()}, {flange_T_board}, s.model.effects);
  const calib::CornerMeasurementModel m(model, s.scene.camera, s.scene.board, s.obs, {}, {}, sim::HandEyeSetup::kEyeToHand);
  // With the corners' camera it predicts view 0's corners where they are (the same camera_T_board) at the start.
  const calib::CornerMeasurementModel same(model, taken, s.scene.board, s.obs, {}, {}, sim::HandEyeSetup::kEyeToHand);
  CHECK(same.residual(0, Eigen::VectorXd::Zero(m.numParams())).cwiseAbs().maxCoeff() < 1e-6);
  CHECK((m.cameraTBoard(0, Eigen::VectorXd::Zero(m.numParams())).matrix() - camera_T_board.matrix()).cwiseAbs().maxCoeff() < 1e-9);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  checkJacobian(m, m.layout().typical().unaryExpr([&](double t) { return t * u(rng); }));
  checkJacobian(m, Eigen::VectorXd::Zero(m.numParams()));
}

TEST_CASE("corner model: joint noise enters R through the corner Jacobian", "[calib][corner]") {
  const Setup s = makeSetup({}, 2, nullptr, nullptr, 0.0, 12);
  calib::CornerNoise noise;
  noise.sigma_px = 0.1;
  const calib::CornerMeasurementModel plain(s.model, s.scene.camera, s.scene.board, s.obs, noise);
  noise.joint_noise_sigma_rad = 0.01 * sim::kDegToRad;
  const calib::CornerMeasurementModel noisy(s.model, s.scene.camera, s.scene.board, s.obs, noise);
  const Eigen::VectorXd y = Eigen::VectorXd::Zero(plain.numParams());
  const calib::Linearization a = plain.linearize(0, y), b = noisy.linearize(0, y);
  CHECK(a.R.isApprox(0.01 * Eigen::MatrixXd::Identity(a.R.rows(), a.R.cols())));
  const Eigen::MatrixXd extra = b.R - a.R;
  CHECK(extra.isApprox(extra.transpose()));
  CHECK(extra.trace() > 0.0);
}

TEST_CASE("corner model: every estimator runs on it and recovers the distortion from noisy corners", "[calib][corner]") {
  // Truth: the scene camera (no distortion) + dk = (-0.05, 0.02, 5e-4, -5e-4), geometry and frames as
  // the model starts (p = 0 in the chain); corners with 0.1 px noise. Start: dk = 0.
  const sim::Scene scene = sim::loadScene(test::sourcePath("scenes/quick_scene.yaml"));
  sim::Camera taken = scene.camera;
  const Eigen::Vector4d dk(-0.05, 0.02, 5e-4, -5e-4);
  for (int i = 0; i < 4; ++i) taken.distortion[static_cast<std::size_t>(i)] += dk[i];
  const Setup s = makeSetup({sim::Cyclic{{1}, 1}}, 30, nullptr, &taken, 0.1, 13);
  calib::CornerNoise noise;
  noise.sigma_px = 0.1;
  const calib::CornerMeasurementModel m(s.model, s.scene.camera, s.scene.board, s.obs, noise);
  const int off = m.distortionOffset();
  calib::EkfOptions ekf;
  calib::LseOptions lse;
  lse.weighted = true;
  for (const calib::Estimate& e : {calib::runLm(m, {}), calib::runLse(m, lse), calib::runEkf(m, ekf)}) {
    CAPTURE(e.method, e.y.segment(off, 4).transpose(), e.converged);
    REQUIRE(e.y.size() == m.numParams());
    for (int i = 0; i < 4; ++i) {
      const double sigma = std::sqrt(e.covariance(off + i, off + i));
      CAPTURE(i, sigma);
      CHECK(std::abs(e.y[off + i] - dk[i]) < 4.0 * sigma + 1e-4 * std::abs(dk[i]));
    }
    const double rms = cornerResidualRms(m, m.p0() + e.y), rms_start = cornerResidualRms(m, m.p0());
    CAPTURE(rms, rms_start);
    CHECK(rms < 0.105);              // the 0.1 px noise
    CHECK(rms_start > 1.3 * rms);    // the distortion left out (a board near the image centre: ~0.1 px)
  }
}

TEST_CASE("corner model: corners known by identity (a partly seen ChArUco board) give the full model's rows",
          "[calib][corner][charuco]") {
  Setup s = makeSetup({}, 2, nullptr, nullptr, 0.05, 21);
  s.scene.camera = distortedCamera(s.scene.camera);
  // Each view keeps every third corner, in a scrambled order, with its identity.
  std::vector<calib::CornerObservation> partial;
  std::vector<std::vector<int>> kept;
  for (const calib::CornerObservation& o : s.obs) {
    calib::CornerObservation p;
    p.sample = o.sample;
    std::vector<int> ids;
    for (int k = s.scene.board.numCorners() - 1; k >= 0; k -= 3) ids.push_back(k);
    for (const int k : ids) p.corners_px.push_back(o.corners_px[static_cast<std::size_t>(k)]);
    p.ids = ids;
    kept.push_back(ids);
    partial.push_back(std::move(p));
  }
  const calib::CornerMeasurementModel full(s.model, s.scene.camera, s.scene.board, s.obs, {});
  const calib::CornerMeasurementModel part(s.model, s.scene.camera, s.scene.board, partial, {});
  std::mt19937_64 rng(6);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Eigen::VectorXd y = full.layout().typical().unaryExpr([&](double t) { return t * u(rng); });
  for (int k = 0; k < full.numSamples(); ++k) {
    const calib::Linearization a = full.linearize(k, y), b = part.linearize(k, y);
    REQUIRE(b.innovation.size() == 2 * static_cast<int>(kept[static_cast<std::size_t>(k)].size()));
    for (std::size_t n = 0; n < kept[static_cast<std::size_t>(k)].size(); ++n) {
      const int id = kept[static_cast<std::size_t>(k)][n];
      CHECK((b.innovation.segment<2>(2 * n) - a.innovation.segment<2>(2 * id)).norm() == 0.0);
      CHECK((b.H.middleRows<2>(2 * n) - a.H.middleRows<2>(2 * id)).norm() == 0.0);
    }
  }
  checkJacobian(part, y);
  // An id outside the board is refused.
  partial[0].ids[0] = s.scene.board.numCorners();
  CHECK_THROWS_AS(calib::CornerMeasurementModel(s.model, s.scene.camera, s.scene.board, partial, {}), std::invalid_argument);
}
