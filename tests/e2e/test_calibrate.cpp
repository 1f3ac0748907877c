// `orbcal calibrate` on a rendered dataset, with and without the simulation's ground truth.
#include <algorithm>
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "figures.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/workflow/calibrate.hpp"
#include "orbcal/render/dataset_writer.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/io.hpp"
#include "test_util.hpp"

using namespace orbcal;

using orbcal::test::slurp;

namespace {
/// A 40-view quick-scene dataset (Table 3 errors, 0.01 deg joint noise, seed 1) in a fresh temporary folder.
render::DatasetJob renderQuick(const std::string& name) {
  render::DatasetJob job;
  job.scene = test::sourcePath("scenes/quick_scene.yaml");
  job.count = 40;
  job.out = test::tempDir(name) + "/dataset";
  render::renderDataset(job);
  return job;
}
}  // namespace

TEST_CASE("calibrate a rendered dataset: the calibrated robot file reproduces the estimate and cuts the hold-out error",
          "[e2e][calibrate]") {
  render::DatasetJob job = renderQuick("calibrate");

  workflow::CalibrateOptions o;
  o.dataset = job.out;
  o.quiet = true;
  const workflow::CalibrateResult r = workflow::runCalibrate(o);
  CHECK(r.images == 40);
  CHECK(r.usable >= 38);  // clean rendered views; the planner keeps a 20 px margin
  // 20 % of 38-40 usable images would be 8, fewer than the 10 configurations the held-out test needs
  // (calib::kMinHeldoutConfigurations); the default holds out 10 where as many are left to fit.
  CHECK(r.held_out == 10);
  REQUIRE(r.has_truth);
  // Wang et al. 2023's bar (90%) on held-out samples, against the camera's measurements and against the truth.
  CHECK(calib::improvement(r.before.position_avg_m, r.after.position_avg_m) >= 0.90);
  CHECK(calib::improvement(r.truth_before.position_avg_m, r.truth_after.position_avg_m) >= 0.90);

  // Alone, the 90% bar passes at 4 x the floor. The floor on the same held-out samples: calibrate a
  // copy of the dataset whose nominal robot is the true arm (nominal + true errors, true errors zero).
  // Its images, usable set and hold-out draw are the same, so its "before" errors are what the true
  // parameters leave there: against the truth, the control noise alone; against the camera, that plus
  // the measurement noise.
  {
    const std::string copy = test::tempDir("calibrate-floor") + "/dataset";
    std::filesystem::copy(job.out, copy, std::filesystem::copy_options::recursive);
    sim::Dataset d = sim::loadDataset(copy);
    REQUIRE(d.manifest.true_errors);
    sim::writeFileAtomic(copy + "/" + d.manifest.robot_file, sim::formatArm(sim::withErrors(d.arm, *d.manifest.true_errors)));
    d.manifest.true_errors = Eigen::VectorXd::Zero(d.arm.numParams());
    sim::writeDatasetTables(d, d.arm.numJoints());
    workflow::CalibrateOptions fo = o;
    fo.dataset = copy;
    const workflow::CalibrateResult at_truth = workflow::runCalibrate(fo);
    REQUIRE(at_truth.usable == r.usable);
    REQUIRE(at_truth.held_out == r.held_out);
    REQUIRE(at_truth.has_truth);
    const calib::ErrorSummary& floor = at_truth.truth_before;          // control noise alone
    const calib::ErrorSummary& floor_measured = at_truth.before;      // plus the camera's noise
    INFO("after / floor, position: " << r.truth_after.position_avg_m / floor.position_avg_m << " against the truth, "
                                     << r.after.position_avg_m / floor_measured.position_avg_m << " against the camera");
    CAPTURE(r.usable, r.held_out, r.truth_before.position_avg_m, r.before.position_avg_m);
    CAPTURE(r.truth_after.position_avg_m, floor.position_avg_m, r.after.position_avg_m, floor_measured.position_avg_m);
    // The main job's runs (docs/papers-experiments.md) (50 + 200 views) land at 1.02-1.09 x floor; here the mean is over
    // only 10 held-out samples (and 29 identification images), so the ratio scatters more: measured
    // 1.03 against the truth and 1.03 against the camera (1.11 and 1.06 on another split of 7). 1.4 leaves room for that scatter; the 90%
    // bar allows 4.0 x the floor here.
    CHECK(r.truth_after.position_avg_m <= 1.4 * floor.position_avg_m);
    CHECK(r.after.position_avg_m <= 1.4 * floor_measured.position_avg_m);
  }

  // The calibrated robot file is a robot file: it loads, and its kinematics are nominal + estimate.
  const sim::Arm nominal = sim::loadArm(job.out + "/robot.yaml");
  const sim::Arm calibrated = sim::loadArm(r.robot_path);
  const sim::Arm expected = sim::withErrors(nominal, r.estimate.y);
  for (const Eigen::VectorXd& q : {Eigen::VectorXd(Eigen::VectorXd::Zero(7)), Eigen::VectorXd(Eigen::VectorXd::LinSpaced(7, -1.5, 2.0))}) {
    CHECK((sim::forwardKinematics(calibrated, q).matrix() - sim::forwardKinematics(expected, q).matrix()).norm() < 1e-12);
  }
  CHECK(slurp(r.report_path).find("## Hold-out validation against the true poses") != std::string::npos);

  // Real data has no truth: the same dataset without the simulation-only manifest fields still calibrates.
  std::string manifest = slurp(job.out + "/manifest.yaml");
  manifest = manifest.substr(0, manifest.find("true_errors:"));
  std::ofstream(job.out + "/manifest.yaml") << manifest;
  o.out = job.out + "/calibration-real";
  const workflow::CalibrateResult real = workflow::runCalibrate(o);
  CHECK_FALSE(real.has_truth);
  CHECK(calib::improvement(real.before.position_avg_m, real.after.position_avg_m) >= 0.90);
  CHECK(slurp(real.report_path).find("true poses") == std::string::npos);
  CHECK(slurp(o.out + "/estimates.csv").find(",,") != std::string::npos);  // empty truth cells

  // Too few usable images is a one-line error naming the dataset.
  o.holdout = 0.9;
  job.count = 5;
  job.out = test::tempDir("calibrate-few") + "/dataset";
  render::renderDataset(job);
  o.dataset = job.out;
  CHECK_THROWS_WITH(workflow::runCalibrate(o), Catch::StartsWith(job.out + ": only "));
}

namespace {
/// The names after "Held as unidentifiable (N): " in an image calibration's report.
std::vector<std::string> reportedHeld(const std::string& report) {
  const std::smatch m = [&] {
    std::smatch out;
    std::regex_search(report, out, std::regex(R"(Held as unidentifiable \((\d+)\): ([^(\n]*))"));
    return out;
  }();
  REQUIRE(m.size() == 3);
  std::vector<std::string> names;
  std::istringstream in(m[2].str());
  for (std::string w; in >> w;) {
    while (!w.empty() && (w.back() == ',' || w.back() == '.')) w.pop_back();
    if (!w.empty()) names.push_back(w);
  }
  CHECK(static_cast<int>(names.size()) == std::stoi(m[1].str()));
  return names;
}

/// The parameters the report's estimate table marks held: the first cell of each row whose 1-sigma cell
/// says "held" (the table of every calibration report, workflow::parameterTable).
std::vector<std::string> markedHeld(const std::string& report) {
  const std::size_t table = report.find("| parameter |", report.find("## Estimate"));
  REQUIRE(table != std::string::npos);
  std::istringstream in(report.substr(table));
  std::string line;
  std::getline(in, line);
  REQUIRE(line.rfind("| parameter | block | value | 1-sigma |", 0) == 0);
  std::getline(in, line);  // the rule
  std::vector<std::string> names;
  while (std::getline(in, line) && line.rfind("| ", 0) == 0) {
    std::vector<std::string> cells;
    for (std::size_t a = 0; (a = line.find('|', a)) != std::string::npos && a + 1 < line.size(); ++a) {
      const std::string cell = line.substr(a + 1, line.find('|', a + 1) - a - 1);
      const std::size_t first = cell.find_first_not_of(' ');
      cells.push_back(first == std::string::npos ? "" : cell.substr(first, cell.find_last_not_of(' ') - first + 1));
    }
    REQUIRE(cells.size() >= 4);
    if (cells[3] == "held") names.push_back(cells[0]);
  }
  return names;
}
}  // namespace

TEST_CASE("calibrate: the report's held set is the one its estimate table marks, for every estimator", "[e2e][calibrate]") {
  // The SSRMS's joints 3, 4 and 5 are parallel: d3, d4 and d5 are observable only as their sum, so two
  // of them are held. One decision (sim::numericalRank) names them in the identifiability section and
  // in the estimate table, whatever the estimator.
  const render::DatasetJob job = renderQuick("calibrate-held");
  for (const std::string method : {"EKF", "LM", "LSE (weighted)", "IEKF"}) {
    CAPTURE(method);
    workflow::CalibrateOptions o;
    o.dataset = job.out;
    o.quiet = true;
    o.plots = false;
    o.method = method;
    o.out = test::tempDir("calibrate-held-" + std::to_string(method.size())) + "/out";
    const workflow::CalibrateResult r = workflow::runCalibrate(o);
    const std::string report = slurp(r.report_path);
    const std::vector<std::string> reported = reportedHeld(report);
    std::vector<std::string> marked = markedHeld(report);
    CHECK(reported.size() == 2);
    std::vector<std::string> sorted_reported = reported;
    std::sort(sorted_reported.begin(), sorted_reported.end());
    std::sort(marked.begin(), marked.end());
    CHECK(marked == sorted_reported);
    CHECK(r.estimate.held == r.classes.held);
    for (int i : r.classes.held) CHECK(r.estimate.y[i] == 0.0);
    // estimates.csv (parameters.png's source) says the same: held exactly the held set, and each
    // parameter's class (relative: d3, d4, d5, only their sum determined).
    const sim::CsvTable estimates = sim::CsvTable::parse(slurp(o.out + "/estimates.csv"), "estimates.csv");
    REQUIRE(estimates.rows() == r.classes.names.size());
    for (std::size_t i = 0; i < estimates.rows(); ++i) {
      const bool held = std::binary_search(r.classes.held.begin(), r.classes.held.end(), static_cast<int>(i));
      CHECK(estimates.cell(i, estimates.requireColumn("held")) == (held ? "1" : "0"));
      CHECK(estimates.cell(i, estimates.requireColumn("class")) == calib::paramClassName(r.classes.classes[i]));
    }
  }
}

namespace {
/// The dataset's scene with its board placement off by 5 mm and 0.3 deg (a board re-mounted, a
/// tape-measure error; or, in orbit, launch loads and thermal deformation).
void misplaceBoard(const std::string& dataset) {
  const std::string scene = dataset + "/scene.yaml";
  std::string text = slurp(scene);
  const std::string from = "base_T_board: {xyz_m: [6.0, 4.0, 6.0], rpy_deg: [0.0, 90.0, 0.0]}";
  REQUIRE(text.find(from) != std::string::npos);
  text.replace(text.find(from), from.size(), "base_T_board: {xyz_m: [6.005, 4.0, 6.0], rpy_deg: [0.3, 90.0, 0.0]}");
  sim::writeFileAtomic(scene, text);
}
}  // namespace

TEST_CASE("calibrate --estimate-frames: a wrong base_T_board in the scene no longer spoils the calibration",
          "[e2e][calibrate]") {
  const render::DatasetJob job = renderQuick("calibrate-frames");
  workflow::CalibrateOptions o;
  o.dataset = job.out;
  o.quiet = true;
  o.estimate_frames = true;
  o.out = job.out + "/../right";
  o.callbacks.figure = tools::plotReportFigure;  // the program's figure drawer
  const workflow::CalibrateResult right = workflow::runCalibrate(o);
  REQUIRE(right.frames);

  // The scene's board placement off by 5 mm and 0.3 deg (a board re-mounted, a tape-measure error).
  misplaceBoard(job.out);
  o.out = job.out + "/../wrong";
  const workflow::CalibrateResult wrong = workflow::runCalibrate(o);
  REQUIRE(wrong.frames);
  // The frames start from the camera poses alone, so the scene's placement does not enter the fit.
  CHECK(wrong.frames->heldout_after.position_rms_m == Approx(right.frames->heldout_after.position_rms_m).epsilon(1e-9));
  // Taking the wrong placement as exact costs several times the error (against the true poses).
  CHECK(wrong.truth_after.position_avg_m > 3.0 * right.truth_after.position_avg_m);
  // With the frames estimated the held-out camera poses are predicted to the level of the correct scene's
  // DH-only calibration (the control noise floor, ~2.4 mm on this 20 m arm), not to the wrong one's.
  CHECK(wrong.frames->heldout_after.position_rms_m < 1.5 * right.truth_after.position_avg_m);
  CHECK(wrong.frames->heldout_before.position_rms_m > 10.0 * wrong.frames->heldout_after.position_rms_m);
  CHECK(std::filesystem::exists(job.out + "/../wrong/frames.yaml"));
}

TEST_CASE("calibrate --model dr: frame-free pairs of camera poses, a wrong base_T_board changes nothing", "[e2e][calibrate]") {
  // Jia et al. 2019's reason for the distance-and-rotation model: the board-to-base transform changes
  // between the ground calibration and use; distances and rotation angles between camera poses do not
  // depend on it.
  const render::DatasetJob job = renderQuick("calibrate-dr");
  workflow::CalibrateOptions o;
  o.dataset = job.out;
  o.quiet = true;
  o.method = "LSE (weighted)";
  o.model = "dr";
  o.out = job.out + "/../right";
  o.callbacks.figure = tools::plotReportFigure;  // the program's figure drawer
  const workflow::CalibrateResult right = workflow::runCalibrate(o);
  REQUIRE(right.relative_before);
  // A rigid motion of the whole arm is invisible to both rows (Jia et al. 2019): theta1
  // and d1, and in modified DH alpha_0 and a_0 (alpha1, a1 here), which precede q1.
  for (const char* name : {"theta1", "alpha1", "a1", "d1"}) {
    const auto it = std::find(right.classes.names.begin(), right.classes.names.end(), name);
    REQUIRE(it != right.classes.names.end());
    CHECK(right.classes.classes[static_cast<std::size_t>(it - right.classes.names.begin())] == calib::ParamClass::kIneffective);
  }
  // The held-out pairs are predicted far better than by the nominal arm: the Table 3 errors move them
  // by tens of mm and tenths of a degree; the joint noise (0.01 deg on a 20 m arm) leaves a few mm.
  CHECK(right.relative_after->distance_rms_m < 0.15 * right.relative_before->distance_rms_m);
  CHECK(right.relative_after->angle_rms_rad < 0.15 * right.relative_before->angle_rms_rad);
  workflow::CalibrateOptions pose = o;
  pose.model = "pose";
  pose.out = job.out + "/../right-pose";
  const workflow::CalibrateResult pose_right = workflow::runCalibrate(pose);
  CHECK_FALSE(pose_right.relative_before);

  misplaceBoard(job.out);
  o.out = job.out + "/../wrong";
  const workflow::CalibrateResult wrong = workflow::runCalibrate(o);
  // The same estimate (to round-off) and the same errors against the true poses.
  CHECK((wrong.estimate.y - right.estimate.y).cwiseAbs().maxCoeff() < 1e-9);
  CHECK(wrong.truth_after.position_avg_m == Approx(right.truth_after.position_avg_m).epsilon(1e-6));
  // The absolute model takes the wrong placement as exact and absorbs it into the arm's parameters
  // (5 mm and 0.3 deg at the board move the estimate by far more than its round-off).
  pose.out = job.out + "/../wrong-pose";
  const workflow::CalibrateResult pose_wrong = workflow::runCalibrate(pose);
  CHECK((pose_wrong.estimate.y - pose_right.estimate.y).cwiseAbs().maxCoeff() > 1e-4);
}

TEST_CASE("calibrate: an inconsistent fit is refused, named, and writes no robot file unless --accept-worse",
          "[e2e][calibrate]") {
  const render::DatasetJob job = renderQuick("calibrate-refuse");
  workflow::CalibrateOptions o;
  o.dataset = job.out;
  o.quiet = true;
  o.out = job.out + "/../right";
  o.callbacks.figure = tools::plotReportFigure;  // the program's figure drawer
  const workflow::CalibrateResult right = workflow::runCalibrate(o);
  INFO(calib::formatConsistency(right.consistency));
  CHECK(right.consistency.consistent());  // the vision covariance plus the joint noise is honest
  CHECK(right.refusals.empty());
  CHECK(right.written);
  // Per-image errors (a header and one row per usable image) and the report's figures (python3 with
  // matplotlib is installed by tools/install-deps.sh).
  const std::string rows = slurp(o.out + "/samples.csv");
  CHECK(rows.rfind("image,set,before_mm,after_mm,outlier\n", 0) == 0);
  CHECK(static_cast<int>(std::count(rows.begin(), rows.end(), '\n')) == 1 + right.usable);
  CHECK(std::filesystem::exists(o.out + "/samples.png"));
  CHECK(std::filesystem::exists(o.out + "/parameters.png"));

  misplaceBoard(job.out);
  o.out = job.out + "/../wrong";
  const workflow::CalibrateResult wrong = workflow::runCalibrate(o);
  CHECK_FALSE(wrong.consistency.consistent());
  REQUIRE_FALSE(wrong.refusals.empty());
  // The frames explain it: with both estimated the fit is consistent again.
  CHECK(wrong.likely_cause.find("board or camera mount") != std::string::npos);
  CHECK_FALSE(wrong.written);
  CHECK_FALSE(std::filesystem::exists(o.out + "/robot_calibrated.yaml"));
  const std::string report = slurp(o.out + "/report.md");
  CHECK(report.find("**This calibration is not to be trusted as it is:**") < report.find("## Images"));

  o.accept_worse = true;
  o.out = job.out + "/../accepted";
  const workflow::CalibrateResult accepted = workflow::runCalibrate(o);
  CHECK_FALSE(accepted.refusals.empty());
  CHECK(accepted.written);
  CHECK(std::filesystem::exists(o.out + "/robot_calibrated.yaml"));
}
