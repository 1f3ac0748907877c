// Subcommands on images: measure (dataset images -> measured flange poses) and intrinsics (Zhang).
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>

#include "cli.hpp"
#include "orbcal/sim/camera_io.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/vision/intrinsics.hpp"
#include "orbcal/vision/measurement.hpp"
#include "progress.hpp"

namespace orbcal::tools {

namespace {

void addDetectorOption(CLI::App& cmd, std::string& detector) {
  cmd.add_option("--detector", detector,
                 "corner detector: classic (findChessboardCorners + cornerSubPix) or sb (findChessboardCornersSB, slower)")
      ->capture_default_str()
      ->check(CLI::IsMember({"classic", "sb"}));
}

void addMeasureCommand(CLI::App& app) {
  struct Opts {
    std::string dataset;
    std::string out;
    std::string detector = "classic";
    vision::MeasureSettings settings;
  };
  auto opt = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand(
      "measure", "Board images of a dataset -> measured flange poses with covariance (<dataset>/measurements.csv)");
  cmd->add_option("dataset", opt->dataset, "dataset folder (manifest.yaml, robot.yaml, scene.yaml, samples.csv, images)")
      ->required();
  cmd->add_option("-o,--out", opt->out, "output table (default: <dataset>/measurements.csv); written atomically");
  addDetectorOption(*cmd, opt->detector);
  cmd->add_option("--max-rms-px", opt->settings.max_rms_px, "reject poses whose corners reproject worse than this (px)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->callback([opt] {
    opt->settings.detector.detector = vision::parseDetector(opt->detector);
    const sim::Dataset ds = sim::loadDataset(opt->dataset);
    std::optional<sim::FolderLock> lock;  // measurements.csv goes into the dataset folder: no other writer meanwhile
    if (opt->out.empty()) lock.emplace(opt->dataset, "orbcal measure");
    Progress bar("measure", static_cast<int>(ds.samples.size()));
    const auto rows = vision::measureDataset(ds, opt->settings, [&](int d, int) { bar.update(d); });
    bar.finish();
    const std::string out = opt->out.empty() ? ds.path("measurements.csv") : opt->out;
    sim::writeFileAtomic(out, vision::formatMeasurementsCsv(rows));
    const vision::MeasurementSummary summary = vision::summarize(rows);
    std::printf("%s", vision::formatSummary(summary).c_str());
    std::printf("-> %s\n", out.c_str());
    std::fflush(stdout);  // the summary first, then main's one-line error on stderr
    if (summary.found == 0) {
      throw sim::InputError("measure: no image of " + opt->dataset + " gave a pose (statuses in " + out + ")");
    }
  });
}

void addIntrinsicsCommand(CLI::App& app) {
  struct Opts {
    std::vector<std::string> images;
    std::string scene;
    int corners_x = 0, corners_y = 0;
    double square_m = 0.0;
    std::string out = "intrinsics.yaml";
    std::string detector = "classic";
    vision::IntrinsicsSettings settings;
  };
  auto opt = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand(
      "intrinsics", "Camera intrinsics from board images (Zhang's method, cv::calibrateCamera) -> YAML");
  cmd->add_option("images", opt->images,
                 "board images (any format OpenCV reads), all from one camera; a folder stands for every image file in it "
                 "(png jpg jpeg bmp tif tiff pgm ppm pnm webp), sorted by name")
      ->required();
  cmd->add_option("--scene", opt->scene, "take the board from this scene (YAML; or builtin:default_scene.yaml); a ChArUco board's corners are found by identity");
  cmd->add_option("--corners-x", opt->corners_x, "inner corners along a row (e.g. 9)")->check(CLI::Range(2, 1000));
  cmd->add_option("--corners-y", opt->corners_y, "inner corners along a column (e.g. 6)")->check(CLI::Range(2, 1000));
  cmd->add_option("--square-m", opt->square_m, "side of one square (m)")->check(CLI::PositiveNumber);
  cmd->add_option("-o,--out", opt->out,
                 "output YAML; beside it STEM_camera_info.yaml (ROS camera_info) and STEM_opencv.yml (OpenCV "
                 "FileStorage), either usable as a scene's camera: {file: ...}; all written atomically")
      ->capture_default_str();
  addDetectorOption(*cmd, opt->detector);
  cmd->add_flag("--fix-aspect-ratio", opt->settings.fix_aspect_ratio, "fx = fy");
  cmd->add_flag("--zero-tangential", opt->settings.zero_tangential, "p1 = p2 = 0");
  cmd->add_flag("--fix-k3", opt->settings.fix_k3, "k3 = 0");
  cmd->add_option("--subpix-window", opt->settings.detector.fixed_subpix_half_window_px,
                  "cornerSubPix half window [px] for every image (OpenCV's calibration sample and tutorial: 11). Default: "
                  "min(5, 0.4 x the smallest corner spacing), which moves fx by about 0.6 % on OpenCV's left*.jpg sample "
                  "images against their published left_intrinsics.yml")
      ->check(CLI::Range(1, 100));
  cmd->callback([opt] {
    sim::Board board;
    if (!opt->scene.empty()) board = sim::loadScene(opt->scene).board;
    const bool any_size = opt->corners_x > 0 || opt->corners_y > 0 || opt->square_m > 0.0;
    if (opt->scene.empty() && !(opt->corners_x > 0 && opt->corners_y > 0 && opt->square_m > 0.0)) {
      throw sim::InputError("intrinsics: give --scene, or all of --corners-x, --corners-y and --square-m");
    }
    if (any_size) {
      if (opt->corners_x > 0) board.corners_x = opt->corners_x;
      if (opt->corners_y > 0) board.corners_y = opt->corners_y;
      if (opt->square_m > 0.0) board.square_m = opt->square_m;
    }
    opt->settings.detector.detector = vision::parseDetector(opt->detector);
    const std::vector<std::string> images = vision::expandImageArguments(opt->images);
    const vision::IntrinsicsResult r = vision::calibrateIntrinsicsFromFiles(images, board, opt->settings);
    for (const auto& im : r.images) {
      std::printf("  %-10s %s", vision::toString(im.status), im.image.c_str());
      if (im.status == vision::ImageStatus::kFound && r.ok) std::printf("  (RMS %.3f px)", im.rms_px);
      if (!im.reason.empty()) std::printf("  %s%s%s", im.reason.c_str(), im.detail.empty() ? "" : ": ", im.detail.c_str());
      std::printf("\n");
    }
    const std::string parent = std::filesystem::path(opt->out).parent_path().string();
    if (!parent.empty()) sim::makeDirectories(parent);  // -o calib/cam.yaml into a folder not made yet
    sim::writeFileAtomic(opt->out, vision::formatIntrinsicsYaml(r, board));
    if (!r.ok) throw sim::InputError("intrinsics: " + r.reason + " (statuses written to " + opt->out + ")");
    const vision::CameraFileNames files = vision::cameraFileNames(opt->out);
    sim::writeFileAtomic(files.camera_info, sim::formatCameraInfoYaml(r.camera, "orbcal_intrinsics"));
    sim::writeFileAtomic(files.opencv, sim::formatOpenCvCameraYaml(r.camera));
    const sim::Camera& c = r.camera;
    std::printf("%d of %zu images used; RMS %.4f px\n", r.images_used, r.images.size(), r.rms_px);
    std::printf("%s\n", vision::subpixWindowText(opt->settings.detector).c_str());
    std::printf("fx %.4f  fy %.4f  cx %.4f  cy %.4f px  (1-sigma %.3f %.3f %.3f %.3f)\n", c.fx_px, c.fy_px, c.cx_px,
                c.cy_px, r.std_dev[0], r.std_dev[1], r.std_dev[2], r.std_dev[3]);
    std::printf("distortion k1 k2 p1 p2 k3: %.6g %.6g %.6g %.6g %.6g\n", c.distortion[0], c.distortion[1],
                c.distortion[2], c.distortion[3], c.distortion[4]);
    std::printf("-> %s, %s, %s\n", opt->out.c_str(), files.camera_info.c_str(), files.opencv.c_str());
  });
}

}  // namespace

ORBCAL_COMMAND(40, addMeasureCommand);
ORBCAL_COMMAND(41, addIntrinsicsCommand);

}  // namespace orbcal::tools
