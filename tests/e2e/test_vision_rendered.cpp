// The vision chain on the real renderer: accuracy of the recovered pose and honesty of its covariance.
#include <catch2/catch.hpp>
#include <cmath>

#include "orbcal/render/renderer.hpp"
#include "orbcal/render/settings.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/vision/corners.hpp"
#include "orbcal/vision/pose.hpp"

using namespace orbcal;

namespace {
constexpr int kViews = 200;
// The bars: mean over the views of |t_est - t_true| of camera_T_board (the board origin in
// the camera frame, as the rendering notes measure it) and of the rotation angle of R_est^T R_true.
constexpr double kMeanPositionTolM = 0.2e-3;
constexpr double kMeanAngleTolRad = 0.02 * sim::kDegToRad;
// NEES of the 6-D pose: chi-square with 6 degrees of freedom has mean 6; the band [4, 8]
// leaves room for the residual-based scale and the renderer's small systematic corner errors.
constexpr double kNeesLow = 4.0, kNeesHigh = 8.0;

struct View {
  Eigen::VectorXd q;
  Eigen::Isometry3d camera_T_board;
};

std::vector<View> defaultViews(const sim::Arm& arm, const sim::Scene& scene, std::uint64_t seed) {
  sim::GeneratorSettings gen;
  gen.count = kViews;
  gen.seed = seed;
  std::vector<View> views;
  for (const Eigen::VectorXd& q : sim::generateConfigurations(arm, scene, gen)) {
    const Eigen::Isometry3d base_T_camera = sim::forwardKinematics(arm, q) * scene.flange_T_camera;
    views.push_back({q, base_T_camera.inverse(Eigen::Isometry) * scene.base_T_board});
  }
  return views;
}
}  // namespace

TEST_CASE("rendered default scene: the recovered camera pose is within 0.2 mm / 0.02 deg on average",
          "[e2e][vision][rendered]") {
  const sim::Arm arm = sim::loadArm(sim::kDefaultRobot);
  const sim::Scene scene = sim::loadScene(sim::kDefaultScene);
  const render::RenderSettings settings = render::loadRenderSettings(sim::kDefaultScene);
  render::BoardRenderer renderer(scene, settings);
  const auto views = defaultViews(arm, scene, 2024);
  REQUIRE(static_cast<int>(views.size()) == kViews);
  double sum_t = 0.0, sum_r = 0.0, max_t = 0.0, max_r = 0.0, sum_cam_pos = 0.0, sum_rms = 0.0;
  int found = 0;
  for (const View& v : views) {
    const cv::Mat img = renderer.renderClean(v.camera_T_board);
    const auto det = vision::detectCorners(img, scene.board);
    CAPTURE(det.reason, det.detail);
    CHECK(det.found());
    if (!det.found()) continue;
    const auto pose = vision::estimateBoardPose(scene.camera, scene.board, det.corners_px);
    REQUIRE(pose.ok);
    ++found;
    const double t = (pose.camera_T_board.translation() - v.camera_T_board.translation()).norm();
    const double r = sim::rotationAngle(pose.camera_T_board.linear().transpose() * v.camera_T_board.linear());
    sum_t += t, sum_r += r, max_t = std::max(max_t, t), max_r = std::max(max_r, r), sum_rms += pose.rms_px;
    sum_cam_pos += (pose.camera_T_board.inverse(Eigen::Isometry).translation() -
                    v.camera_T_board.inverse(Eigen::Isometry).translation())
                       .norm();
  }
  REQUIRE(found == kViews);
  const double mean_t = sum_t / found, mean_r = sum_r / found;
  WARN("rendered accuracy over " << found << " views: camera_T_board translation mean " << mean_t * 1e3 << " mm (max "
                                 << max_t * 1e3 << "), rotation mean " << mean_r * sim::kRadToDeg << " deg (max "
                                 << max_r * sim::kRadToDeg << "); camera position in the board frame mean "
                                 << sum_cam_pos / found * 1e3 << " mm; reprojection RMS mean " << sum_rms / found
                                 << " px");
  CHECK(mean_t < kMeanPositionTolM);
  CHECK(mean_r < kMeanAngleTolRad);
}

TEST_CASE("rendered default scene with image noise: the pose covariance is honest (NEES in [4, 8])",
          "[e2e][vision][rendered][nees][slow]") {
  const sim::Arm arm = sim::loadArm(sim::kDefaultRobot);
  const sim::Scene scene = sim::loadScene(sim::kDefaultScene);
  render::RenderSettings settings = render::loadRenderSettings(sim::kDefaultScene);
  settings.degradations.read_noise_dn = 4.0;  // Gaussian read noise, 8-bit DN
  settings.degradations.full_well_e = 10000;  // shot noise
  render::BoardRenderer renderer(scene, settings);
  const auto views = defaultViews(arm, scene, 4048);
  double nees_c = 0.0, nees_f = 0.0, sum_sigma = 0.0;
  int found = 0;
  for (std::size_t i = 0; i < views.size(); ++i) {
    const View& v = views[i];
    const cv::Mat img = renderer.render(v.camera_T_board, 77, i);
    const auto det = vision::detectCorners(img, scene.board);
    CAPTURE(i, det.reason, det.detail);
    CHECK(det.found());
    if (!det.found()) continue;
    const auto pose = vision::estimateBoardPose(scene.camera, scene.board, det.corners_px);
    REQUIRE(pose.ok);
    ++found;
    sum_sigma += pose.sigma_px;
    // Camera convention: e_c = poseMinus(board_T_camera_true, board_T_camera_est).
    const sim::Vector6d e_c =
        sim::poseMinus(v.camera_T_board.inverse(Eigen::Isometry), pose.camera_T_board.inverse(Eigen::Isometry));
    nees_c += e_c.dot(pose.covariance_camera.ldlt().solve(e_c));
    // Flange convention: e_f = poseMinus(base_T_flange_true, base_T_flange_measured).
    const Eigen::Isometry3d flange_est = vision::measuredFlangePose(scene, pose.camera_T_board);
    const sim::Vector6d e_f = sim::poseMinus(sim::forwardKinematics(arm, v.q), flange_est);
    nees_f += e_f.dot(vision::flangeCovariance(scene.flange_T_camera, pose.covariance_camera).ldlt().solve(e_f));
  }
  REQUIRE(found == kViews);
  nees_c /= found;
  nees_f /= found;
  WARN("NEES over " << found << " noisy rendered views: camera frame " << nees_c << ", flange frame " << nees_f
                    << "; mean estimated corner sigma " << sum_sigma / found << " px");
  CHECK(nees_c > kNeesLow);
  CHECK(nees_c < kNeesHigh);
  CHECK(nees_f > kNeesLow);
  CHECK(nees_f < kNeesHigh);
}
