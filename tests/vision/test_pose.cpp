#include <catch2/catch.hpp>
#include <random>

#include "orbcal/sim/arm.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/vision/pose.hpp"
#include "vision_test_util.hpp"

using namespace orbcal;

namespace {
constexpr double kStep = 1e-6;           // central differences: truncation ~h^2, round-off ~1e-16/h
constexpr double kPixelJacobianTol = 1e-4;  // entries are O(1e3) px per m or rad; relative 1e-7

sim::Camera distortedCamera() {
  sim::Camera c = test::defaultScene().camera;
  c.distortion = {-0.12, 0.05, 0.0012, -0.0008, -0.01};
  return c;
}
}  // namespace

TEST_CASE("projection Jacobian matches central differences, with distortion", "[vision][pose][jacobian]") {
  const sim::Camera cam = distortedCamera();
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> xy(-0.6, 0.6), z(1.2, 2.5);
  for (int n = 0; n < 20; ++n) {
    const Eigen::Vector3d p(xy(rng), xy(rng), z(rng));
    CAPTURE(p.transpose());
    const auto J = vision::projectionJacobian(cam, p);
    Eigen::Matrix<double, 2, 3> J_num;
    for (int c = 0; c < 3; ++c) {
      Eigen::Vector3d d = Eigen::Vector3d::Zero();
      d[c] = kStep;
      J_num.col(c) = (sim::project(cam, p + d) - sim::project(cam, p - d)) / (2 * kStep);
    }
    REQUIRE(J_num.norm() > 100.0);
    CHECK((J - J_num).cwiseAbs().maxCoeff() < kPixelJacobianTol);
  }
}

TEST_CASE("reprojection Jacobian is d pixels / d e_c with board_T_camera (+) e_c", "[vision][pose][jacobian]") {
  const sim::Scene& scene = test::defaultScene();
  const sim::Camera cam = distortedCamera();
  for (const Eigen::Isometry3d& camera_T_board : test::randomViews(scene, 5, 3)) {
    const Eigen::MatrixXd J = vision::reprojectionJacobian(cam, scene.board, camera_T_board);
    Eigen::MatrixXd J_num(J.rows(), 6);
    const Eigen::Isometry3d board_T_camera = camera_T_board.inverse(Eigen::Isometry);
    for (int c = 0; c < 6; ++c) {
      sim::Vector6d e = sim::Vector6d::Zero();
      e[c] = kStep;
      const auto plus = vision::projectBoard(cam, scene.board, sim::posePlus(board_T_camera, e).inverse(Eigen::Isometry));
      const auto minus = vision::projectBoard(cam, scene.board, sim::posePlus(board_T_camera, -e).inverse(Eigen::Isometry));
      for (std::size_t k = 0; k < plus.size(); ++k) J_num.block<2, 1>(2 * k, c) = (plus[k] - minus[k]) / (2 * kStep);
    }
    REQUIRE(J_num.norm() > 100.0);
    Eigen::Index r = 0, c = 0;
    (J - J_num).cwiseAbs().maxCoeff(&r, &c);
    CAPTURE(r, c, J(r, c), J_num(r, c));
    CHECK(std::abs(J(r, c) - J_num(r, c)) < kPixelJacobianTol);
  }
}

TEST_CASE("PnP recovers the pose from exact projections", "[vision][pose]") {
  const sim::Scene& scene = test::defaultScene();
  const sim::Camera cam = distortedCamera();
  for (const Eigen::Isometry3d& T : test::randomViews(scene, 20, 5)) {
    const auto pose = vision::estimateBoardPose(cam, scene.board, vision::projectBoard(cam, scene.board, T));
    REQUIRE(pose.ok);
    CHECK((pose.camera_T_board.translation() - T.translation()).norm() < 1e-8);
    CHECK(sim::rotationAngle(pose.camera_T_board.linear().transpose() * T.linear()) < 1e-9);
    CHECK(pose.rms_px < 1e-6);
  }
  CHECK_THROWS_AS(vision::estimateBoardPose(cam, scene.board, {}), std::invalid_argument);
}

TEST_CASE("the flange error is Ad(flange_T_camera) times the camera error", "[vision][pose]") {
  const sim::Scene& scene = test::defaultScene();
  const Eigen::Isometry3d camera_T_board = test::lookAtBoard(scene.board, 2.0, 0.2, 0.1, 0.5);
  const Eigen::Isometry3d base_T_flange = vision::measuredFlangePose(scene, camera_T_board);
  // the chain closes: base_T_board = base_T_flange * flange_T_camera * camera_T_board
  CHECK((base_T_flange * scene.flange_T_camera * camera_T_board).matrix().isApprox(scene.base_T_board.matrix(), 1e-12));
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g(0.0, 1e-6);
  for (int n = 0; n < 10; ++n) {
    sim::Vector6d e_c;
    for (int i = 0; i < 6; ++i) e_c[i] = g(rng);
    const Eigen::Isometry3d board_T_camera_true = sim::posePlus(camera_T_board.inverse(Eigen::Isometry), e_c);
    const Eigen::Isometry3d flange_true = vision::measuredFlangePose(scene, board_T_camera_true.inverse(Eigen::Isometry));
    const sim::Vector6d e_f = sim::poseMinus(flange_true, base_T_flange);
    const sim::Vector6d predicted = sim::adjoint(scene.flange_T_camera) * e_c;
    CHECK((e_f - predicted).norm() < 1e-10);  // second order in |e| ~ 1e-6 (lever arm < 1 m)
  }
  const sim::Matrix6d S = sim::Matrix6d::Identity();
  CHECK(vision::flangeCovariance(scene.flange_T_camera, S)
            .isApprox(sim::adjoint(scene.flange_T_camera) * sim::adjoint(scene.flange_T_camera).transpose()));
}

TEST_CASE("the PnP covariance is consistent under Gaussian corner noise (NEES ~ 6)", "[vision][pose][nees]") {
  // Corner noise straight onto exact projections: checks the covariance formula alone. The rendered
  // version (tests/e2e/test_vision_rendered.cpp) checks it with real detection noise.
  const sim::Scene& scene = test::defaultScene();
  const sim::Camera cam = distortedCamera();
  constexpr int kTrials = 1000;
  constexpr double kNoisePx = 0.3;
  std::mt19937_64 rng(99);
  std::normal_distribution<double> noise(0.0, kNoisePx);
  double nees_c = 0.0, nees_f = 0.0;
  const auto views = test::randomViews(scene, kTrials, 21);
  for (const Eigen::Isometry3d& T : views) {
    auto corners = vision::projectBoard(cam, scene.board, T);
    for (auto& p : corners) p += Eigen::Vector2d(noise(rng), noise(rng));
    const auto pose = vision::estimateBoardPose(cam, scene.board, corners);
    REQUIRE(pose.ok);
    const sim::Vector6d e_c =
        sim::poseMinus(T.inverse(Eigen::Isometry), pose.camera_T_board.inverse(Eigen::Isometry));
    nees_c += e_c.dot(pose.covariance_camera.ldlt().solve(e_c));
    const Eigen::Isometry3d flange_est = vision::measuredFlangePose(scene, pose.camera_T_board);
    const sim::Vector6d e_f = sim::poseMinus(vision::measuredFlangePose(scene, T), flange_est);
    const sim::Matrix6d S_f = vision::flangeCovariance(scene.flange_T_camera, pose.covariance_camera);
    nees_f += e_f.dot(S_f.ldlt().solve(e_f));
  }
  nees_c /= kTrials;
  nees_f /= kTrials;
  // Mean of 6 F(6, 102)-like values: 6.1 with standard error ~0.1 over 1000 trials; [5.5, 6.8] is > 4 sigma.
  CAPTURE(nees_c, nees_f);
  CHECK(nees_c > 5.5);
  CHECK(nees_c < 6.8);
  CHECK(std::abs(nees_f - nees_c) < 0.05);  // the adjoint maps the error and the covariance alike
}

TEST_CASE("the measured flange pose equals FK when camera_T_board comes from FK", "[vision][pose]") {
  const sim::Scene& scene = test::defaultScene();
  const sim::Arm arm = sim::loadArm(sim::kDefaultRobot);
  Eigen::VectorXd q = Eigen::VectorXd::Constant(arm.numJoints(), 0.3);
  const Eigen::Isometry3d base_T_flange = sim::forwardKinematics(arm, q);
  const Eigen::Isometry3d camera_T_board =
      (base_T_flange * scene.flange_T_camera).inverse(Eigen::Isometry) * scene.base_T_board;
  CHECK(sim::poseMinus(vision::measuredFlangePose(scene, camera_T_board), base_T_flange).norm() < 1e-12);
}
