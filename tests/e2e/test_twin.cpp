// Rendered twins find what a hidden camera profile did to "real" images (workflow/twin.hpp): renders
// of a ChArUco board with a profile drawn from a seed stand for the real views, and the comparison
// with their clean twins must name each hidden effect with its size; a clean render names none.
// A radial distortion the stated intrinsics lack and a bowed board are named from the corners (each
// view's pose refitted under the shared geometry).
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
  CHECK(c.fitted.lens.identity());
  CHECK(c.fitted.board.bow_m == 0.0);
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
  // x against y (a uniform scale moves no corner about a view's own pose), fitted with every pose
  // refitted: within 10 %
  CHECK(s->size == Approx(scaled.board.scale_x - 1.0).epsilon(0.1));
  CHECK_FALSE(named(c, "tone curve"));  // the real pixels are paired with a twin drawn stretched
  CHECK_FALSE(named(c, "lens distortion"));
  CHECK_FALSE(named(c, "bow"));
  CHECK_FALSE(named(c, "blur"));
  CHECK_FALSE(named(c, "noise"));
}

TEST_CASE("twin: a hidden radial distortion the stated intrinsics lack is named with its size", "[e2e][twin]") {
  std::mt19937_64 rng(33);
  render::CameraProfile lens;
  lens.lens.k1 = std::uniform_real_distribution<double>(-0.15, -0.08)(rng);
  const workflow::TwinComparison c = compareHidden(lens, 5);
  const double hidden_px = render::lensShiftAtImageCorner(smallCamera(), lens.lens);
  INFO(effectList(c) << " hidden k1 " << lens.lens.k1 << " (" << hidden_px << " px at the image corner)");
  const workflow::NamedEffect* d = named(c, "lens distortion");
  REQUIRE(d);
  CHECK(d->size == Approx(hidden_px).epsilon(0.1));  // k2 is fitted too: the image corner is an extrapolation
  CHECK(c.fitted.lens.k1 == Approx(lens.lens.k1).margin(0.04));
  CHECK_FALSE(named(c, "bow"));
  CHECK_FALSE(named(c, "print scale"));
  CHECK_FALSE(named(c, "tone curve"));
  // (blur may be named beside it: the renderer draws a distortion by resampling, which widens the edges
  // of some views by up to 0.2 px more than their twins drawn through the fitted one)
}

TEST_CASE("twin: a hidden bow of the board is named with its sagitta", "[e2e][twin]") {
  std::mt19937_64 rng(34);
  render::CameraProfile bowed;
  bowed.board.bow_m = std::uniform_real_distribution<double>(0.002, 0.003)(rng);
  const workflow::TwinComparison c = compareHidden(bowed, 6);
  INFO(effectList(c) << " hidden bow " << bowed.board.bow_m * 1e3 << " mm");
  const workflow::NamedEffect* b = named(c, "bow");
  REQUIRE(b);
  CHECK(b->size == Approx(bowed.board.bow_m * 1e3).epsilon(0.1));
  CHECK_FALSE(named(c, "lens distortion"));
  CHECK_FALSE(named(c, "print scale"));
  CHECK_FALSE(named(c, "tone curve"));  // the real pixels are paired with a twin drawn bowed
  CHECK_FALSE(named(c, "blur"));
}
