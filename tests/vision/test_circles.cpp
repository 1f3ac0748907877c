// Circle grids (vision/circles.hpp): the ellipse-centre bias against an ellipse fitted to the projected
// circle's outline (cv::fitEllipse on 720 points), and its size where it matters.
#include <catch2/catch.hpp>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "orbcal/sim/se3.hpp"
#include "orbcal/vision/circles.hpp"

using namespace orbcal;

TEST_CASE("the ellipse-centre bias of a circle grid is the fitted ellipse's centre minus the projected centre", "[vision][circles]") {
  sim::Camera camera;  // 1400 px focal length
  sim::Board board;
  board.type = sim::BoardType::kCircles;
  board.corners_x = 4, board.corners_y = 11, board.asymmetric = true, board.square_m = 0.04, board.diameter_m = 0.04;
  const Eigen::Isometry3d T = sim::fromXyzRpy(Eigen::Vector3d(-0.1, -0.2, 0.6), Eigen::Vector3d(35.0, -25.0, 10.0) * sim::kDegToRad);
  double largest = 0.0;
  for (int k = 0; k < board.numCorners(); ++k) {
    const Eigen::Vector3d c = sim::cornerInBoard(board, k);
    std::vector<cv::Point2f> outline;
    for (int i = 0; i < 720; ++i) {
      const double a = 2.0 * sim::kPi * i / 720.0;
      const Eigen::Vector3d p = c + 0.5 * board.diameter_m * Eigen::Vector3d(std::cos(a), std::sin(a), 0.0);
      const Eigen::Vector2d uv = sim::project(camera, T * p);
      outline.emplace_back(static_cast<float>(uv.x()), static_cast<float>(uv.y()));
    }
    const cv::RotatedRect e = cv::fitEllipse(outline);
    const Eigen::Vector2d fitted_bias = Eigen::Vector2d(e.center.x, e.center.y) - sim::project(camera, T * c);
    const Eigen::Vector2d bias = vision::ellipseCentreBias(camera, board, T, k);
    CAPTURE(k, fitted_bias.transpose(), bias.transpose());
    CHECK((bias - fitted_bias).norm() < 2e-3);  // float outline points: a few thousandths of a pixel
    largest = std::max(largest, bias.norm());
  }
  // 40 mm circles at 0.6 m, tilted 40 deg, f = 1400 px: about f r^2 sin(2 tilt) / (2 Z^2) = 1.5 px: not negligible.
  CHECK(largest > 0.5);
  // A fronto-parallel board has none.
  const Eigen::Isometry3d front = sim::fromXyzRpy(Eigen::Vector3d(-0.1, -0.2, 0.6), Eigen::Vector3d::Zero());
  for (int k = 0; k < board.numCorners(); ++k) CHECK(vision::ellipseCentreBias(camera, board, front, k).norm() < 1e-9);
}
