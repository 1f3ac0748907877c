#pragma once
// The rendering sections of a scene file (lighting, degradations, meshes, render), read from the same
// YAML as sim::loadScene with sim::ConfigNode: misspelt keys are errors naming the file and the key.
//
//   lighting:
//     ambient: 0.35                    # light reaching every surface: adds albedo * ambient (before exposure)
//     sun: {to_sun_base: [x, y, z],    # direction TOWARD the sun in the base frame (normalised on load)
//           intensity: 0.7}            # Lambert term: albedo * intensity * max(0, n . l)
//     specular: {strength: 0.08, shininess: 60}   # Blinn-Phong highlight on the board (and meshes)
//   degradations:
//     exposure: 1.0                    # gain on the rendered radiance (1 = nominal)
//     defocus_sigma_px: 0.0            # Gaussian blur; 0 = off
//     full_well_e: 0                   # shot noise: electrons at full scale (255 DN); 0 = off
//     read_noise_dn: 0.0               # Gaussian read noise (DN, 8-bit); 0 = off
//   meshes:                            # extra geometry (Assimp: .obj, .ply, .stl, ...) that occludes and shadows
//     - file: meshes/board_frame.obj   # relative to the scene file's folder (absolute paths allowed)
//       frame: board                   # 'board' or 'base': the frame `pose` is given in
//       pose: {xyz_m: [0, 0, 0], rpy_deg: [0, 0, 0]}   # frame_T_mesh
//       scale: 1.0                     # mesh units -> m
//       albedo: 0.5                    # grey reflectance 0..1
//       casts_shadow: true
//   render:
//     msaa_samples: 0                  # 0 or 1 = off; clamped to GL_MAX_SAMPLES (warning); smooths mesh and board outlines
//     supersample: 1                   # render s times larger and average down (INTER_AREA)
//     board_black: 0.05                # albedo of the black squares
//     board_white: 0.85                # albedo of the white squares and the margin
//     board_back: 0.3                  # albedo of the unprinted back of the board
//     background: 0.0                  # value where nothing is drawn (deep space)
//     board_filter: true               # the pattern averaged over each pixel's footprint analytically
//                                      # (on top of MSAA); false = flat square colours, MSAA only
//     crop_to_scene: true              # draw and read back only the box the board and meshes project into
//                                      # (the same image, faster); false = the whole frame
//
// Every section and key is optional; absent ones take the defaults below. Top-level keys are checked
// against sim::sceneTopLevelKeys() here as in sim::loadScene.
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "orbcal/sim/config.hpp"

namespace orbcal::render {

struct Lighting {
  double ambient = 0.35;
  Eigen::Vector3d to_sun_base = Eigen::Vector3d(-0.6, -0.3, 0.74).normalized();  ///< unit, base frame
  double sun_intensity = 0.6;
  double specular_strength = 0.08;
  double shininess = 60.0;
};

struct Degradations {
  double exposure = 1.0;
  double defocus_sigma_px = 0.0;
  double full_well_e = 0.0;    ///< 0: no shot noise
  double read_noise_dn = 0.0;  ///< 0: no read noise
  bool any() const { return exposure != 1.0 || defocus_sigma_px > 0 || full_well_e > 0 || read_noise_dn > 0; }
};

enum class MeshFrame { kBase, kBoard };

struct MeshSpec {
  std::string file;  ///< resolved path (relative ones resolved against the scene file's folder)
  std::string file_as_written;  ///< the `file` value as the scene file gives it (absolute or relative)
  std::string key;   ///< e.g. "meshes[0].file", for messages
  MeshFrame frame = MeshFrame::kBoard;
  Eigen::Isometry3d frame_T_mesh = Eigen::Isometry3d::Identity();
  double scale = 1.0;
  double albedo = 0.5;
  bool casts_shadow = true;
};

struct RenderOptions {
  int msaa_samples = 0;  ///< the board filter alone gives the corners MSAA 4 gave, in half the time (docs, Speed)
  int supersample = 1;
  double board_black = 0.05;
  double board_white = 0.85;
  double board_back = 0.3;
  double background = 0.0;
  bool board_filter = true;  ///< the printed pattern box-filtered over each pixel analytically (on top of MSAA)
  /// Clear, draw, read back (and undistort) only the pixels the board and meshes can cover: the bounding
  /// box of their projected bounding boxes. The same image as the whole frame (the rest is background
  /// either way); the whole frame is drawn whenever a box reaches the near plane.
  bool crop_to_scene = true;
};

struct RenderSettings {
  std::string source;  ///< the scene file (for messages)
  Lighting lighting;
  Degradations degradations;
  std::vector<MeshSpec> meshes;
  RenderOptions options;
};

/// Reads the rendering sections of the scene file at `path` (a file or "builtin:default_scene.yaml").
/// Throws sim::InputError naming the file and the key (unknown top-level keys included). Mesh files are
/// not opened here (see mesh.hpp).
RenderSettings loadRenderSettings(const std::string& path);
/// Same from a parsed root; relative mesh paths are resolved against `base_dir` (empty: the current folder).
RenderSettings parseRenderSettings(const sim::ConfigNode& root, const std::string& base_dir);

}  // namespace orbcal::render
