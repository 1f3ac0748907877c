// Camera files as ROS and OpenCV write them (sim/camera_io.hpp): round trips, a scene's camera taken
// from each format, and the one-line errors for bad files.
#include <catch2/catch.hpp>
#include <cmath>

#include "orbcal/sim/camera_io.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/io.hpp"
#include "test_util.hpp"

using namespace orbcal::sim;
using orbcal::test::checkSameCamera;
using orbcal::test::inputError;
using orbcal::test::oddCamera;
using orbcal::test::slurp;
using orbcal::test::write;

namespace {

/// The default scene with its camera section replaced by `camera_section` (the lines from "camera:" up
/// to "board:").
std::string sceneWithCamera(const std::string& camera_section) {
  std::string t = slurp(orbcal::test::sourcePath("scenes/default_scene.yaml"));
  const auto a = t.find("\ncamera:\n"), b = t.find("\nboard:\n");
  REQUIRE(a != std::string::npos);
  REQUIRE(b != std::string::npos);
  return t.replace(a + 1, b - a, camera_section);
}

}  // namespace

TEST_CASE("camera_info and OpenCV FileStorage files round-trip to 1e-12", "[sim][camera_io]") {
  const Camera c = oddCamera();
  CameraFileFormat f{};
  checkSameCamera(parseCameraFile(formatCameraInfoYaml(c, "cam0"), "ci.yaml", &f), c);
  CHECK(f == CameraFileFormat::kRosCameraInfo);
  checkSameCamera(parseCameraFile(formatOpenCvCameraYaml(c), "cv.yml", &f), c);
  CHECK(f == CameraFileFormat::kOpenCvFileStorage);
}

TEST_CASE("a scene's camera from a camera_info or FileStorage file is the inline one", "[sim][camera_io]") {
  const std::string dir = orbcal::test::tempDir("camera-io-scene");
  const Scene inline_scene = loadScene(orbcal::test::sourcePath("scenes/default_scene.yaml"));
  write(dir + "/ci.yaml", formatCameraInfoYaml(inline_scene.camera, "cam"));
  std::filesystem::create_directories(dir + "/cams");
  write(dir + "/cams/cv.yml", formatOpenCvCameraYaml(inline_scene.camera));
  // Relative to the scene file's folder (block and flow style), and absolute.
  write(dir + "/a.yaml", sceneWithCamera("camera:\n  file: ci.yaml\n"));
  write(dir + "/b.yaml", sceneWithCamera("camera: {file: cams/cv.yml}\n"));
  write(dir + "/c.yaml", sceneWithCamera("camera: {file: \"" + dir + "/ci.yaml\"}\n"));
  for (const char* name : {"/a.yaml", "/b.yaml", "/c.yaml"}) {
    INFO(name);
    const Scene s = loadScene(dir + name);
    checkSameCamera(s.camera, inline_scene.camera);
    CHECK(!s.camera_file.empty());
    CHECK(std::filesystem::equivalent(s.camera_file, std::string(name) == "/b.yaml" ? dir + "/cams/cv.yml" : dir + "/ci.yaml"));
    CHECK(s.board.corners_x == inline_scene.board.corners_x);
  }
  CHECK(inline_scene.camera_file.empty());
  // A camera file that is missing: the scene and the key, then the file.
  write(dir + "/d.yaml", sceneWithCamera("camera: {file: nothere.yaml}\n"));
  CHECK_THAT(inputError([&] { loadScene(dir + "/d.yaml"); }),
             Catch::StartsWith(dir + "/d.yaml: camera.file: " + dir + "/nothere.yaml: cannot read"));
  write(dir + "/e.yaml", sceneWithCamera("camera: {file: ci.yaml, fx_px: 3}\n"));
  CHECK_THAT(inputError([&] { loadScene(dir + "/e.yaml"); }), Catch::StartsWith(dir + "/e.yaml: camera.fx_px: unknown key"));
}

TEST_CASE("bad camera files: one line naming the file and the key", "[sim][camera_io][badinput]") {
  const Camera c = oddCamera();
  const std::string ros = formatCameraInfoYaml(c, "cam0");
  const std::string cv = formatOpenCvCameraYaml(c);
  const auto error = [](const std::string& text) {
    return inputError([&] { parseCameraFile(text, "cam.yaml"); });
  };
  const auto replaced = [](std::string text, const std::string& from, const std::string& to) {
    const auto at = text.find(from);
    REQUIRE(at != std::string::npos);
    return text.replace(at, from.size(), to);
  };
  const std::string K0 = "data: [" + exactNumber(c.fx_px);
  // Unknown distortion model.
  CHECK(error(replaced(ros, "distortion_model: plumb_bob", "distortion_model: equidistant")) ==
        "cam.yaml: distortion_model: unknown distortion model 'equidistant' (expected plumb_bob or rational_polynomial)");
  // Wrong matrix sizes.
  CHECK(error(replaced(ros, "rows: 3\n  cols: 3\n  data: [" + exactNumber(c.fx_px), "rows: 3\n  cols: 4\n  data: [" + exactNumber(c.fx_px))) ==
        "cam.yaml: camera_matrix: expected a 3x3 matrix, got 3x4");
  CHECK(error(replaced(ros, "rows: 1\n  cols: 5", "rows: 1\n  cols: 4")) ==
        "cam.yaml: distortion_coefficients: expected a 1x5 or 5x1 matrix, got 1x4");
  CHECK(error(replaced(cv, "rows: 3\n   cols: 3\n   dt: d\n   data: [" + exactNumber(c.fx_px) + ", ",
                       "rows: 3\n   cols: 3\n   dt: d\n   data: [")) ==
        "cam.yaml: camera_matrix.data: expected 9 numbers (rows x cols)");
  CHECK(error(replaced(ros, "cols: 4\n  data: [", "cols: 3\n  data: [")) ==
        "cam.yaml: projection_matrix: expected a 3x4 matrix, got 3x3");
  // Non-finite values.
  CHECK_THAT(error(replaced(ros, K0, "data: [.nan")), Catch::StartsWith("cam.yaml: camera_matrix.data[0]: expected a finite number"));
  CHECK_THAT(error(replaced(cv, K0, "data: [.inf")), Catch::StartsWith("cam.yaml: camera_matrix.data[0]: expected a finite number"));
  // Absurd values, at their own key.
  CHECK(error(replaced(ros, K0, "data: [0")) == "cam.yaml: camera_matrix.data[0]: '0' is outside 1 px to 1e6 px (a focal length in pixels)");
  CHECK(error(replaced(cv, K0, "data: [1e-9")) == "cam.yaml: camera_matrix.data[0]: '1e-09' is outside 1 px to 1e6 px (a focal length in pixels)");
  CHECK_THAT(error(replaced(ros, "data: [" + exactNumber(c.distortion[0]), "data: [50")),
             Catch::StartsWith("cam.yaml: distortion_coefficients.data: coefficient 1 of k1 k2 p1 p2 k3, '50', is outside -10 to 10"));
  CHECK_THAT(error(replaced(cv, "image_width: 1288", "image_width: 100")),
             Catch::StartsWith("cam.yaml: camera_matrix.data[2]: '643.3' is outside the image"));
  CHECK(error(replaced(ros, "image_height: 964", "image_height: 0")) == "cam.yaml: image_height: must be within 16..16384");
  // Skew, and rational terms orbcal's model does not have.
  CHECK_THAT(error(replaced(ros, K0 + ", 0,", K0 + ", 0.5,")),
             Catch::StartsWith("cam.yaml: camera_matrix.data[1]: expected 0 (orbcal's camera has no skew)"));
  const std::string rational = replaced(replaced(ros, "distortion_model: plumb_bob", "distortion_model: rational_polynomial"),
                                        "rows: 1\n  cols: 5\n  data: [", "rows: 1\n  cols: 8\n  data: [0, 0, 0, ");
  CHECK_THAT(error(rational), Catch::StartsWith("cam.yaml: distortion_coefficients.data[5]: orbcal's camera is OpenCV's 5-coefficient"));
  // rational_polynomial with k4 = k5 = k6 = 0 reads.
  const std::string rational_ok = replaced(replaced(ros, "distortion_model: plumb_bob", "distortion_model: rational_polynomial"),
                                           "rows: 1\n  cols: 5", "rows: 1\n  cols: 8");
  checkSameCamera(parseCameraFile(replaced(rational_ok, "]\nrectification", ", 0, 0, 0]\nrectification"), "cam.yaml"), c);
  // Missing keys and other files.
  CHECK(error(replaced(cv, "image_width: 1288\n", "")) == "cam.yaml: image_width: missing");
  CHECK(error(replaced(ros, "camera_name: cam0\n", "camera_name: cam0\nfocal: 3\n")) ==
        "cam.yaml: focal: unknown key (expected one of: image_width, image_height, camera_name, camera_matrix, "
        "distortion_model, distortion_coefficients, rectification_matrix, projection_matrix, binning_x, binning_y, roi)");
  CHECK_THAT(error("name: a scene\nfx_px: 3\n"), Catch::StartsWith("cam.yaml: (top level): not a camera file"));
  CHECK_THAT(error("- 1\n- 2\n"), Catch::StartsWith("cam.yaml: (top level): expected a camera file"));
}

TEST_CASE("ChArUco board keys: read, and bad values named at their key", "[sim][io][charuco][badinput]") {
  const std::string dir = orbcal::test::tempDir("scene-charuco");
  const std::string f = dir + "/scene.yaml";
  const std::string good = slurp(orbcal::test::sourcePath("scenes/default_scene.yaml"));
  const auto withBoard = [&](const std::string& extra) {
    std::string t = good;
    const std::string from = "board:\n";
    const auto at = t.find(from);
    REQUIRE(at != std::string::npos);
    write(f, t.replace(at, from.size(), from + extra));
  };
  withBoard("  type: charuco\n  dictionary: DICT_5X5_100\n  marker_m: 0.06\n");
  const Scene s = loadScene(f);
  CHECK(s.board.type == BoardType::kCharuco);
  CHECK(s.board.dictionary == "DICT_5X5_100");
  CHECK(s.board.marker_m == 0.06);
  CHECK(charucoMarkers(s.board).size() == 35);  // the white half of 10 x 7 squares
  withBoard("  type: charuco\n  dictionary: DICT_5X5_99\n  marker_m: 0.06\n");
  CHECK_THAT(inputError([&] { loadScene(f); }), Catch::StartsWith(f + ": board.dictionary: unknown ArUco dictionary 'DICT_5X5_99'"));
  withBoard("  type: charuco\n  dictionary: DICT_5X5_100\n  marker_m: 0.08\n");
  CHECK(inputError([&] { loadScene(f); }) == f + ": board.marker_m: must be positive and smaller than square_m");
  withBoard("  type: charuco\n  dictionary: DICT_5X5_100\n");
  CHECK(inputError([&] { loadScene(f); }) == f + ": board.marker_m: missing");
  withBoard("  type: charuko\n");
  CHECK(inputError([&] { loadScene(f); }) == f + ": board.type: expected chessboard, charuco or circles, got 'charuko'");
  withBoard("  marker_m: 0.06\n");
  CHECK(inputError([&] { loadScene(f); }) == f + ": board.marker_m: only for a ChArUco board (type: charuco)");
  // 9 x 10 inner corners: 10 x 11 squares, 55 of them white, one marker each: more than DICT_4X4_50 has.
  std::string big = good;
  big.replace(big.find("inner_corners_y: 6"), 18, "inner_corners_y: 10");
  big.replace(big.find("board:\n"), 7, "board:\n  type: charuco\n  dictionary: DICT_4X4_50\n  marker_m: 0.06\n");
  write(f, big);
  CHECK(inputError([&] { loadScene(f); }) == f + ": board.dictionary: DICT_4X4_50 has 50 markers, the board needs 55");
}

TEST_CASE("circle-grid board keys of a scene: read, and bad values named at their key", "[sim][io][circles][badinput]") {
  const std::string dir = orbcal::test::tempDir("scene-circles");
  const std::string f = dir + "/scene.yaml";
  std::string good = slurp(orbcal::test::sourcePath("scenes/default_scene.yaml"));
  const auto from = good.find("board:\n"), to = good.find("\n", good.find("margin_m:", from));
  REQUIRE(to != std::string::npos);
  const auto withBoard = [&](const std::string& board) {
    std::string t = good;
    write(f, t.replace(from, to - from, "board: " + board));
  };
  withBoard("{type: circles, grid: [4, 11], spacing_m: 0.04, diameter_m: 0.03, asymmetric: true}");
  const Scene s = loadScene(f);
  CHECK(s.board.type == BoardType::kCircles);
  CHECK(s.board.asymmetric);
  CHECK(s.board.numCorners() == 44);
  CHECK(s.board.margin_m == 0.04);  // one spacing by default
  CHECK(cornerInBoard(s.board, 43).isApprox(Eigen::Vector3d(0.24, 0.40, 0.0)));  // row 10, column 3: ((2 * 3 + 0) s, 10 s)
  withBoard("{type: circles, grid: [4, 11], spacing_m: 0.04, diameter_m: 0.06, asymmetric: true}");
  CHECK(inputError([&] { loadScene(f); }) == f + ": board.diameter_m: must be below 0.9 of the nearest circles' distance");
  withBoard("{type: circles, grid: [4, 11], square_m: 0.04, diameter_m: 0.03}");
  CHECK_THAT(inputError([&] { loadScene(f); }), Catch::StartsWith(f + ": board.square_m: not for a circle grid"));
  withBoard("{type: chessboard, inner_corners_x: 9, inner_corners_y: 6, square_m: 0.08, diameter_m: 0.03}");
  CHECK(inputError([&] { loadScene(f); }) == f + ": board.diameter_m: only for a circle grid (type: circles)");
}
