// The camera files orbcal writes against OpenCV's own reader and writer (cv::FileStorage), and the
// image folder argument of `orbcal intrinsics`.
#include <catch2/catch.hpp>
#include <algorithm>
#include <opencv2/core.hpp>

#include "orbcal/sim/camera_io.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/vision/intrinsics.hpp"
#include "test_util.hpp"

using namespace orbcal;


TEST_CASE("OpenCV's FileStorage reads orbcal's file, and orbcal reads FileStorage's", "[vision][camera_files]") {
  const std::string dir = test::tempDir("camera-files-cv");
  const sim::Camera c = test::oddCamera();
  // orbcal -> OpenCV.
  test::write(dir + "/orbcal.yml", sim::formatOpenCvCameraYaml(c));
  cv::FileStorage in(dir + "/orbcal.yml", cv::FileStorage::READ);
  REQUIRE(in.isOpened());
  cv::Mat K, D;
  in["camera_matrix"] >> K;
  in["distortion_coefficients"] >> D;
  CHECK(static_cast<int>(in["image_width"]) == c.width_px);
  CHECK(static_cast<int>(in["image_height"]) == c.height_px);
  REQUIRE(K.rows == 3);
  REQUIRE(K.cols == 3);
  REQUIRE(D.total() == 5);
  CHECK(std::abs(K.at<double>(0, 0) - c.fx_px) <= 1e-12);
  CHECK(std::abs(K.at<double>(1, 1) - c.fy_px) <= 1e-12);
  CHECK(std::abs(K.at<double>(0, 2) - c.cx_px) <= 1e-12);
  CHECK(std::abs(K.at<double>(1, 2) - c.cy_px) <= 1e-12);
  CHECK(K.at<double>(2, 2) == 1.0);
  for (int i = 0; i < 5; ++i) CHECK(std::abs(D.at<double>(i) - c.distortion[i]) <= 1e-12);
  // OpenCV -> orbcal, written as OpenCV's calibration sample does (1x5 coefficients, extra keys).
  {
    cv::FileStorage out(dir + "/opencv.yml", cv::FileStorage::WRITE);
    out << "calibration_time" << "today" << "image_width" << c.width_px << "image_height" << c.height_px;
    out << "camera_matrix" << K << "distortion_coefficients" << D.reshape(1, 1) << "avg_reprojection_error" << 0.2;
  }
  sim::CameraFileFormat f{};
  const sim::Camera back = sim::loadCameraFile(dir + "/opencv.yml", &f);
  CHECK(f == sim::CameraFileFormat::kOpenCvFileStorage);
  test::checkSameCamera(back, c);
}

TEST_CASE("intrinsics image arguments: a folder is its images, sorted, none is an error", "[vision][camera_files][badinput]") {
  const std::string dir = test::tempDir("camera-files-folder");
  std::filesystem::create_directories(dir + "/imgs/sub.png");  // a folder with an image's name: ignored
  for (const char* name : {"b.png", "a.JPG", "c.tiff", "notes.txt", "c.png.bak"}) test::write(dir + "/imgs/" + name, "x");
  test::write(dir + "/single.png", "x");
  const std::vector<std::string> got = vision::expandImageArguments({dir + "/single.png", dir + "/imgs"});
  const std::vector<std::string> want{dir + "/single.png", dir + "/imgs/a.JPG", dir + "/imgs/b.png", dir + "/imgs/c.tiff"};
  CHECK(got == want);
  std::filesystem::create_directories(dir + "/empty");
  test::write(dir + "/empty/readme.md", "x");
  CHECK_THAT(test::inputError([&] { vision::expandImageArguments({dir + "/empty"}); }),
             Catch::StartsWith(dir + "/empty: no image files in this folder"));
  CHECK(test::inputError([&] { vision::expandImageArguments({dir + "/missing"}); }) ==
        dir + "/missing: no such image file or folder");
  const vision::CameraFileNames names = vision::cameraFileNames(dir + "/out/intr.yaml");
  CHECK(names.camera_info == dir + "/out/intr_camera_info.yaml");
  CHECK(names.opencv == dir + "/out/intr_opencv.yml");
}

TEST_CASE("OpenCV's own left_intrinsics.yml reads as a camera", "[vision][camera_files][real]") {
  const std::string file = "/usr/share/doc/opencv-doc/examples/data/left_intrinsics.yml";
  if (!std::filesystem::exists(file)) {
    ORBCAL_SKIP("" << file << " absent (Debian package opencv-doc)");
    return;
  }
  cv::FileStorage fs(file, cv::FileStorage::READ);
  cv::Mat K, D;
  fs["camera_matrix"] >> K;
  fs["distortion_coefficients"] >> D;
  const sim::Camera c = sim::loadCameraFile(file);
  CHECK(c.width_px == 640);
  CHECK(c.height_px == 480);
  CHECK(c.fx_px == K.at<double>(0, 0));
  CHECK(c.fy_px == K.at<double>(1, 1));
  CHECK(c.cx_px == K.at<double>(0, 2));
  CHECK(c.cy_px == K.at<double>(1, 2));
  for (int i = 0; i < 5; ++i) CHECK(c.distortion[i] == D.at<double>(i));
}

TEST_CASE("intrinsics from a folder of photographs: both camera files load as a scene's camera", "[vision][camera_files][real]") {
  const std::string data = "/usr/share/doc/opencv-doc/examples/data/";
  if (!std::filesystem::exists(data + "left01.jpg")) {
    ORBCAL_SKIP("" << data << " absent (Debian package opencv-doc)");
    return;
  }
  const std::string dir = test::tempDir("camera-files-intrinsics");
  std::filesystem::create_directories(dir + "/photos");
  std::size_t copied = 0;
  for (int i = 1; i <= 14; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "left%02d.jpg", i);
    if (!std::filesystem::exists(data + name)) continue;  // left10.jpg is not in the package
    std::filesystem::copy_file(data + name, dir + "/photos/" + name);
    ++copied;
  }
  test::write(dir + "/photos/notes.txt", "not an image");
  const std::vector<std::string> images = vision::expandImageArguments({dir + "/photos"});
  CHECK(copied >= 10);
  CHECK(images.size() == copied);  // the photographs, sorted; notes.txt ignored
  CHECK(std::is_sorted(images.begin(), images.end()));
  sim::Board board;
  board.corners_x = 9, board.corners_y = 6, board.square_m = 0.025;
  const vision::IntrinsicsResult r = vision::calibrateIntrinsicsFromFiles(images, board);
  REQUIRE(r.ok);
  const vision::CameraFileNames names = vision::cameraFileNames(dir + "/intrinsics.yaml");
  test::write(names.camera_info, sim::formatCameraInfoYaml(r.camera, "left"));
  test::write(names.opencv, sim::formatOpenCvCameraYaml(r.camera));
  std::string scene = test::slurp(test::sourcePath("scenes/default_scene.yaml"));
  const auto a = scene.find("\ncamera:\n"), b = scene.find("\nboard:\n");
  REQUIRE(a != std::string::npos);
  REQUIRE(b != std::string::npos);
  for (const std::string& file : {names.camera_info, names.opencv}) {
    std::string t = scene;
    test::write(dir + "/scene.yaml", t.replace(a + 1, b - a, "camera: {file: " + std::filesystem::path(file).filename().string() + "}\n"));
    const sim::Camera c = sim::loadScene(dir + "/scene.yaml").camera;
    CHECK(c.width_px == 640);
    test::checkSameCamera(c, r.camera);
  }
}
