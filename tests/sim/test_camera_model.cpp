// The camera's distortion polynomial (sim::distortNormalized, its Jacobian, sim::project) and the board outline.
#include <catch2/catch.hpp>
#include <random>

#include "orbcal/sim/scene.hpp"

using namespace orbcal::sim;

namespace {
constexpr double kStep = 1e-6;          // central differences: truncation ~h^2, round-off ~1e-16 / h
constexpr double kJacobianTol = 1e-8;   // entries are O(1) for |x|, |y| < 0.6 and these coefficients
constexpr double kExactTol = 1e-12;     // the same arithmetic, rearranged at most
}  // namespace

TEST_CASE("distortNormalized's Jacobian matches central differences", "[sim][camera][jacobian]") {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> xy(-0.6, 0.6);
  for (const std::array<double, 5>& k : {std::array<double, 5>{-0.25, 0.12, 0.001, -0.0015, -0.02},
                                         std::array<double, 5>{0.15, -0.05, -0.002, 0.001, 0.01},
                                         std::array<double, 5>{0, 0, 0, 0, 0}}) {
    std::vector<Eigen::Vector2d> points{Eigen::Vector2d::Zero()};  // the centre: J = identity
    for (int i = 0; i < 30; ++i) points.emplace_back(xy(rng), xy(rng));
    for (const Eigen::Vector2d& p : points) {
      Eigen::Matrix2d J;
      distortNormalized(k, p, &J);
      Eigen::Matrix2d J_num;
      for (int c = 0; c < 2; ++c) {
        const Eigen::Vector2d h = kStep * Eigen::Vector2d::Unit(c);
        J_num.col(c) = (distortNormalized(k, p + h) - distortNormalized(k, p - h)) / (2.0 * kStep);
      }
      CAPTURE(k[0], p.transpose(), J, J_num);
      REQUIRE(J_num.norm() > 0.5);  // a harness returning zeros must not pass
      REQUIRE((J - J_num).cwiseAbs().maxCoeff() < kJacobianTol);
    }
  }
}

TEST_CASE("distortNormalized is OpenCV's model and sim::project uses it", "[sim][camera]") {
  const std::array<double, 5> k{-0.2, 0.08, 0.0008, -0.0006, -0.01};
  const Eigen::Vector2d p(0.31, -0.22);
  // OpenCV's formula, written out independently.
  const double x = p.x(), y = p.y(), r2 = x * x + y * y;
  const double radial = 1 + k[0] * r2 + k[1] * r2 * r2 + k[4] * r2 * r2 * r2;
  const Eigen::Vector2d expected(x * radial + 2 * k[2] * x * y + k[3] * (r2 + 2 * x * x),
                                 y * radial + k[2] * (r2 + 2 * y * y) + 2 * k[3] * x * y);
  CHECK((distortNormalized(k, p) - expected).norm() < kExactTol);
  Camera c;
  c.distortion = k;
  const Eigen::Vector3d p_cam(0.31 * 2.0, -0.22 * 2.0, 2.0);
  const Eigen::Vector2d uv = project(c, p_cam);
  CHECK((uv - Eigen::Vector2d(c.fx_px * expected.x() + c.cx_px, c.fy_px * expected.y() + c.cy_px)).norm() < 1e-9);
}

TEST_CASE("boardOutline is the squares' outline grown by the margin", "[sim][board]") {
  Board b;
  b.corners_x = 9, b.corners_y = 6, b.square_m = 0.08, b.margin_m = 0.06;
  const auto squares = squaresOutline(b);
  const auto outline = boardOutline(b);
  const Eigen::Vector3d lo(-0.08 - 0.06, -0.08 - 0.06, 0), hi(9 * 0.08 + 0.06, 6 * 0.08 + 0.06, 0);
  CHECK((outline[0] - lo).norm() < kExactTol);
  CHECK((outline[2] - hi).norm() < kExactTol);
  CHECK((outline[1] - Eigen::Vector3d(hi.x(), lo.y(), 0)).norm() < kExactTol);
  CHECK((outline[3] - Eigen::Vector3d(lo.x(), hi.y(), 0)).norm() < kExactTol);
  for (int i = 0; i < 4; ++i) {
    CAPTURE(i);
    CHECK(std::abs(std::abs((outline[i] - squares[i]).x()) - b.margin_m) < kExactTol);  // same order, each corner outward
    CHECK(std::abs(std::abs((outline[i] - squares[i]).y()) - b.margin_m) < kExactTol);
  }
  b.margin_m = 0;
  for (int i = 0; i < 4; ++i) CHECK(boardOutline(b)[i] == squaresOutline(b)[i]);
}
