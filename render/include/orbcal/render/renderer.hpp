#pragma once
// The calibration board (and any extra meshes) as the eye-in-hand camera sees it, rendered off-screen
// with OSMesa into an 8-bit grey framebuffer (multisampled when render.msaa_samples > 1) and read back
// into a cv::Mat. With render.crop_to_scene (default) only the bounding box of the drawables' projected
// bounding boxes is drawn, read back and undistorted; the rest is the background grey level GL stores,
// so the image is the whole frame's pixel for pixel (tests/render/test_crop.cpp).
//
// Projection: exactly OpenCV's pinhole model, pixel centres at integer coordinates, y down, any
// principal point (sim::project). GL pixel i spans [i, i+1] with its centre at i + 0.5 and GL's rows
// go up, so after the row flip u = x_window - 0.5 and v = H - y_window - 0.5; glProjection() folds
// that in. Supersampling by s renders the camera scaledCamera(camera, s): f -> s f and
// c -> s (c + 0.5) - 0.5, then averages s x s blocks (cv::INTER_AREA). Distortion: distortion.hpp.
//
// Board colouring (the vision library relies on it to fix the corner order):
//   square (i, j), i in [0, corners_x], j in [0, corners_y], covers x in [(i-1) s, i s] and
//   y in [(j-1) s, j s] of the board frame, and is BLACK when (i + j) is even, white otherwise.
//   So the square touching the first inner corner diagonally, (-s, -s)..(0, 0), is black.
//   A white margin of margin_m surrounds the squares. The printed face looks along -z_board; the
//   back (seen from +z) is a uniform grey (render.board_back).
//   A ChArUco board (sim::BoardType::kCharuco) adds its ArUco markers (sim::charucoMarkers, the bits of
//   OpenCV's dictionary) in the white squares: a mipmapped texture of their black cells, 128 texels per
//   square, added to the board filter's black fraction (render.board_filter must be on).
//   A circle grid (sim::BoardType::kCircles) is white with its black circles where sim::cornerInBoard puts
//   their centres, drawn analytically by the board filter (which must be on): each circle's edge a ramp
//   one pixel's footprint wide, symmetric about it; the white area is sim::squaresOutline plus margin_m.
//
// Lighting (GLSL 330 core): L = albedo (ambient + sun max(0, n.l) shadow) + specular sun (n.h)^shininess shadow,
// n facing the viewer, l toward the sun (given in the base frame), h the half vector; then times the
// exposure and clamped to [0, 1] -> 0..255. Shadows: a shadow map from the sun of the meshes with
// casts_shadow (the scene is static in the board frame, so the map is computed once).
#include <Eigen/Geometry>
#include <cstdint>
#include <future>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "orbcal/render/camera_profile.hpp"
#include "orbcal/render/distortion.hpp"
#include "orbcal/render/settings.hpp"
#include "orbcal/sim/scene.hpp"

namespace orbcal::render {

/// The camera of an image s times larger in each direction: f -> s f, c -> s (c + 0.5) - 0.5.
sim::Camera scaledCamera(const sim::Camera& camera, int s);

/// OpenGL projection matrix for eye coordinates diag(1, -1, -1) p_cam (OpenCV camera frame -> GL eye
/// frame) that reproduces OpenCV's pinhole model of `pinhole` (its distortion is ignored) after the
/// readback row flip: P(0,0) = 2 fx / W, P(0,2) = 1 - 2 (cx + 0.5) / W, P(1,1) = 2 fy / H,
/// P(1,2) = 2 (cy + 0.5) / H - 1, P(3,2) = -1, depth terms from near_m and far_m.
Eigen::Matrix4d glProjection(const sim::Camera& pinhole, double near_m, double far_m);

class BoardRenderer {
 public:
  /// Creates its own OSMesa context, loads the meshes (sim::InputError naming the scene file, key and
  /// mesh path when one is missing), builds the framebuffers (falls back from MSAA with a warning)
  /// and, with distortion, the inverse distortion map. Throws std::runtime_error on GL failures.
  /// `distortion_map`, when given and valid, is makeDistortionMap(scene.camera) started earlier (e.g.
  /// std::async, so that it is built while the caller prepares other things): taken instead of building it.
  BoardRenderer(const sim::Scene& scene, const RenderSettings& settings,
                std::future<DistortionMap>* distortion_map = nullptr);
  /// The same with a camera profile (camera_profile.hpp): the board drawn as printed (its print scale,
  /// bow and corner displacements: printedBoardPoint; sim::InputError naming profile.source when the
  /// board part does not fit the scene's board: checkBoardPrint), and finish() applying its image part.
  BoardRenderer(const sim::Scene& scene, const RenderSettings& settings, const CameraProfile& profile,
                std::future<DistortionMap>* distortion_map = nullptr);
  ~BoardRenderer();
  BoardRenderer(const BoardRenderer&) = delete;
  BoardRenderer& operator=(const BoardRenderer&) = delete;

  /// The noise-free image (CV_8UC1, camera size) of the scene seen from camera_T_board, exposure applied
  /// (with a profile: its board drawn as printed, without its image part).
  cv::Mat renderClean(const Eigen::Isometry3d& camera_T_board);
  /// renderClean, then the scene's degradations (degrade.hpp), then the camera profile's image part
  /// (applyCameraProfile, about the real camera's principal point, the background where nothing is
  /// drawn), both drawn from one stream sim::makeRng(seed, stream) in that order.
  cv::Mat render(const Eigen::Isometry3d& camera_T_board, std::uint64_t seed, std::uint64_t stream);

  /// render() in two halves, so that a pipeline can draw the next frame while another thread finishes
  /// this one: draw() does the OpenGL work (one thread at a time: the context's); finish() applies the
  /// lens distortion and the degradations, is const and may run on any thread, concurrently with
  /// draw() and other finish() calls. finish(draw(T), seed, stream) is exactly render(T, seed, stream).
  struct Drawn {
    cv::Mat pinhole;  ///< the image OpenGL drew (the undistorted pinhole camera's size; averaged down)
    cv::Rect rect;    ///< its pixels that were drawn; the rest is background
    bool cropped = false;
    cv::Mat coverage; ///< like pinhole, 255 where the board or a mesh covers the pixel (fractions at edges), 0
                      ///< where not; only when the profile has a background (else empty)
  };
  Drawn draw(const Eigen::Isometry3d& camera_T_board);
  cv::Mat finish(const Drawn& drawn, std::uint64_t seed, std::uint64_t stream) const;

  /// Samples per pixel of the multisampled framebuffer in use (0: none).
  int msaaSamples() const;
  /// What was asked for but could not be given (e.g. "msaa_samples: 8 requested, GL_MAX_SAMPLES is 4; using 4").
  const std::vector<std::string>& warnings() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace orbcal::render
