#pragma once
// The inputs a rendered dataset copies into its folder so that it stands alone: the meshes and the
// camera file its scene names, and the scene's text with their paths rewritten to the copies. Internal
// to render/src/dataset_*.cpp.
#include <string>
#include <vector>

#include "orbcal/render/settings.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/scene.hpp"

namespace orbcal::render::dataset_copies {

/// A mesh file the scene uses, as copied into the dataset folder.
/// Where `orbcal render --profile` and `--configs` keep their files in the dataset folder.
inline constexpr const char* kProfileFile = "camera_profile.yaml";
inline constexpr const char* kConfigsFile = "configurations.csv";
/// A dataset of flange poses: its image description (sim::kImagesDescriptionFile) names this camera file.
inline constexpr const char* kImagesCameraFile = "images_camera.yaml";

struct MeshCopy {
  std::string relative;    ///< path inside the dataset folder, '/'-separated
  std::string bytes;       ///< the file's content
  bool rewritten = false;  ///< the copied scene.yaml names it by `relative` instead of as written
};

/// Where each mesh goes in the dataset folder, so that the copied scene.yaml (at DIR/scene.yaml; relative
/// mesh paths resolve against its folder) finds it: a relative path without ".." keeps its place,
/// DIR/<path>; an absolute one, one with "..", or one that would land on the dataset's own files goes to
/// DIR/meshes/<file name> (made unique) and is rewritten in the copied scene. Reads every mesh.
std::vector<MeshCopy> planMeshCopies(const RenderSettings& settings, const sim::DatasetManifest& m);

/// The scene text with the `file:` value of each rewritten mesh replaced by its place in the dataset,
/// everything else (comments, layout) unchanged, and a comment at the top saying what was rewritten.
std::string rewriteMeshPaths(const std::string& scene_text, const RenderSettings& settings,
                             const std::vector<MeshCopy>& copies);

/// A scene whose camera is {file: PATH} (sim::Scene::camera_file): the camera file goes into the dataset
/// as camera.EXT (camera-2.EXT, ... if a mesh copy holds that name), appended to `files`, and the copied
/// scene's camera.file names it (whether PATH was relative, absolute or had ".."), so the dataset
/// stands alone. Returns the scene text to copy.
std::string placeCameraFile(const sim::Scene& scene, const std::string& scene_copy, std::vector<MeshCopy>& files);

}  // namespace orbcal::render::dataset_copies
