#include <catch2/catch.hpp>
#include <Eigen/Eigenvalues>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/vision/measurement.hpp"
#include "orbcal/vision/synthetic.hpp"
#include "test_util.hpp"
#include "vision_test_util.hpp"

using namespace orbcal;

namespace {
// Drawn images of the exact nominal arm: the measured flange pose is off only by the corner
// detection error (~0.1 px). One view at 1.5-2.5 m fixes the camera's orientation to a few 0.01 deg
// and hence its position in the board frame to ~1 mm (angle x distance; measured 0.6-1.6 mm, with
// covariance sigmas of 0.5-2.6 mm). 5 mm / 0.2 deg still flags real mistakes (a wrong transform in
// the chain is off by decimetres or degrees).
constexpr double kPoseErrorTolM = 5e-3;
constexpr double kPoseErrorTolRad = 0.2 * sim::kDegToRad;
// Drawn corners sit within ~0.1 px of the projection (supersampling and 8-bit quantisation), so the
// pose's reprojection RMS is ~0.05-0.1 px; 0.3 px is 3x that and still far below
// MeasureSettings::max_rms_px (1 px), which is what a real lens is allowed.
constexpr double kMaxDrawnRmsPx = 0.3;

void copyFile(const std::string& from, const std::string& to) {
  sim::writeFileAtomic(to, sim::readTextSource(from));
}

/// A dataset of `good` drawn views followed by the bad inputs of the issue; returns the folder.
std::string makeDataset(const std::string& name, int good) {
  const std::string dir = test::tempDir(name);
  sim::makeDirectories(dir + "/images");
  copyFile(test::sourcePath("scenes/ssrms.yaml"), dir + "/robot.yaml");
  copyFile(test::sourcePath("scenes/default_scene.yaml"), dir + "/scene.yaml");
  const sim::Arm arm = sim::loadArm(dir + "/robot.yaml");
  const sim::Scene scene = sim::loadScene(dir + "/scene.yaml");
  sim::GeneratorSettings gen;
  gen.count = good + 5;
  gen.seed = 17;
  const auto configs = sim::generateConfigurations(arm, scene, gen);
  sim::Dataset ds;
  ds.folder = dir;
  const auto cameraT = [&](const Eigen::VectorXd& q) {
    return (sim::forwardKinematics(arm, q) * scene.flange_T_camera).inverse(Eigen::Isometry) * scene.base_T_board;
  };
  const auto add = [&](const std::string& image, const Eigen::VectorXd& q) {
    sim::DatasetSample s;
    s.index = static_cast<int>(ds.samples.size());
    s.image = image;
    s.q_rad = q;
    s.camera_T_board_true = cameraT(q);
    ds.samples.push_back(s);
    return dir + "/" + image;
  };
  for (int i = 0; i < good; ++i) {
    const std::string path = add("images/good" + std::to_string(i) + ".png", configs[i]);
    cv::imwrite(path, vision::drawSyntheticBoard(scene.camera, scene.board, cameraT(configs[i])));
  }
  {  // truncated PNG: the first half of a good one
    const std::string path = add("images/truncated.png", configs[good]);
    std::vector<uchar> bytes;
    cv::imencode(".png", vision::drawSyntheticBoard(scene.camera, scene.board, cameraT(configs[good])), bytes);
    std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), bytes.size() / 2);
  }
  cv::imwrite(add("images/black.png", configs[good + 1]),
              cv::Mat::zeros(scene.camera.height_px, scene.camera.width_px, CV_8UC1));
  {
    sim::Board other = scene.board;
    other.corners_x = 7;
    other.corners_y = 4;
    cv::imwrite(add("images/wrong_board.png", configs[good + 2]),
                vision::drawSyntheticBoard(scene.camera, other, cameraT(configs[good + 2])));
  }
  add("images/missing.png", configs[good + 3]);
  cv::imwrite(add("images/small.png", configs[good + 4]), cv::Mat(480, 640, CV_8UC1, cv::Scalar(128)));
  ds.manifest.num_samples = static_cast<int>(ds.samples.size());
  sim::writeDatasetTables(ds, arm.numJoints());
  return dir;
}
}  // namespace

TEST_CASE("measuring a dataset: every image gets a status, bad ones counted", "[vision][measure][bad-input]") {
  constexpr int kGood = 6;
  const std::string dir = makeDataset("vision-measure", kGood);
  const sim::Dataset ds = sim::loadDataset(dir);
  int progress_calls = 0;
  const auto rows = vision::measureDataset(ds, {}, [&](int, int) { ++progress_calls; });
  REQUIRE(rows.size() == ds.samples.size());
  CHECK(progress_calls == static_cast<int>(rows.size()));
  for (int i = 0; i < kGood; ++i) {
    const vision::Measurement& m = rows[i];
    CAPTURE(m.image, m.reason, m.detail);
    REQUIRE(m.found());
    CHECK(m.num_corners == 54);
    CHECK(m.rms_px < kMaxDrawnRmsPx);
    CHECK(m.has_pose_error);
    CHECK(m.pose_error.head<3>().norm() < kPoseErrorTolM);
    CHECK(m.pose_error.tail<3>().norm() < kPoseErrorTolRad);
    const sim::Vector6d e_true = sim::poseMinus(
        vision::measuredFlangePose(ds.scene, *ds.samples[i].camera_T_board_true), m.base_T_flange);
    CHECK(e_true.head<3>().norm() < kPoseErrorTolM);
    // a positive definite covariance of sub-millimetre size
    Eigen::SelfAdjointEigenSolver<sim::Matrix6d> eig(m.covariance);
    CHECK(eig.eigenvalues().minCoeff() > 0.0);
    CHECK(std::sqrt(m.covariance.topLeftCorner<3, 3>().trace()) < kPoseErrorTolM);
  }
  const auto at = [&](const std::string& image) -> const vision::Measurement& {
    for (const auto& m : rows) {
      if (m.image == image) return m;
    }
    FAIL("no row for " << image);
    return rows.front();
  };
  CHECK(at("images/truncated.png").status == vision::ImageStatus::kUnreadable);
  CHECK(at("images/truncated.png").reason == "cannot decode");
  CHECK(at("images/black.png").status == vision::ImageStatus::kNotFound);
  CHECK(at("images/black.png").reason == "blank image");
  CHECK(at("images/wrong_board.png").status == vision::ImageStatus::kNotFound);
  CHECK(at("images/wrong_board.png").reason == "no board found");
  CHECK(at("images/missing.png").status == vision::ImageStatus::kUnreadable);
  CHECK(at("images/missing.png").reason == "file missing");
  CHECK(at("images/small.png").status == vision::ImageStatus::kRejected);
  CHECK(at("images/small.png").reason == "image size differs from the camera's");

  const vision::MeasurementSummary s = vision::summarize(rows);
  CHECK(s.total == kGood + 5);
  CHECK(s.found == kGood);
  CHECK(s.not_found == 2);
  CHECK(s.rejected == 1);
  CHECK(s.unreadable == 2);
  CHECK(s.reasons.at("unreadable: file missing") == 1);
  CHECK(s.reasons.at("unreadable: cannot decode") == 1);
  CHECK(s.reasons.at("not_found: blank image") == 1);
  CHECK(s.reasons.at("not_found: no board found") == 1);
  const std::string text = vision::formatSummary(s);
  CHECK(text.find("6 used, 2 not found, 1 rejected, 2 unreadable") != std::string::npos);

  SECTION("the table reads back bit for bit") {
    const std::string path = dir + "/measurements.csv";
    sim::writeFileAtomic(path, vision::formatMeasurementsCsv(rows));
    const auto back = vision::loadMeasurements(path);
    REQUIRE(back.size() == rows.size());
    for (std::size_t i = 0; i < rows.size(); ++i) {
      CAPTURE(i);
      CHECK(back[i].index == rows[i].index);
      CHECK(back[i].image == rows[i].image);
      CHECK(back[i].status == rows[i].status);
      CHECK(back[i].reason == rows[i].reason);
      CHECK(back[i].detail == vision::measurementCell(rows[i].detail));
      CHECK(back[i].num_corners == rows[i].num_corners);
      CHECK(back[i].has_pose_error == rows[i].has_pose_error);
      CHECK(back[i].rms_px == rows[i].rms_px);
      CHECK(back[i].covariance == rows[i].covariance);
      CHECK(back[i].pose_error == rows[i].pose_error);
      // poses go through a rotation vector: equal to round-off
      CHECK(sim::poseMinus(back[i].base_T_flange, rows[i].base_T_flange).norm() < 1e-14);
      CHECK(sim::poseMinus(back[i].camera_T_board, rows[i].camera_T_board).norm() < 1e-14);
    }
  }
}

TEST_CASE("measurement table errors name the file and the line", "[vision][measure]") {
  const std::string header = vision::formatMeasurementsCsv({});
  CHECK_THROWS_WITH(vision::parseMeasurementsCsv("index,image\n", "m.csv"), Catch::Contains("m.csv: header: missing column"));
  std::string bad = header + "0,a.png,maybe,,,,";
  bad += std::string(39, ',') + "\n";
  CHECK_THROWS_WITH(vision::parseMeasurementsCsv(bad, "m.csv"),
                    Catch::Equals("m.csv: line 2: status: expected found, not_found, rejected or unreadable, got 'maybe'"));
  std::string empty_found = header + "0,a.png,found,,,54,0.1" + std::string(39, ',') + "\n";
  CHECK_THROWS_WITH(vision::parseMeasurementsCsv(empty_found, "m.csv"),
                    Catch::Equals("m.csv: line 2: status 'found' but the cam_board cells are empty"));
  CHECK_THROWS_AS(vision::loadMeasurements("/nonexistent/measurements.csv"), sim::InputError);

  // index and num_corners: non-negative integers within int range, each index once
  const auto row = [](const std::string& index, const std::string& num_corners) {
    return index + ",a.png,not_found,no board found,," + num_corners + "," + std::string(39, ',') + "\n";
  };
  const std::string int_error = ": expected a non-negative integer (at most 2147483647), got ";
  CHECK_THROWS_WITH(vision::parseMeasurementsCsv(header + row("0", "") + row("1.5", ""), "m.csv"),
                    Catch::Equals("m.csv: line 3: index" + int_error + "'1.5'"));
  CHECK_THROWS_WITH(vision::parseMeasurementsCsv(header + row("-1", ""), "m.csv"),
                    Catch::Equals("m.csv: line 2: index" + int_error + "'-1'"));
  CHECK_THROWS_WITH(vision::parseMeasurementsCsv(header + row("3000000000", ""), "m.csv"),
                    Catch::Equals("m.csv: line 2: index" + int_error + "'3000000000'"));
  CHECK_THROWS_WITH(vision::parseMeasurementsCsv(header + row("0", "54.5"), "m.csv"),
                    Catch::Equals("m.csv: line 2: num_corners" + int_error + "'54.5'"));
  CHECK_THROWS_WITH(vision::parseMeasurementsCsv(header + row("0", "1e10"), "m.csv"),
                    Catch::Equals("m.csv: line 2: num_corners" + int_error + "'1e10'"));
  CHECK_THROWS_WITH(vision::parseMeasurementsCsv(header + row("0", "x"), "m.csv"),
                    Catch::Equals("m.csv: line 2: num_corners: expected a finite number, got 'x'"));
  CHECK_THROWS_WITH(vision::parseMeasurementsCsv(header + row("4", "") + row("5", "") + row("4", ""), "m.csv"),
                    Catch::Equals("m.csv: line 4: index: 4 repeats the row of m.csv: line 2"));
  // the largest int is accepted
  CHECK(vision::parseMeasurementsCsv(header + row("2147483647", "54"), "m.csv").at(0).index == 2147483647);
}

TEST_CASE("a found row without a joint reading has empty err cells, not zeros", "[vision][measure]") {
  vision::Measurement m;
  m.status = vision::ImageStatus::kFound;
  m.num_corners = 54;
  m.rms_px = 0.05;
  m.camera_T_board.translation() << 0.1, -0.2, 2.0;
  m.covariance = sim::Matrix6d::Identity() * 1e-8;
  REQUIRE_FALSE(m.has_pose_error);
  const std::string text = vision::formatMeasurementsCsv({m});
  const std::string last_line = text.substr(text.rfind('\n', text.size() - 2) + 1);
  CHECK(last_line.substr(last_line.size() - 7) == ",,,,,,\n");  // the 6 err_* cells, empty
  const auto back = vision::parseMeasurementsCsv(text, "t.csv");
  REQUIRE(back.size() == 1);
  CHECK(back[0].found());
  CHECK_FALSE(back[0].has_pose_error);
  CHECK(back[0].pose_error == sim::Vector6d::Zero());
  CHECK(back[0].covariance == m.covariance);

  m.has_pose_error = true;
  m.pose_error << 1e-3, 0.0, 0.0, 0.0, 0.0, 2e-4;
  const auto with = vision::parseMeasurementsCsv(vision::formatMeasurementsCsv({m}), "t.csv");
  CHECK(with.at(0).has_pose_error);
  CHECK(with.at(0).pose_error == m.pose_error);
}

TEST_CASE("measureImage never reports found without a known orientation", "[vision][measure]") {
  // A 9 x 7-square board (8 x 6 inner corners) looks the same after a half turn. With the detector's
  // orientation made optional, detectCorners keeps it (found, orientation unknown); a measurement
  // must not: its pose could be off by a half turn.
  sim::Scene scene = test::defaultScene();
  scene.board.corners_x = 8;
  REQUIRE(vision::isHalfTurnSymmetric(scene.board));
  const sim::Arm arm = sim::loadArm(sim::kDefaultRobot);
  const cv::Mat img =
      vision::drawSyntheticBoard(scene.camera, scene.board, test::lookAtBoard(scene.board, 1.8, 0.1, 0.1, 0.0));
  for (const bool required : {true, false}) {
    CAPTURE(required);
    vision::MeasureSettings st;
    st.detector.require_orientation = required;
    const auto det = vision::detectCorners(img, scene.board, st.detector);
    CHECK(det.found() == !required);  // the image itself is fine: only the orientation is unknown
    CHECK_FALSE(det.orientation_known);
    const vision::Measurement m = vision::measureImage(img, scene, arm, Eigen::VectorXd(), st);
    CHECK(m.status == vision::ImageStatus::kRejected);
    CHECK(m.reason == "orientation undecidable");
    CHECK_FALSE(m.detail.empty());
  }
  // control: the even-by-odd default board in the same view is measured
  const sim::Scene& good = test::defaultScene();
  const cv::Mat good_img =
      vision::drawSyntheticBoard(good.camera, good.board, test::lookAtBoard(good.board, 1.8, 0.1, 0.1, 0.0));
  vision::MeasureSettings st;
  st.detector.require_orientation = false;
  CHECK(vision::measureImage(good_img, good, arm, Eigen::VectorXd(), st).found());
}

TEST_CASE("a reason with commas does not break the table", "[vision][measure]") {
  vision::Measurement m;
  m.status = vision::ImageStatus::kRejected;
  m.reason = "x";
  m.detail = "a, b,\nc";
  const auto back = vision::parseMeasurementsCsv(vision::formatMeasurementsCsv({m}), "t.csv");
  REQUIRE(back.size() == 1);
  CHECK(back[0].detail == "a; b; c");
}
