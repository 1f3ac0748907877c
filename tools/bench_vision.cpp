// Vision figures: corner detection + orientation + pose (+ covariance) per 1280x1024 image.
#include <cstdio>

#include "bench.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/vision/corners.hpp"
#include "orbcal/vision/pose.hpp"
#include "orbcal/vision/synthetic.hpp"

namespace orbcal::tools {

namespace {
void benchVision() {
  const sim::Scene scene = sim::loadScene(sim::kDefaultScene);
  // Drawn (not rendered: vision never depends on render) views at 1.6-2.4 m with some tilt and roll.
  std::vector<cv::Mat> images;
  for (int i = 0; i < 8; ++i) {
    const double d = 1.6 + 0.1 * i, tilt = 0.3 * ((i % 3) - 1), roll = 0.8 * i;
    const Eigen::Matrix3d R = (Eigen::AngleAxisd(tilt, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(-0.5 * tilt, Eigen::Vector3d::UnitX()) *
                               Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()))
                                  .toRotationMatrix();
    Eigen::Isometry3d board_T_camera = Eigen::Isometry3d::Identity();
    board_T_camera.linear() = R;
    board_T_camera.translation() = sim::boardCentre(scene.board) - d * R.col(2);
    vision::SyntheticImageSettings st;
    st.noise_sigma = 2.0;
    st.seed = i;
    images.push_back(vision::drawSyntheticBoard(scene.camera, scene.board, board_T_camera.inverse(Eigen::Isometry), st));
  }
  const cv::Mat blank = cv::Mat::zeros(scene.camera.height_px, scene.camera.width_px, CV_8UC1);
  cv::Mat flat(scene.camera.height_px, scene.camera.width_px, CV_8UC1, cv::Scalar(128));
  cv::randn(flat, 128, 20);  // noise, no board: the detector's worst case

  for (const vision::Detector det : {vision::Detector::kClassic, vision::Detector::kSectorBased}) {
    vision::DetectorSettings ds;
    ds.detector = det;
    (void)vision::detectCorners(images[0], scene.board, ds);  // warm-up
    std::size_t i = 0;
    int found = 0;
    const int repeats = det == vision::Detector::kClassic ? 40 : 8;
    const auto t_det = timeRepeats(repeats, [&] {
      const auto d = vision::detectCorners(images[i++ % images.size()], scene.board, ds);
      found += d.found();
    });
    printFigure(std::string("detect + order corners 1280x1024 (") + vision::toString(det) + ")", t_det, "ms", 1e3,
                det == vision::Detector::kClassic ? "< 15 ms" : "");
    i = 0;
    const auto t_all = timeRepeats(repeats, [&] {
      const auto d = vision::detectCorners(images[i++ % images.size()], scene.board, ds);
      if (d.found()) (void)vision::estimateBoardPose(scene.camera, scene.board, d.corners_px);
    });
    printFigure(std::string("detect + order + PnP + covariance 1280x1024 (") + vision::toString(det) + ")", t_all, "ms",
                1e3, det == vision::Detector::kClassic ? "< 15 ms" : "");
    if (found != repeats) std::printf("  (board found in %d of %d images)\n", found, repeats);
  }
  const auto t_blank = timeRepeats(20, [&] { (void)vision::detectCorners(blank, scene.board); });
  printFigure("reject an all-black image", t_blank, "ms", 1e3, "");
  const auto t_flat = timeRepeats(10, [&] { (void)vision::detectCorners(flat, scene.board); });
  printFigure("no board in a noise image (classic)", t_flat, "ms", 1e3, "");
  vision::DetectorSettings ds;
  const auto d = vision::detectCorners(images[0], scene.board, ds);
  if (d.found()) {
    const auto t_pnp = timeRepeats(200, [&] { (void)vision::estimateBoardPose(scene.camera, scene.board, d.corners_px); });
    printFigure("PnP (IPPE + LM) + covariance, 54 corners", t_pnp, "ms", 1e3, "");
  }
}
}  // namespace

ORBCAL_BENCH("vision", benchVision);

}  // namespace orbcal::tools
