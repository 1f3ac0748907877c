// A measurement description of images (sim/image_views.hpp): flange poses from pose files (a 4x4 text
// matrix in mm, a YAML position + quaternion in m) or joint readings of a robot, the board's frame
// conventions, and the one-line errors of bad input.
#include "orbcal/sim/image_views.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "test_util.hpp"

using namespace orbcal;

namespace {

void write(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

const char* kHead =
    "format: orbcal-measurements-1\n"
    "files: [views.csv]\n"
    "images: {column: image, ignore: coloured, rectangles: [[0, 0, 100, 20]]}\n"
    "camera: {width_px: 640, height_px: 480, fx_px: 500, fy_px: 500, cx_px: 320, cy_px: 240}\n"
    "board: {charuco: {squares: [7, 5], square_mm: 30, marker_mm: 22, dictionary: DICT_4X4_50}, frame: legacy}\n"
    "setup: eye_in_hand\n";

}  // namespace

TEST_CASE("image descriptions: pose files per row, as a 4x4 text matrix in mm and a YAML position + quaternion", "[image-views]") {
  const std::string dir = test::tempDir("image-views-files");
  write(dir + "/a.txt", "1 0 0 447.0\n0 -1 0 0\n0 0 -1 395.5\n0 0 0 1\n");
  write(dir + "/b.yaml", "x: 0.1\ny: 0.2\nz: 0.3\nqx: 0\nqy: 0\nqz: 0.7071067811865476\nqw: 0.7071067811865476\n");
  write(dir + "/views.csv", "image,pose\nimg_a.png,a.txt\nimg_b.png,b.yaml\n");
  write(dir + "/d.yaml", std::string(kHead) + "flange_pose: {file_column: pose, length_unit: mm}\n");
  const sim::ImageViews v = sim::loadImageViews(dir + "/d.yaml");
  REQUIRE(v.views.size() == 2);
  CHECK(v.views[0].image == (std::filesystem::path(dir) / "img_a.png").lexically_normal().string());
  CHECK(v.views[0].base_T_flange.translation().isApprox(Eigen::Vector3d(0.447, 0.0, 0.3955)));
  CHECK(v.views[0].base_T_flange.linear().isApprox(Eigen::Vector3d(1, -1, -1).asDiagonal().toDenseMatrix()));
  // length_unit applies to the YAML file's numbers too: mm here.
  CHECK(v.views[1].base_T_flange.translation().isApprox(Eigen::Vector3d(1e-4, 2e-4, 3e-4)));
  CHECK(std::abs(sim::rotationAngle(v.views[1].base_T_flange.linear()) - sim::kPi / 2) < 1e-12);
  CHECK(v.mask.ignore_coloured);
  REQUIRE(v.mask.rectangles.size() == 1);
  CHECK(v.mask.rectangles[0][2] == 100);
  CHECK(v.board.corners_x == 6);
  CHECK(v.board.corners_y == 4);
  CHECK(v.setup == sim::HandEyeSetup::kEyeInHand);
  // The legacy frame: inner corner 0 (orbcal's origin) sits at (s, H - s, 0) with H = 5 squares; z flips.
  const Eigen::Isometry3d printed_T_board = sim::printedFromBoard(v.board, v.board_frame);
  CHECK((printed_T_board * Eigen::Vector3d::Zero()).isApprox(Eigen::Vector3d(0.03, 0.12, 0.0)));
  CHECK((printed_T_board.linear() * Eigen::Vector3d::UnitZ()).isApprox(-Eigen::Vector3d::UnitZ()));
}

TEST_CASE("image descriptions: joint readings give the nominal arm's flange pose", "[image-views]") {
  const std::string dir = test::tempDir("image-views-joints");
  write(dir + "/views.csv", "image,q1,q2,q3,q4,q5,q6,q7\nimg.png,10,20,30,40,50,60,70\n");
  write(dir + "/d.yaml", std::string(kHead) + "robot: " + test::sourcePath("scenes/iiwa7.yaml") +
                             "\njoints: {columns: [q1, q2, q3, q4, q5, q6, q7], unit: deg}\n");
  const sim::ImageViews v = sim::loadImageViews(dir + "/d.yaml");
  REQUIRE(v.views.size() == 1);
  REQUIRE(v.arm);
  Eigen::VectorXd q(7);
  q << 10, 20, 30, 40, 50, 60, 70;
  q *= sim::kDegToRad;
  CHECK(v.views[0].base_T_flange.isApprox(sim::forwardKinematics(*v.arm, q)));
}

TEST_CASE("image descriptions: bad input is one line naming the file and the key", "[image-views]") {
  const std::string dir = test::tempDir("image-views-bad");
  write(dir + "/views.csv", "image,pose\nimg.png,p.txt\n");
  const std::string d = dir + "/d.yaml";
  write(d, std::string(kHead));
  CHECK_THROWS_WITH(sim::loadImageViews(d), Catch::Contains("d.yaml: flange_pose: give either flange_pose"));
  write(d, std::string(kHead) + "flange_pose: {file_column: pose, length_unit: inch}\n");
  CHECK_THROWS_WITH(sim::loadImageViews(d), Catch::Contains("length_unit"));
  // A rotation off orthonormal by 1e-2: refused with the CSV's line and the pose file.
  write(dir + "/p.txt", "0.99 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  write(d, std::string(kHead) + "flange_pose: {file_column: pose, length_unit: m}\n");
  CHECK_THROWS_WITH(sim::loadImageViews(d), Catch::Contains("views.csv: line 2") && Catch::Contains("not orthonormal"));
  // Four printed decimals (0.7071): re-orthonormalised with a warning.
  write(dir + "/p.txt", "0.7071 -0.7071 0 0\n0.7071 0.7071 0 0\n0 0 1 0\n0 0 0 1\n");
  const sim::ImageViews v = sim::loadImageViews(d);
  REQUIRE(v.warnings.size() == 1);
  CHECK(v.warnings[0].find("re-orthonormalised") != std::string::npos);
  const Eigen::Matrix3d R = v.views[0].base_T_flange.linear();
  CHECK((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-12);
  // A description of images is not tracker data: loadMeasuredData names the key.
  CHECK(sim::describesImages(d));
  write(d, std::string(kHead) + "flange_pose: {file_column: pose, length_unit: m}\ncircles: 1\n");
  CHECK_THROWS_WITH(sim::loadImageViews(d), Catch::Contains("d.yaml") && Catch::Contains("circles"));
}
