// Extra meshes (Assimp): occlusion, shadows, and the errors of the scene's rendering sections.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>

#include "orbcal/render/mesh.hpp"
#include "orbcal/render/renderer.hpp"
#include "orbcal/render/settings.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/io.hpp"
#include "render_test_util.hpp"
#include "test_util.hpp"

using namespace orbcal;
using Catch::Matchers::Contains;

namespace {
constexpr int kEdgePx = 3;            // pixels this close to the silhouette may be partly covered (MSAA)
constexpr int kPlateUniformityDn = 4;  // the plate's face: flat, one normal; only the highlight varies
constexpr int kMinHiddenPx = 2000;

std::string plateYaml(bool casts_shadow) {
  return std::string("meshes:\n"
                     "  - file: meshes/occluder_plate.obj\n"
                     "    frame: board\n"
                     "    pose: {xyz_m: [0.32, 0.2, -0.3], rpy_deg: [0, 0, 0]}\n"
                     "    albedo: 0.5\n"
                     "    casts_shadow: ") +
         (casts_shadow ? "true" : "false") + "\n";
}

/// Mask (CV_8U, 255 inside) of the plate's silhouette: convex hull of its 8 projected corners.
cv::Mat plateSilhouette(const sim::Scene& scene, const Eigen::Isometry3d& camera_T_board, const Eigen::Isometry3d& board_T_plate) {
  std::vector<cv::Point> pts;
  for (double x : {-0.10, 0.10})
    for (double y : {-0.05, 0.05})
      for (double z : {-0.005, 0.005}) {
        const Eigen::Vector2d uv = sim::project(scene.camera, camera_T_board * (board_T_plate * Eigen::Vector3d(x, y, z)));
        pts.emplace_back(static_cast<int>(std::lround(uv.x())), static_cast<int>(std::lround(uv.y())));
      }
  std::vector<cv::Point> hull;
  cv::convexHull(pts, hull);
  cv::Mat mask(scene.camera.height_px, scene.camera.width_px, CV_8UC1, cv::Scalar(0));
  cv::fillConvexPoly(mask, hull, cv::Scalar(255));
  return mask;
}
}  // namespace

TEST_CASE("an Assimp mesh in front of the board hides exactly the pixels it covers", "[render][mesh]") {
  const std::string dir = test::tempDir("render-mesh-occlusion");
  const std::string scene_path = test::writeSceneWithPlate(dir, plateYaml(false));
  const sim::Scene scene = sim::loadScene(scene_path);
  const render::RenderSettings with_mesh = render::loadRenderSettings(scene_path);
  REQUIRE(with_mesh.meshes.size() == 1);
  REQUIRE(with_mesh.meshes[0].file == dir + "/meshes/occluder_plate.obj");  // relative to the scene file
  render::RenderSettings without_mesh = with_mesh;
  without_mesh.meshes.clear();

  const Eigen::Isometry3d camera_T_board = test::lookAtBoard(scene.board, 2.0, 20.0, 30.0, 10.0);
  const cv::Mat occluded = test::renderCleanWith(scene, with_mesh, camera_T_board);
  const cv::Mat clean = test::renderCleanWith(scene, without_mesh, camera_T_board);
  const cv::Mat mask = plateSilhouette(scene, camera_T_board, with_mesh.meshes[0].frame_T_mesh);
  const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * kEdgePx + 1, 2 * kEdgePx + 1));
  cv::Mat inside, near;
  cv::erode(mask, inside, kernel);
  cv::dilate(mask, near, kernel);
  const int hidden = cv::countNonZero(inside);
  REQUIRE(hidden > kMinHiddenPx);

  // Inside: the plate's uniform grey, where the board behind shows both black and white squares.
  double plate_min = 0, plate_max = 0, board_min = 0, board_max = 0;
  cv::minMaxLoc(occluded, &plate_min, &plate_max, nullptr, nullptr, inside);
  cv::minMaxLoc(clean, &board_min, &board_max, nullptr, nullptr, inside);
  CAPTURE(plate_min, plate_max, board_min, board_max);
  CHECK(plate_max - plate_min <= kPlateUniformityDn);
  CHECK(board_max - board_min > 100);
  // Outside (no shadow cast): every pixel as without the mesh.
  cv::Mat diff;
  cv::absdiff(occluded, clean, diff);
  diff.setTo(0, near);
  CHECK(cv::countNonZero(diff) == 0);
}

TEST_CASE("a mesh casts a shadow from the sun onto the board", "[render][mesh][shadow]") {
  const std::string dir = test::tempDir("render-mesh-shadow");
  const std::string lit_path = test::writeSceneWithPlate(dir, plateYaml(false));
  const sim::Scene scene = sim::loadScene(lit_path);
  const render::RenderSettings no_shadow = render::loadRenderSettings(lit_path);
  render::RenderSettings shadow = no_shadow;
  shadow.meshes[0].casts_shadow = true;
  const Eigen::Isometry3d camera_T_board = test::lookAtBoard(scene.board, 2.2, 10.0, 0.0, 0.0);
  const cv::Mat a = test::renderCleanWith(scene, no_shadow, camera_T_board);
  const cv::Mat b = test::renderCleanWith(scene, shadow, camera_T_board);
  cv::Mat darker, brighter;
  cv::subtract(a, b, darker);    // saturates at 0
  cv::subtract(b, a, brighter);
  const int shadowed = cv::countNonZero(darker > 10);
  CAPTURE(shadowed);
  CHECK(shadowed > kMinHiddenPx);
  CHECK(cv::countNonZero(brighter > 1) == 0);
}

TEST_CASE("scene rendering sections: misspelt keys and missing meshes name the file and the key", "[render][settings]") {
  const std::string dir = test::tempDir("render-settings");
  {
    const std::string path = test::writeSceneWithPlate(dir, "meshes: []\nlighting_extra: 1\n");
    // sim::loadScene rejects unknown top-level keys; the render sections' own keys are checked here.
    REQUIRE_THROWS_AS(sim::loadScene(path), sim::InputError);
  }
  {
    std::string text = sim::readTextSource(sim::kDefaultScene);
    text.replace(text.find("  ambient: 0.35"), std::string("  ambient").size(), "  ambiant");
    const std::string path = dir + "/misspelt.yaml";
    std::ofstream(path) << text;
    REQUIRE_THROWS_WITH(render::loadRenderSettings(path), Contains(path) && Contains("lighting.ambiant") && Contains("unknown key"));
  }
  {
    const std::string path = test::writeSceneWithPlate(dir, "meshes:\n  - {file: meshes/no_such_truss.obj}\n");
    const sim::Scene scene = sim::loadScene(path);
    const render::RenderSettings settings = render::loadRenderSettings(path);
    REQUIRE_THROWS_WITH(render::BoardRenderer(scene, settings),
                        Contains(path) && Contains("meshes[0].file") && Contains(dir + "/meshes/no_such_truss.obj"));
  }
  {
    std::string text = sim::readTextSource(sim::kDefaultScene);
    text.replace(text.find("  supersample: 1"), std::string("  supersample: 1").size(), "  supersample: 0");
    const std::string path = dir + "/bad_supersample.yaml";
    std::ofstream(path) << text;
    REQUIRE_THROWS_WITH(render::loadRenderSettings(path), Contains(path) && Contains("render.supersample"));
  }
}

TEST_CASE("loadRenderSettings alone rejects a misspelt top-level section", "[render][settings]") {
  const std::string dir = test::tempDir("render-settings-top-level");
  // `lightning:` instead of `lighting:` would otherwise be ignored and the default lighting used.
  std::string text = sim::readTextSource(sim::kDefaultScene);
  text.replace(text.find("\nlighting:"), std::string("\nlighting:").size(), "\nlightning:");
  const std::string path = dir + "/lightning.yaml";
  std::ofstream(path) << text;
  REQUIRE_THROWS_WITH(render::loadRenderSettings(path), Contains(path) && Contains("lightning") && Contains("unknown key"));
  REQUIRE_THROWS_WITH(sim::loadScene(path), Contains(path) && Contains("lightning") && Contains("unknown key"));
  // Every allowed key is accepted by both (the default scene has them all but none extra).
  CHECK_NOTHROW(render::loadRenderSettings(sim::kDefaultScene));
}

TEST_CASE("a rendered image too large for OpenGL names the camera size and render.supersample", "[render][settings]") {
  sim::Scene scene = sim::loadScene(sim::kDefaultScene);
  scene.camera.width_px = 4096;
  scene.camera.height_px = 3072;
  render::RenderSettings settings = render::loadRenderSettings(sim::kDefaultScene);
  settings.options.supersample = 8;  // 32768 px wide: over llvmpipe's GL_MAX_RENDERBUFFER_SIZE of 16384
  REQUIRE_THROWS_AS(render::BoardRenderer(scene, settings), sim::InputError);
  REQUIRE_THROWS_WITH(render::BoardRenderer(scene, settings),
                      Contains("camera.width_px/height_px") && Contains("render.supersample") &&
                          Contains("GL_MAX_RENDERBUFFER_SIZE"));
}

TEST_CASE("the built-in default scene's rendering sections load", "[render][settings]") {
  const render::RenderSettings s = render::loadRenderSettings(sim::kDefaultScene);
  CHECK(s.options.msaa_samples == 0);  // the board filter anti-aliases the pattern
  CHECK(s.options.board_filter);
  CHECK(s.options.crop_to_scene);
  CHECK(s.meshes.empty());
  CHECK(!s.degradations.any());
  CHECK(s.lighting.to_sun_base.norm() == Approx(1.0));
}
