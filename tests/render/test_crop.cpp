// render.crop_to_scene: drawing, reading back and undistorting only the box the scene projects into
// must give exactly the image of the whole frame (everything else is background either way).
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <future>

#include "orbcal/render/distortion.hpp"
#include "orbcal/render/renderer.hpp"
#include "orbcal/render/settings.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/io.hpp"
#include "render_test_util.hpp"
#include "test_util.hpp"

using namespace orbcal;

namespace {

int differingPixels(const cv::Mat& a, const cv::Mat& b) {
  REQUIRE(a.size() == b.size());
  REQUIRE(a.type() == b.type());
  return cv::countNonZero(a != b);
}

/// Renders the same views cropped and whole-frame (two renderers) and requires identical images.
/// Returns how many views had non-background pixels, so callers can check the views saw something.
int requireSameImages(const sim::Scene& scene, render::RenderSettings settings,
                      const std::vector<Eigen::Isometry3d>& views) {
  settings.options.crop_to_scene = true;
  render::BoardRenderer cropped(scene, settings);
  settings.options.crop_to_scene = false;
  render::BoardRenderer whole(scene, settings);
  int seen = 0;
  for (std::size_t i = 0; i < views.size(); ++i) {
    const cv::Mat a = cropped.renderClean(views[i]), b = whole.renderClean(views[i]);
    CAPTURE(i);
    CHECK(differingPixels(a, b) == 0);
    double lo = 0, hi = 0;
    cv::minMaxLoc(b, &lo, &hi);
    if (hi > lo) ++seen;
  }
  return seen;
}

sim::Scene offCentreScene() {
  sim::Scene scene = sim::loadScene(sim::kDefaultScene);
  scene.camera.cx_px = 700.3;
  scene.camera.cy_px = 470.7;
  return scene;
}

/// Whole board in view, tilted; the board half out of the image (the crop is clamped at the edge);
/// the board entirely beside the image (nothing drawn); the camera behind the board (its back, grey).
std::vector<Eigen::Isometry3d> views(const sim::Board& board) {
  std::vector<Eigen::Isometry3d> v;
  v.push_back(test::lookAtBoard(board, 1.8, 35.0, 40.0, 15.0));
  v.push_back(test::lookAtBoard(board, 1.6, 10.0, 200.0, -20.0, Eigen::Vector3d(0.45, 0.3, 0)));
  v.push_back(test::lookAtBoard(board, 2.0, 0.0, 0.0, 0.0, Eigen::Vector3d(3.0, 0.0, 0)));
  Eigen::Isometry3d flip = Eigen::Isometry3d::Identity();
  flip.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  v.push_back(test::lookAtBoard(board, 2.2, 20.0, 80.0, 5.0) * Eigen::Translation3d(sim::boardCentre(board)) * flip *
              Eigen::Translation3d(-sim::boardCentre(board)));
  return v;
}

/// 160 x 128 px with strong barrel distortion: small enough for brute force over every pixel.
sim::Camera smallDistortedCamera() {
  sim::Camera c;
  c.width_px = 160;
  c.height_px = 128;
  c.fx_px = c.fy_px = 150.0;
  c.cx_px = 83.2;
  c.cy_px = 61.7;
  c.distortion = {-0.25, 0.09, 0.001, -0.0007, -0.01};
  return c;
}

}  // namespace

TEST_CASE("cropping to the board gives the whole frame's image: default settings, off-centre principal point",
          "[render][crop]") {
  const sim::Scene scene = offCentreScene();
  CHECK(requireSameImages(scene, render::loadRenderSettings(sim::kDefaultScene), views(scene.board)) == 3);
}

TEST_CASE("cropping gives the whole frame's image with MSAA 4, with supersampling 2 and on a grey background",
          "[render][crop]") {
  const sim::Scene scene = offCentreScene();
  render::RenderSettings settings = render::loadRenderSettings(sim::kDefaultScene);
  settings.options.msaa_samples = 4;
  settings.options.background = 0.3;  // the pixels never drawn must get GL's own grey level
  CHECK(requireSameImages(scene, settings, views(scene.board)) == 3);
  settings.options.msaa_samples = 0;
  settings.options.supersample = 2;  // the crop is aligned to 2 x 2 blocks before averaging down
  CHECK(requireSameImages(scene, settings, views(scene.board)) == 3);
}

TEST_CASE("cropping gives the whole frame's image with lens distortion: the remap is cropped by tiles too",
          "[render][crop][distortion]") {
  sim::Scene scene = offCentreScene();
  scene.camera.distortion = {-0.2, 0.08, 0.0008, -0.0006, -0.01};
  render::RenderSettings settings = render::loadRenderSettings(sim::kDefaultScene);
  CHECK(requireSameImages(scene, settings, views(scene.board)) == 3);
  settings.options.background = 0.3;  // also the border value of pixels that map outside the drawn field
  CHECK(requireSameImages(scene, settings, views(scene.board)) == 3);
}

TEST_CASE("cropping gives the whole frame's image with a mesh that casts a shadow and sticks out past the board",
          "[render][crop][mesh]") {
  // The plate (0.2 x 0.1 m) is placed beyond the board's edge and toward the camera: its pixels lie
  // partly outside the board's own box, so a crop to the board alone would cut it.
  const std::string path = test::writeSceneWithPlate(test::tempDir("render-crop-mesh"),
                                                      "meshes:\n"
                                                      "  - file: meshes/occluder_plate.obj\n"
                                                      "    frame: board\n"
                                                      "    pose: {xyz_m: [-0.15, 0.2, -0.3], rpy_deg: [0, 30, 0]}\n"
                                                      "    casts_shadow: true\n");
  const sim::Scene scene = sim::loadScene(path);
  const render::RenderSettings settings = render::loadRenderSettings(path);
  REQUIRE(settings.meshes.size() == 1);
  const Eigen::Isometry3d view = test::lookAtBoard(scene.board, 1.8, 25.0, 160.0, 10.0);
  // The plate reaches more than 10 px past the box of the board's projected outline.
  std::vector<cv::Point2f> board_px, plate_px;
  for (const Eigen::Vector3d& p : sim::boardOutline(scene.board)) {
    const Eigen::Vector2d uv = sim::project(scene.camera, view * p);
    board_px.emplace_back(static_cast<float>(uv.x()), static_cast<float>(uv.y()));
  }
  for (double x : {-0.10, 0.10})
    for (double y : {-0.05, 0.05})
      for (double z : {-0.005, 0.005}) {
        const Eigen::Vector2d uv = sim::project(scene.camera, view * (settings.meshes[0].frame_T_mesh * Eigen::Vector3d(x, y, z)));
        plate_px.emplace_back(static_cast<float>(uv.x()), static_cast<float>(uv.y()));
      }
  const cv::Rect2f board_box = cv::boundingRect(board_px), plate_box = cv::boundingRect(plate_px);
  const float past = std::max({board_box.x - plate_box.x, board_box.y - plate_box.y, plate_box.br().x - board_box.br().x,
                               plate_box.br().y - board_box.br().y});
  CAPTURE(past);
  REQUIRE(past > 10.f);
  CHECK(requireSameImages(scene, settings, {view}) == 1);
  // The plate is really in the picture: without it the image differs.
  render::RenderSettings bare = settings;
  bare.meshes.clear();
  CHECK(differingPixels(test::renderCleanWith(scene, settings, view), test::renderCleanWith(scene, bare, view)) > 500);
}

TEST_CASE("a camera nearer the board than the crop's depth limit draws the whole frame", "[render][crop]") {
  // 0.03 m from the board centre: the board's corners are beside and behind the camera, where the
  // projection of a box no longer bounds what is drawn; the renderer falls back to the whole frame.
  const sim::Scene scene = offCentreScene();
  const Eigen::Isometry3d near = test::lookAtBoard(scene.board, 0.03, 50.0, 30.0, 0.0);
  CHECK(requireSameImages(scene, render::loadRenderSettings(sim::kDefaultScene), {near}) == 1);
}

TEST_CASE("outputStripsReading: every output pixel outside the strips reads no pinhole pixel inside the drawn one",
          "[render][crop][distortion]") {
  // Brute force over a small camera: the bicubic lookup at (x, y) reads pixels floor(x) - 1 .. floor(x) + 2
  // (likewise in y); outside the returned rectangle none of them may lie in the drawn rectangle.
  const sim::Camera c = smallDistortedCamera();
  const render::DistortionMap map = render::makeDistortionMap(c);
  const cv::Rect drawn(map.pinhole.width_px / 3, map.pinhole.height_px / 4, 30, 20);
  const std::vector<cv::Rect> strips = render::outputStripsReading(map, drawn);
  REQUIRE(!strips.empty());
  int area = 0;
  for (const cv::Rect& s : strips) area += s.area();
  CHECK(area < c.width_px * c.height_px / 2);  // it does crop
  const auto inStrips = [&](int u, int v) {
    return std::any_of(strips.begin(), strips.end(), [&](const cv::Rect& s) { return s.contains(cv::Point(u, v)); });
  };
  int inside_reads = 0;
  for (int v = 0; v < c.height_px; ++v) {
    for (int u = 0; u < c.width_px; ++u) {
      const float x = map.map_x.at<float>(v, u), y = map.map_y.at<float>(v, u);
      if (x < 0) continue;
      const cv::Rect reads(static_cast<int>(std::floor(x)) - 1, static_cast<int>(std::floor(y)) - 1, 4, 4);
      if ((reads & drawn).empty()) continue;
      ++inside_reads;
      CAPTURE(u, v, x, y);
      CHECK(inStrips(u, v));
    }
  }
  CHECK(inside_reads > 0);
  CHECK(render::outputStripsReading(map, cv::Rect()).empty());
}

TEST_CASE("the precomputed fixed-point distortion maps give cv::remap's pixels from the float maps", "[render][distortion]") {
  // cv::remap converts float maps to fixed point (1/32 px) on every call; doing it once must not change a pixel.
  const sim::Camera c = smallDistortedCamera();
  const render::DistortionMap map = render::makeDistortionMap(c);
  cv::Mat pinhole(map.pinhole.height_px, map.pinhole.width_px, CV_8UC1);
  cv::RNG rng(7);
  rng.fill(pinhole, cv::RNG::UNIFORM, 0, 256);
  cv::Mat expected;
  cv::remap(pinhole, expected, map.map_x, map.map_y, cv::INTER_CUBIC, cv::BORDER_CONSTANT, cv::Scalar::all(40));
  CHECK(differingPixels(render::applyDistortion(map, pinhole, 40.0), expected) == 0);
}

TEST_CASE("the cropped remap gives cv::remap's pixels where lookups read one grey level and where they do not",
          "[render][crop][distortion]") {
  // applyDistortion with a drawn rectangle fills the tiles and pixels whose 4 x 4 lookups all read one grey
  // level and remaps the rest: against cv::remap of the float maps over the whole image, on a pinhole image
  // of 8 x 8 px blocks (the background level, two other levels, noise) inside the drawn rectangle.
  const sim::Camera c = smallDistortedCamera();
  const render::DistortionMap map = render::makeDistortionMap(c);
  const cv::Rect drawn(map.pinhole.width_px / 5, map.pinhole.height_px / 6, map.pinhole.width_px / 2, map.pinhole.height_px / 2);
  cv::RNG rng(11);
  for (const int background : {40, 0}) {
    CAPTURE(background);
    cv::Mat pinhole(map.pinhole.height_px, map.pinhole.width_px, CV_8UC1, cv::Scalar(background));
    for (int y = drawn.y; y < drawn.br().y; y += 8) {
      for (int x = drawn.x; x < drawn.br().x; x += 8) {
        cv::Mat block = pinhole(cv::Rect(x, y, 8, 8) & drawn);
        const int kind = rng.uniform(0, 4);
        if (kind == 3) {
          rng.fill(block, cv::RNG::UNIFORM, 0, 256);
        } else {
          block.setTo(kind == 0 ? background : kind == 1 ? 10 : 200);
        }
      }
    }
    cv::Mat expected;
    cv::remap(pinhole, expected, map.map_x, map.map_y, cv::INTER_CUBIC, cv::BORDER_CONSTANT, cv::Scalar::all(background));
    CHECK(differingPixels(render::applyDistortion(map, pinhole, background, drawn), expected) == 0);
    // Uniform lookups of each level were there to be filled, and mixed ones to be remapped.
    CHECK(cv::countNonZero(expected == 10) > 200);
    CHECK(cv::countNonZero(expected == 200) > 200);
    CHECK(cv::countNonZero(expected != 10 & expected != 200 & expected != background) > 500);
  }
  // Output pixels without a ray (the distortion folds over before the image corners) get the
  // background even where every pixel around their tile's lookups holds another level.
  sim::Camera folded = c;
  folded.distortion = {-0.8, 0.0, 0.0, 0.0, 0.0};
  const render::DistortionMap fold_map = render::makeDistortionMap(folded);
  REQUIRE(cv::countNonZero(fold_map.map_x < 0) > 0);
  const cv::Mat level(fold_map.pinhole.height_px, fold_map.pinhole.width_px, CV_8UC1, cv::Scalar(200));
  cv::Mat expected;
  cv::remap(level, expected, fold_map.map_x, fold_map.map_y, cv::INTER_CUBIC, cv::BORDER_CONSTANT, cv::Scalar::all(40));
  CHECK(differingPixels(render::applyDistortion(fold_map, level, 40, cv::Rect(0, 0, level.cols, level.rows)), expected) == 0);
  CHECK(cv::countNonZero(expected == 40) >= cv::countNonZero(fold_map.map_x < 0));
}

TEST_CASE("a renderer given its distortion map built beforehand draws the same images", "[render][distortion]") {
  // renderDataset builds the map on another thread while it generates the configurations.
  sim::Scene scene = offCentreScene();
  scene.camera.distortion = {-0.2, 0.08, 0.0008, -0.0006, -0.01};
  const render::RenderSettings settings = render::loadRenderSettings(sim::kDefaultScene);
  std::future<render::DistortionMap> map =
      std::async(std::launch::async, [c = scene.camera] { return render::makeDistortionMap(c); });
  render::BoardRenderer given(scene, settings, &map), own(scene, settings);
  CHECK(!map.valid());  // taken
  int seen = 0;
  for (const Eigen::Isometry3d& view : views(scene.board)) {
    const cv::Mat a = given.renderClean(view), b = own.renderClean(view);
    CHECK(differingPixels(a, b) == 0);
    double lo = 0, hi = 0;
    cv::minMaxLoc(b, &lo, &hi);
    seen += hi > lo ? 1 : 0;
  }
  CHECK(seen == 3);
}
