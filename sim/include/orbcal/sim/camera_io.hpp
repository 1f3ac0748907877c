#pragma once
// Camera files as the ecosystem writes them, beside the scene file's own `camera:` keys:
//  - ROS camera_info YAML (camera_calibration_parsers): image_width, image_height, camera_name,
//    camera_matrix {rows: 3, cols: 3, data}, distortion_model (plumb_bob or rational_polynomial),
//    distortion_coefficients {rows: 1, cols: N, data}, rectification_matrix (3x3), projection_matrix (3x4);
//  - OpenCV FileStorage YAML ("%YAML:1.0", cv::FileStorage): camera_matrix and distortion_coefficients
//    as !!opencv-matrix {rows, cols, dt, data}, image_width and image_height.
// Both are read with yaml-cpp (sim does not depend on OpenCV): the FileStorage directive line
// "%YAML:1.0", which is not YAML 1.2 syntax, is dropped before parsing; the !!opencv-matrix tag is
// ignored. orbcal's camera is OpenCV's 5-coefficient model (k1 k2 p1 p2 k3): a rational_polynomial
// file (8 coefficients) reads only when k4 = k5 = k6 = 0. The camera matrix K and the distortion are
// used; a camera_info's rectification and projection matrices (for rectified images) are checked for
// size and finiteness only, since orbcal works on the raw image.
#include <functional>
#include <string>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/scene.hpp"

namespace orbcal::sim {

enum class CameraFileFormat { kRosCameraInfo, kOpenCvFileStorage };

/// The scene's inline camera keys (width_px, height_px, fx_px, fy_px, cx_px, cy_px, distortion).
Camera parseInlineCamera(const ConfigNode& cam);

/// Reads a camera_info or FileStorage file, the format told by its content (a "%YAML:" first line or
/// !!opencv-matrix: FileStorage; distortion_model or camera_name: camera_info). Errors are InputError
/// naming the file and the key. `format` (optional) receives which one it was.
Camera loadCameraFile(const std::string& path, CameraFileFormat* format = nullptr);
Camera parseCameraFile(const std::string& text, const std::string& source, CameraFileFormat* format = nullptr);

/// The scene's `camera:` section: inline keys, or {file: PATH} (PATH relative to `scene_dir` unless
/// absolute; empty scene_dir: the current folder). `resolved_file` receives the file's path (empty
/// when inline).
Camera parseSceneCamera(const ConfigNode& cam, const std::string& scene_dir, std::string* resolved_file = nullptr);

/// Range checks shared by every camera source; `key(name)` is the node to blame for field `name`
/// (width_px, height_px, fx_px, fy_px, cx_px, cy_px, distortion). Rejects sizes outside 16..16384,
/// focal lengths outside [1, 1e6] px, a principal point outside the image, |k_i| > 10.
void checkCamera(const Camera& c, const std::function<ConfigNode(const std::string&)>& key);

/// A ROS camera_info YAML for `c` (plumb_bob, R = I, P = [K | 0]); numbers written exactly.
std::string formatCameraInfoYaml(const Camera& c, const std::string& camera_name);
/// An OpenCV FileStorage YAML for `c` (what cv::FileStorage writes: camera_matrix,
/// distortion_coefficients as 5x1, image_width, image_height); numbers written exactly.
std::string formatOpenCvCameraYaml(const Camera& c);

}  // namespace orbcal::sim
