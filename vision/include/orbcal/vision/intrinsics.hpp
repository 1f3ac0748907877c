#pragma once
// Camera intrinsics from board images: Zhang's method (cv::calibrateCamera), the first link of the
// paper's chain. The board's orientation is not needed here (a half-turned board is still a plane),
// so images whose orientation is undecidable are kept.
#include <array>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "orbcal/sim/scene.hpp"
#include "orbcal/vision/corners.hpp"

namespace orbcal::vision {

struct IntrinsicsSettings {
  DetectorSettings detector;           ///< require_orientation is ignored (treated as false)
  bool fix_aspect_ratio = false;       ///< fx = fy (cv::CALIB_FIX_ASPECT_RATIO)
  bool zero_tangential = false;        ///< p1 = p2 = 0 (cv::CALIB_ZERO_TANGENT_DIST)
  bool fix_k3 = false;                 ///< k3 = 0 (cv::CALIB_FIX_K3)
  int min_images = 3;                  ///< fewer found images: no calibration (Zhang needs >= 3 views in general)
};

struct IntrinsicsImage {
  std::string image;
  ImageStatus status = ImageStatus::kNotFound;
  std::string reason, detail;
  double rms_px = 0.0;  ///< per-view reprojection RMS after calibration (found ones)
};

struct IntrinsicsResult {
  bool ok = false;
  std::string reason;            ///< why not, when !ok
  sim::Camera camera;            ///< width/height from the images; fx fy cx cy, (k1 k2 p1 p2 k3)
  double rms_px = 0.0;           ///< overall RMS (cv::calibrateCamera's return value)
  /// 1-sigma of fx fy cx cy k1 k2 p1 p2 k3 from calibrateCamera (0 for fixed ones; with
  /// fix_aspect_ratio OpenCV reports the focal length's in fy and 0 for fx).
  std::array<double, 9> std_dev{};
  int images_used = 0;
  std::vector<IntrinsicsImage> images;  ///< one per input, in input order
};

/// One detected view: every corner in sim::cornerInBoard order (any orientation), or (ChArUco) the
/// corners seen, corners_px[n] being inner corner ids[n].
struct BoardView {
  std::vector<Eigen::Vector2d> corners_px;
  std::vector<int> ids;  ///< empty: all corners in order
};

/// calibrateCamera on views already detected (all from one camera of size image_size).
/// Throws std::invalid_argument on a view with the wrong corner count.
IntrinsicsResult calibrateIntrinsics(const std::vector<BoardView>& views, const cv::Size& image_size,
                                     const sim::Board& board, const IntrinsicsSettings& settings = {});

/// Reads, detects and calibrates. Every path gets a status; a board image whose size differs from the
/// first board image's (another camera) is rejected. Never throws for a bad image. A ChArUco board's
/// views are its corners found by identity (detectCharuco), so partly visible boards count.
IntrinsicsResult calibrateIntrinsicsFromFiles(const std::vector<std::string>& paths, const sim::Board& board,
                                              const IntrinsicsSettings& settings = {});

/// YAML: a `camera:` section in the scene file's keys (paste it into a scene), plus the fit's RMS,
/// standard deviations and per-image statuses.
std::string formatIntrinsicsYaml(const IntrinsicsResult& r, const sim::Board& board);

/// The image arguments of `orbcal intrinsics`: a file stays as given; a folder becomes every image file
/// directly in it (by extension: png, jpg, jpeg, bmp, tif, tiff, pgm, ppm, pnm, webp; any case), sorted
/// by name; other files are ignored. Throws sim::InputError naming a folder without images, or an
/// argument that does not exist.
std::vector<std::string> expandImageArguments(const std::vector<std::string>& arguments);

/// The files `orbcal intrinsics -o OUT` writes beside OUT (OUT = DIR/STEM.EXT): DIR/STEM_camera_info.yaml
/// (ROS camera_info) and DIR/STEM_opencv.yml (OpenCV FileStorage). Either loads as a scene's camera
/// (`camera: {file: ...}`, sim/camera_io.hpp).
struct CameraFileNames {
  std::string camera_info, opencv;
};
CameraFileNames cameraFileNames(const std::string& out);

}  // namespace orbcal::vision
