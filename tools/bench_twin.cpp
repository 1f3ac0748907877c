// orbcal-bench twin: real views against their rendered twins (workflow/twin.hpp) on 30 views of 640 x 480
// px, the "real" ones rendered with a camera profile (vignetting, tone curve, blur, noise).
#include <random>

#include "bench.hpp"
#include "orbcal/render/renderer.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/workflow/twin.hpp"

namespace orbcal::tools {

namespace {

void benchTwin() {
  sim::Camera cam;
  cam.width_px = 640;
  cam.height_px = 480;
  cam.fx_px = cam.fy_px = 620.0;
  cam.cx_px = 322.0;
  cam.cy_px = 236.0;
  sim::Board board;  // the Doosan set's ChArUco board
  board.type = sim::BoardType::kCharuco;
  board.dictionary = "DICT_4X4_50";
  board.corners_x = 6;
  board.corners_y = 4;
  board.square_m = 0.03;
  board.marker_m = 0.022;
  board.margin_m = 0.01;
  render::CameraProfile hidden;
  hidden.vignetting.a2 = -0.3;
  hidden.tone = {35.0, 230.0, 1.7};
  hidden.blur_sigma_px = 0.8;
  hidden.noise = {0.03, 1.0};
  const sim::Scene scene = workflow::twinScene(cam, board);
  render::BoardRenderer renderer(scene, render::RenderSettings{});
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> tilt(-0.25, 0.25), roll(-0.5, 0.5), shift(-0.06, 0.06);
  std::vector<workflow::RealView> views;
  while (views.size() < 30) {
    Eigen::Isometry3d board_T_camera = Eigen::Isometry3d::Identity();
    board_T_camera.linear() = (Eigen::AngleAxisd(tilt(rng), Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(tilt(rng), Eigen::Vector3d::UnitX()) *
                               Eigen::AngleAxisd(roll(rng), Eigen::Vector3d::UnitZ())).toRotationMatrix();
    board_T_camera.translation() = sim::boardCentre(board) - 0.42 * board_T_camera.linear().col(2);
    Eigen::Isometry3d T = board_T_camera.inverse();
    T.translation() += Eigen::Vector3d(shift(rng), shift(rng), 0.0);
    workflow::RealView v;
    v.gray = render::applyCameraProfile(renderer.renderClean(T), vision::boardHullMask(cam, board, T, 0.0), hidden, cam, rng);
    v.detection = vision::measureGray(v.gray, cam, board, {});
    if (v.detection.measurement.found()) views.push_back(std::move(v));
  }
  std::printf("twin (30 views of 640 x 480 px, a ChArUco board of 6 x 4 inner corners):\n");
  const auto t = timeRepeats(3, [&] { workflow::compareWithTwins(cam, board, views, nullptr, 1); });
  printFigure("compare with twins and fit the profile, 30 views", t, "s", 1.0, "< 10 s");
  const auto tp = timeRepeats(3, [&] { workflow::compareWithTwins(cam, board, views, &hidden, 1); });
  printFigure("the same with --profile (profiled twins too), 30 views", tp, "s", 1.0, "< 10 s");
}

}  // namespace

ORBCAL_BENCH("twin", benchTwin);

}  // namespace orbcal::tools
