// ChArUco boards end to end: rendered (render/), detected with corner identities (vision/charuco.hpp),
// and a partly visible board still gives a pose (the bar: 30% of the board outside the image,
// pose within 0.5 mm of the truth).
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "orbcal/render/renderer.hpp"
#include "orbcal/render/settings.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/vision/charuco.hpp"
#include "orbcal/vision/corners.hpp"
#include "orbcal/vision/intrinsics.hpp"
#include "orbcal/vision/measurement.hpp"
#include "orbcal/vision/pose.hpp"

using namespace orbcal;

namespace {
constexpr double kPoseTolM = 0.5e-3;  // the bar for a partly visible board

sim::Scene charucoScene() {
  sim::Scene scene = sim::loadScene(sim::kDefaultScene);
  scene.board.type = sim::BoardType::kCharuco;
  scene.board.dictionary = "DICT_5X5_100";
  scene.board.marker_m = 0.06;  // 3/4 of the 0.08 m square
  return scene;
}

/// camera_T_board for a camera 1.8 m from the board, tilted `tilt_deg` toward azimuth `azimuth_deg`
/// about z_board (90: toward +y), looking at the board centre shifted by `shift_m` along board x (so
/// the board slides out of the image on one side).
Eigen::Isometry3d view(const sim::Board& board, double shift_m, double tilt_deg = 20.0, double azimuth_deg = 90.0) {
  const double t = tilt_deg * sim::kDegToRad, a = azimuth_deg * sim::kDegToRad;
  const Eigen::Vector3d target = sim::boardCentre(board) + Eigen::Vector3d(shift_m, 0.0, 0.0);
  const Eigen::Vector3d z(std::sin(t) * std::cos(a), std::sin(t) * std::sin(a), std::cos(t));  // optical axis
  const Eigen::Vector3d x = (Eigen::Vector3d::UnitX() - z * z.x()).normalized();
  Eigen::Isometry3d board_T_camera = Eigen::Isometry3d::Identity();
  board_T_camera.linear() << x, z.cross(x), z;
  board_T_camera.translation() = target - 1.8 * z;
  return board_T_camera.inverse();
}

/// Fraction of the inner corners that project outside the image.
double fractionOutside(const sim::Scene& scene, const Eigen::Isometry3d& camera_T_board) {
  int outside = 0;
  for (const Eigen::Vector3d& P : sim::boardCorners(scene.board)) {
    const Eigen::Vector2d uv = sim::project(scene.camera, camera_T_board * P);
    outside += (uv.x() < -0.5 || uv.y() < -0.5 || uv.x() > scene.camera.width_px - 0.5 || uv.y() > scene.camera.height_px - 0.5);
  }
  return static_cast<double>(outside) / scene.board.numCorners();
}

/// Largest distance (m) between where the estimate and the truth put any point of the squared area.
double maxBoardError(const sim::Board& board, const Eigen::Isometry3d& est, const Eigen::Isometry3d& truth) {
  double worst = 0.0;
  for (const Eigen::Vector3d& P : sim::squaresOutline(board)) worst = std::max(worst, (est * P - truth * P).norm());
  return worst;
}
}  // namespace

TEST_CASE("ChArUco markers: ids and squares as OpenCV's CharucoBoard numbers them", "[e2e][charuco]") {
  const sim::Scene scene = charucoScene();
  const std::vector<sim::CharucoMarker> markers = sim::charucoMarkers(scene.board);
  // 10 x 7 squares, half of them white (35): one marker each, in white squares only.
  REQUIRE(markers.size() == 35);
  for (const sim::CharucoMarker& m : markers) CHECK(!sim::isBlackSquare(m.i, m.j));
  CHECK(markers.front().i == 1);  // square (0, 0) is black: the first marker is in (1, 0)
  CHECK(markers.front().j == 0);
  CHECK(markers.front().top_left.isApprox(Eigen::Vector3d(0.01, -0.07, 0.0)));  // inset (0.08 - 0.06) / 2
}

TEST_CASE("a rendered ChArUco board is detected with every corner's identity", "[e2e][charuco]") {
  const sim::Scene scene = charucoScene();
  const render::RenderSettings settings = render::loadRenderSettings(sim::kDefaultScene);
  render::BoardRenderer renderer(scene, settings);
  const Eigen::Isometry3d T = view(scene.board, 0.0);
  REQUIRE(fractionOutside(scene, T) == 0.0);
  const cv::Mat image = renderer.renderClean(T);
  const vision::CharucoDetection d = vision::detectCharuco(image, scene.board, &scene.camera);
  REQUIRE(d.found());
  CHECK(d.markers == 35);
  REQUIRE(static_cast<int>(d.ids.size()) == scene.board.numCorners());
  // Each corner where its identity says: against the projection of that corner (px).
  double worst_px = 0.0;
  for (std::size_t n = 0; n < d.ids.size(); ++n) {
    const Eigen::Vector2d truth = sim::project(scene.camera, T * sim::cornerInBoard(scene.board, d.ids[n]));
    worst_px = std::max(worst_px, (d.corners_px[n] - truth).norm());
  }
  CHECK(worst_px < 0.3);
  // The chessboard detector reads the same squares in the same order.
  const vision::CornerDetection chess = vision::detectCorners(image, scene.board);
  if (chess.found()) {
    for (std::size_t n = 0; n < d.ids.size(); ++n) CHECK((chess.corners_px[d.ids[n]] - d.corners_px[n]).norm() < 0.3);
  }
}

TEST_CASE("a ChArUco view with 30% of the board outside the image gives a pose within 0.5 mm", "[e2e][charuco]") {
  const sim::Scene scene = charucoScene();
  const render::RenderSettings settings = render::loadRenderSettings(sim::kDefaultScene);
  render::BoardRenderer renderer(scene, settings);
  // Slide the board until at least 30% of its corners fall outside the image.
  double shift = 0.0;
  while (fractionOutside(scene, view(scene.board, shift)) < 0.3) shift += 0.01;
  const Eigen::Isometry3d T = view(scene.board, shift);
  INFO("shift " << shift << " m, corners outside " << fractionOutside(scene, T));
  REQUIRE(fractionOutside(scene, T) >= 0.3);
  REQUIRE(fractionOutside(scene, T) < 0.5);
  const cv::Mat image = renderer.render(T, 7, 0);  // with the scene's degradations (noise, blur)
  // The chessboard detector needs the whole board: this view is lost to it.
  CHECK_FALSE(vision::detectCorners(image, scene.board).found());
  const vision::CharucoDetection d = vision::detectCharuco(image, scene.board, &scene.camera);
  REQUIRE(d.found());
  CHECK(static_cast<int>(d.ids.size()) <= scene.board.numCorners() * 0.7 + 1e-9);
  const vision::BoardPose pose = vision::estimateBoardPose(scene.camera, scene.board, d.corners_px, d.ids);
  REQUIRE(pose.ok);
  const double error_m = maxBoardError(scene.board, pose.camera_T_board, T);
  INFO("corners " << d.ids.size() << ", RMS " << pose.rms_px << " px, largest board point error " << error_m * 1e3
                   << " mm, origin error " << (pose.camera_T_board.translation() - T.translation()).norm() * 1e3 << " mm");
  CHECK(error_m < kPoseTolM);
  CHECK((pose.camera_T_board.translation() - T.translation()).norm() < kPoseTolM);
  // The covariance is a covariance (the 31 corners on several rows and columns constrain all 6 axes).
  CHECK(pose.covariance_camera.llt().info() == Eigen::Success);
}

TEST_CASE("measure: a ChArUco scene file's partly visible view is used, the chessboard's is lost", "[e2e][charuco]") {
  // The scene as a user writes it: the default scene with `type: charuco` in its board section.
  const std::string dir = std::filesystem::temp_directory_path() / "orbcal-test-charuco-measure";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  std::string text = sim::readTextSource(sim::kDefaultScene);
  text.replace(text.find("board:\n"), 7, "board:\n  type: charuco\n  dictionary: DICT_5X5_100\n  marker_m: 0.06\n");
  std::ofstream(dir + "/scene.yaml") << text;
  const sim::Scene scene = sim::loadScene(dir + "/scene.yaml");
  REQUIRE(scene.board.type == sim::BoardType::kCharuco);
  const sim::Scene chess = sim::loadScene(sim::kDefaultScene);
  const sim::Arm arm = sim::loadArm(sim::kDefaultRobot);
  double shift = 0.0;
  while (fractionOutside(scene, view(scene.board, shift)) < 0.2) shift += 0.01;
  const Eigen::Isometry3d T = view(scene.board, shift);
  const Eigen::VectorXd no_q;
  const cv::Mat charuco_image = render::BoardRenderer(scene, render::loadRenderSettings(dir + "/scene.yaml")).render(T, 3, 0);
  const vision::Measurement m = vision::measureImage(charuco_image, scene, arm, no_q);
  REQUIRE(m.found());
  CHECK(m.num_corners < scene.board.numCorners());
  CHECK(m.corner_ids.size() == m.corners_px.size());
  CHECK((m.camera_T_board.translation() - T.translation()).norm() < kPoseTolM);
  const cv::Mat chess_image = render::BoardRenderer(chess, render::loadRenderSettings(sim::kDefaultScene)).render(T, 3, 0);
  const vision::Measurement lost = vision::measureImage(chess_image, chess, arm, no_q);
  CHECK(lost.status == vision::ImageStatus::kNotFound);
}

TEST_CASE("intrinsics from rendered ChArUco views, some partly outside the image", "[e2e][charuco]") {
  const sim::Scene scene = charucoScene();
  render::BoardRenderer renderer(scene, render::loadRenderSettings(sim::kDefaultScene));
  const std::string dir = std::filesystem::temp_directory_path() / "orbcal-test-charuco-intrinsics";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  // Nine views tilted 30 deg in different directions; three of them shifted until 20% of the corners
  // are outside the image (lost to a chessboard detector).
  std::vector<std::string> files;
  int partial = 0;
  for (int k = 0; k < 9; ++k) {
    double shift = 0.0;
    while (k % 3 == 2 && fractionOutside(scene, view(scene.board, shift, 30.0, 40.0 * k)) < 0.2) shift += 0.01;
    const Eigen::Isometry3d T = view(scene.board, shift, 30.0, 40.0 * k);
    partial += fractionOutside(scene, T) > 0.0 ? 1 : 0;
    files.push_back(dir + "/view" + std::to_string(k) + ".png");
    cv::imwrite(files.back(), renderer.renderClean(T));
  }
  CHECK(partial == 3);
  const vision::IntrinsicsResult r = vision::calibrateIntrinsicsFromFiles(files, scene.board);
  REQUIRE(r.ok);
  CHECK(r.images_used == 9);
  const sim::Camera& c = r.camera, &truth = scene.camera;
  INFO("fx " << c.fx_px << " fy " << c.fy_px << " cx " << c.cx_px << " cy " << c.cy_px << " RMS " << r.rms_px);
  CHECK(r.rms_px < 0.1);
  CHECK(std::abs(c.fx_px - truth.fx_px) < 2.0);
  CHECK(std::abs(c.fy_px - truth.fy_px) < 2.0);
  CHECK(std::abs(c.cx_px - truth.cx_px) < 2.0);
  CHECK(std::abs(c.cy_px - truth.cy_px) < 2.0);
}
