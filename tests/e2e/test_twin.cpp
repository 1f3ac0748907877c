// Rendered twins find what a hidden camera profile did to "real" images (workflow/twin.hpp): renders
// of a ChArUco board with a profile drawn from a seed stand for the real views, and the comparison
// with their clean twins must name each hidden effect with its size; a clean render names none.
// A bowed board is not named yet (docs/twins.md says why).
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "orbcal/render/renderer.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/vision/image_stats.hpp"
#include "orbcal/workflow/twin.hpp"

using namespace orbcal;

namespace {

sim::Camera smallCamera() {
  sim::Camera c;
  c.width_px = 640;
  c.height_px = 480;
  c.fx_px = c.fy_px = 620.0;
  c.cx_px = 322.0;
  c.cy_px = 236.0;
  return c;
}

/// The Doosan set's board: 7 x 5 squares of 30 mm, markers of 22 mm, DICT_4X4_50, a 10 mm margin.
sim::Board smallBoard() {
  sim::Board b;
  b.type = sim::BoardType::kCharuco;
  b.dictionary = "DICT_4X4_50";
  b.corners_x = 6;
  b.corners_y = 4;
  b.square_m = 0.03;
  b.marker_m = 0.022;
  b.margin_m = 0.01;
  return b;
}

/// Eight views 0.42 m away, tilted and rolled, the board's centre moved about the image (vignetting
/// needs radii from the centre to the corners).
std::vector<Eigen::Isometry3d> views() {
  std::vector<Eigen::Isometry3d> out;
  const sim::Board b = smallBoard();
  const double shifts[8][2] = {{0, 0}, {-0.07, -0.05}, {0.07, 0.05}, {0.07, -0.05}, {-0.07, 0.05}, {0.0, 0.05}, {0.07, 0}, {-0.07, 0}};
  for (int k = 0; k < 8; ++k) {
    const double tilt = 0.15 * ((k % 3) - 1), roll = (6.0 + 3.0 * k) * sim::kDegToRad;
    Eigen::Isometry3d board_T_camera = Eigen::Isometry3d::Identity();
    board_T_camera.linear() = (Eigen::AngleAxisd(tilt, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(-0.5 * tilt, Eigen::Vector3d::UnitX()) *
                               Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ())).toRotationMatrix();
    board_T_camera.translation() = sim::boardCentre(b) - 0.42 * board_T_camera.linear().col(2);
    Eigen::Isometry3d T = board_T_camera.inverse();
    T.translation() += Eigen::Vector3d(shifts[k][0], shifts[k][1], 0.0);
    out.push_back(T);
  }
  return out;
}

/// The comparison of renders with `hidden` applied (the "real" views) against their clean twins.
workflow::TwinComparison compareHidden(const render::CameraProfile& hidden, std::uint64_t seed) {
  const sim::Camera cam = smallCamera();
  const sim::Board board = smallBoard();
  const sim::Scene scene = workflow::twinScene(cam, board);
  render::BoardRenderer renderer(scene, render::RenderSettings{}, hidden);  // the board as the hidden profile prints it
  std::mt19937_64 rng(seed);
  std::vector<workflow::RealView> real;
  for (const Eigen::Isometry3d& T : views()) {
    workflow::RealView v;
    v.name = "view" + std::to_string(real.size());
    v.gray = render::applyCameraProfile(renderer.renderClean(T), vision::boardHullMask(cam, board, T, 0.0), hidden, cam, rng);
    v.detection = vision::measureGray(v.gray, cam, board, {});
    REQUIRE(v.detection.measurement.found());
    real.push_back(std::move(v));
  }
  return workflow::compareWithTwins(cam, board, real, nullptr, seed);
}

const workflow::NamedEffect* named(const workflow::TwinComparison& c, const std::string& name) {
  for (const auto& e : c.effects) {
    if (e.name == name) return &e;
  }
  return nullptr;
}

std::string effectList(const workflow::TwinComparison& c) {
  std::string s;
  for (const auto& e : c.effects) s += e.name + " " + std::to_string(e.size) + " " + e.unit + "; ";
  return s;
}

}  // namespace

TEST_CASE("twin: a clean render names no effect", "[e2e][twin]") {
  const workflow::TwinComparison c = compareHidden(render::CameraProfile{}, 1);
  INFO(effectList(c));
  CHECK(c.views.size() == 8);
  CHECK(c.effects.empty());
  CHECK(std::abs(c.fitted.tone.gamma - 1.0) < 0.05);
  CHECK(c.fitted.blur_sigma_px < 0.2);
}

TEST_CASE("twin: hidden vignetting and tone curve are named with their sizes", "[e2e][twin]") {
  std::mt19937_64 rng(30);
  render::CameraProfile hidden;
  hidden.vignetting.a2 = std::uniform_real_distribution<double>(-0.45, -0.25)(rng);
  hidden.tone = {std::uniform_real_distribution<double>(25, 45)(rng), std::uniform_real_distribution<double>(215, 240)(rng),
                 std::uniform_real_distribution<double>(1.4, 1.9)(rng)};
  const workflow::TwinComparison c = compareHidden(hidden, 2);
  INFO(effectList(c) << " hidden a2 " << hidden.vignetting.a2 << " gamma " << hidden.tone.gamma);
  const workflow::NamedEffect* v = named(c, "vignetting");
  REQUIRE(v);
  CHECK(v->size == Approx(hidden.vignetting.a2).margin(0.1));  // a quarter of its size at most
  const workflow::NamedEffect* t = named(c, "tone curve");
  REQUIRE(t);
  CHECK(t->size == Approx(hidden.tone.gamma).epsilon(0.1));
  CHECK(c.fitted.tone.black_dn == Approx(hidden.tone.black_dn).margin(6.0));
  CHECK(named(c, "black level"));
  CHECK_FALSE(named(c, "blur"));
  CHECK_FALSE(named(c, "noise"));
}

TEST_CASE("twin: hidden blur and noise are named with their sizes", "[e2e][twin]") {
  std::mt19937_64 rng(31);
  render::CameraProfile hidden;
  hidden.blur_sigma_px = std::uniform_real_distribution<double>(0.7, 1.1)(rng);
  hidden.noise.a_dn = std::uniform_real_distribution<double>(0.02, 0.05)(rng);
  hidden.noise.b_dn2 = std::uniform_real_distribution<double>(0.5, 1.5)(rng);
  const workflow::TwinComparison c = compareHidden(hidden, 3);
  INFO(effectList(c) << " hidden blur " << hidden.blur_sigma_px);
  const workflow::NamedEffect* b = named(c, "blur");
  REQUIRE(b);
  CHECK(b->size == Approx(hidden.blur_sigma_px).margin(0.25));  // the Gaussian edge model and a 0.05 px grid
  const workflow::NamedEffect* n = named(c, "noise");
  REQUIRE(n);
  CHECK(n->size == Approx(std::sqrt(hidden.noise.a_dn * 128 + hidden.noise.b_dn2)).epsilon(0.2));
  CHECK_FALSE(named(c, "vignetting"));
  CHECK_FALSE(named(c, "tone curve"));
}

TEST_CASE("twin: a hidden print scale is named with its size", "[e2e][twin]") {
  std::mt19937_64 rng(32);
  render::CameraProfile scaled;
  scaled.board.scale_x = 1.0 + std::uniform_real_distribution<double>(0.008, 0.015)(rng);
  const workflow::TwinComparison c = compareHidden(scaled, 4);
  INFO(effectList(c) << " hidden scale_x " << scaled.board.scale_x);
  const workflow::NamedEffect* s = named(c, "print scale");
  REQUIRE(s);
  // x against y, within a factor of 2: a uniform scale moves no corner about a view's own pose, and the
  // pose takes up part of the anisotropic one (measured: 0.0078 for 0.0145)
  CHECK(s->size > 0.5 * (scaled.board.scale_x - 1.0));
  CHECK(s->size < 2.0 * (scaled.board.scale_x - 1.0));
  CHECK_FALSE(named(c, "blur"));
  CHECK_FALSE(named(c, "noise"));
}
