// Reports that agree with themselves and with each other: evaluate's refitted count, per-sample
// residuals and baseline; no rotation anywhere for position-only data; the noise diagnose and calibrate
// report; diagnose's tables saying what each tests; a parameter in an unidentifiable combination said
// to be one; robot paths written clean; `fk` digits and JSON; help text of flags.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <regex>

#include "orbcal/sim/arm.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/measured.hpp"
#include "orbcal/sim/model.hpp"
#include "orbcal/sim/model_io.hpp"
#include "orbcal/sim/simulate.hpp"
#include "orbcal/workflow/diagnose.hpp"
#include "orbcal/workflow/measured.hpp"
#include "run_orbcal.hpp"
#include "test_util.hpp"

using namespace orbcal;
namespace fs = std::filesystem;
using Catch::Matchers::Contains;

namespace {

/// iiwa7 tracker data (its robot file has masses, so torques), seeded.
sim::SimulationSpec trackerSpec(int samples, std::uint64_t seed, bool rotation) {
  sim::SimulationSpec s;
  s.samples = samples;
  s.seed = seed;
  s.rotation = rotation;
  return s;
}

sim::SimulatedData simulate(const sim::SimulationSpec& s, const std::string& out) {
  return workflow::runSimulate(sim::loadArm(test::sourcePath("scenes/iiwa7.yaml")), s, out);
}

/// The numbers of `column` in a CSV file.
std::vector<double> csvColumn(const std::string& path, const std::string& column) {
  const sim::CsvTable t = sim::CsvTable::parse(test::slurp(path), path);
  const int c = t.requireColumn(column);
  std::vector<double> v;
  for (std::size_t r = 0; r < t.rows(); ++r) v.push_back(t.number(r, c));
  return v;
}

double rms(const std::vector<double>& v) {
  double sum = 0.0;
  for (double x : v) sum += x * x;
  return std::sqrt(sum / static_cast<double>(v.size()));
}

/// The first number after `key` in a JSON text (`"key": 1.5`).
double jsonValue(const std::string& json, const std::string& key) {
  std::smatch m;
  REQUIRE(std::regex_search(json, m, std::regex("\"" + key + "\": ([-+0-9.eE]+)")));
  return std::stod(m[1]);
}

}  // namespace

TEST_CASE("evaluate: the refitted count, residuals.csv per sample with its configuration, a baseline row", "[e2e][evaluate]") {
  const std::string dir = test::tempDir("evaluate-residuals");
  const sim::SimulatedData d = simulate(trackerSpec(60, 11, true), dir + "/data");  // marker per session: refitted

  // The truth predicts its own data; only the per-session marker frame is refitted: 6 parameters.
  const workflow::EvaluateResult r = workflow::runEvaluate(dir + "/data/truth/model.yaml", d.data.description, dir + "/eval");
  CHECK(r.refitted == 6);
  CHECK_THAT(test::slurp(r.report_path), Contains("(6 parameters)"));
  CHECK(jsonValue(test::slurp(r.json_path), "refitted_parameters") == 6);

  // One row per sample; its position column is the prediction error whose RMS the JSON gives.
  const std::vector<double> pos = csvColumn(r.residuals_path, "position_mm");
  REQUIRE(pos.size() == d.data.poses.size());
  CHECK(rms(pos) == Approx(r.fit.residuals.position_rms_m * 1e3).epsilon(1e-5));
  const std::vector<double> x = csvColumn(r.residuals_path, "x_mm"), y = csvColumn(r.residuals_path, "y_mm"),
                            z = csvColumn(r.residuals_path, "z_mm");
  for (std::size_t i = 0; i < pos.size(); ++i) CHECK(std::hypot(x[i], y[i], z[i]) == Approx(pos[i]).epsilon(1e-4));
  CHECK(csvColumn(r.residuals_path, "rotation_deg").size() == pos.size());
  // Every sample a configuration of its own here (drawn at random): ids 0..n-1 in data order.
  const std::vector<double> config = csvColumn(r.residuals_path, "configuration");
  for (std::size_t i = 0; i < config.size(); ++i) CHECK(config[i] == static_cast<double>(i));

  // The baseline (nominal arm, frames fitted) carries the true DH errors: well above the truth's.
  CHECK(r.baseline.position_rms_m > 3.0 * r.fit.residuals.position_rms_m);
  CHECK(rms(csvColumn(r.residuals_path, "baseline_position_mm")) == Approx(r.baseline.position_rms_m * 1e3).epsilon(1e-5));
  CHECK_THAT(test::slurp(r.report_path), Contains("| baseline: nominal arm, frames fitted |"));

  // Data whose frames are all the model's: nothing is refitted, and evaluate says so.
  sim::SimulationSpec shared = trackerSpec(40, 12, true);
  shared.marker = sim::FrameSharing::kShared;
  const sim::SimulatedData d2 = simulate(shared, dir + "/data2");
  const workflow::EvaluateResult r2 = workflow::runEvaluate(dir + "/data2/truth/model.yaml", d2.data.description, dir + "/eval2");
  CHECK(r2.refitted == 0);
  CHECK_THAT(test::slurp(r2.report_path), Contains("nothing was refitted"));
}

TEST_CASE("position-only data: no rotation noise, column or number in calibrate, diagnose and evaluate", "[e2e][evaluate]") {
  const std::string dir = test::tempDir("position-only-reports");
  const sim::SimulatedData d = simulate(trackerSpec(120, 13, false), dir + "/data");
  REQUIRE_FALSE(workflow::measuresRotation(d.data));

  workflow::MeasuredCalibrateOptions o;
  o.description = d.data.description;
  o.out = dir + "/cal";
  const workflow::MeasuredCalibrateResult c = workflow::runMeasuredCalibrate(o);
  const test::OrbcalRun cal = test::runOrbcal(dir, "calibrate " + d.data.description + " -o cal2");
  const workflow::EvaluateResult e = workflow::runEvaluate(dir + "/data/truth/model.yaml", d.data.description, dir + "/eval");
  const test::OrbcalRun ev = test::runOrbcal(dir, "evaluate --model data/truth/model.yaml --data " + d.data.description + " -o eval2");
  workflow::DiagnoseRunOptions g;
  g.input = d.data.description;
  g.out = dir + "/diag";
  g.plots = false;
  g.quiet = true;
  const workflow::DiagnoseRunResult dg = workflow::runDiagnose(g);
  for (const std::string& text : {test::slurp(c.report_path), cal.out, test::slurp(e.report_path), test::slurp(e.json_path),
                                  test::slurp(e.residuals_path), ev.out, test::slurp(dg.report_path), test::slurp(dg.json_path)}) {
    CHECK_THAT(text, !Contains("rotation RMS") && !Contains("rotation_rms") && !Contains("rotation_deg") &&
                         !Contains("rotation_max") && !Contains(", rotation "));
  }
  // The positions still are: the check above is not passing on empty reports.
  CHECK_THAT(test::slurp(e.report_path), Contains("position RMS (mm)"));
  CHECK_THAT(cal.out, Contains("noise (1 sigma per axis): position "));
}

TEST_CASE("diagnose reports the noise as calibrate does, and says what selected the effect", "[e2e][diagnose]") {
  const std::string dir = test::tempDir("diagnose-noise");
  sim::SimulationSpec s = trackerSpec(160, 14, true);
  s.effects = {sim::Compliance{{1}}};
  const sim::SimulatedData d = simulate(s, dir + "/data");
  // The noise not stated: both commands estimate it.
  const std::string desc = dir + "/data/no-noise.yaml";
  test::write(desc, std::regex_replace(test::slurp(d.data.description), std::regex("\nnoise: [^\n]*"), ""));
  REQUIRE_FALSE(sim::loadMeasuredData(desc).noise_position_m);
  workflow::DiagnoseRunOptions g;
  g.input = desc;
  g.out = dir + "/diag";
  g.plots = false;
  g.quiet = true;
  const workflow::DiagnoseRunResult dg = workflow::runDiagnose(g);
  REQUIRE_FALSE(dg.diagnosis.selected.empty());
  const std::string report = test::slurp(dg.report_path);

  // calibrate with the selected effects on all the samples estimates the noise diagnose reports for them.
  workflow::MeasuredCalibrateOptions o;
  o.description = desc;
  std::string effects;
  for (const sim::Effect& e : dg.diagnosis.selected) {
    o.effects.push_back(sim::formatEffect(e));
    effects += (effects.empty() ? "" : " ") + o.effects.back();
  }
  o.holdout = 0.0;
  o.out = dir + "/cal";
  const workflow::MeasuredCalibrateResult c = workflow::runMeasuredCalibrate(o);
  REQUIRE(c.fit.noise_estimated);
  const std::string noise = workflow::noiseText(c.fit.noise, true);
  CAPTURE(noise);
  CHECK_THAT(report, Contains("`orbcal calibrate --effects " + effects + "`"));
  CHECK_THAT(report, Contains("the noise is " + noise + "."));
  CHECK_THAT(test::slurp(c.report_path), Contains("Measurement noise (1 sigma per axis): " + noise));
  // Enough digits: a 0.01 deg rotation noise is not printed as 0.0000.
  CHECK_THAT(noise, Contains(" deg") && !Contains("rotation 0 deg") && !Contains("0.0000 deg"));

  // The tables say what they test: the candidates' score tests select, the variables' F tests do not.
  CHECK_THAT(report, Contains("## Candidates: what selected the effects") && Contains("The verdict names the candidates this selects") &&
                         Contains("It does not select anything"));
}

TEST_CASE("calibrate's parameter table marks held parameters and those only a combination of which is determined",
          "[e2e][measured]") {
  const std::string dir = test::tempDir("combination-marks");
  const sim::SimulatedData d = simulate(trackerSpec(80, 15, true), dir + "/data");
  workflow::MeasuredCalibrateOptions o;
  o.description = d.data.description;
  o.out = dir + "/cal";
  o.accept_worse = true;
  const workflow::MeasuredCalibrateResult c = workflow::runMeasuredCalibrate(o);
  REQUIRE_FALSE(c.fit.estimate.held.empty());  // the iiwa7 + frames has unidentifiable parameters
  const std::string report = test::slurp(c.report_path);
  const std::vector<sim::ParameterRow> rows = workflow::parameterRows(c.fit);
  // A registration frame's parameters are said in its row of the frames table (registrationFramesTable).
  const auto frame = [&rows](int i) { return rows[static_cast<std::size_t>(i)].effect == "base" || rows[static_cast<std::size_t>(i)].effect == "marker"; };
  const std::string frame_row = "\\| (world_T_base|flange_T_marker) \\|[^\\n]*";
  for (int i : c.fit.estimate.held) {
    const std::string& name = rows[static_cast<std::size_t>(i)].name;
    CAPTURE(name);
    CHECK(std::regex_search(report, std::regex(frame(i) ? frame_row + "held: [^;|\\n]*\\b" + name + "\\b"
                                                        : "\\| " + name + " \\|[^\\n]*\\| held \\|[^\\n]*no: held at nominal")));
  }
  // Every group of the identifiability analysis: its free members said to be determined only together.
  int marked = 0;
  for (const sim::Redundancy& g : c.fit.identifiability.redundancies) {
    for (int i : g.params) {
      if (rows[static_cast<std::size_t>(i)].held) continue;
      ++marked;
      const std::string& name = rows[static_cast<std::size_t>(i)].name;
      CAPTURE(name);
      CHECK(std::regex_search(report, std::regex(frame(i) ? frame_row + "only in a combination: [^\\n]*\\b" + name + " with "
                                                          : "\\| " + name + " \\|[^\\n]*only in a combination with")));
    }
  }
  CHECK(marked > 0);
}

TEST_CASE("robot paths are written clean: a description's ../ resolved, robot.yaml naming its URDF from its own folder",
          "[e2e][measured][urdf]") {
  const std::string dir = test::tempDir("clean-paths");
  fs::create_directories(dir + "/robots");
  fs::copy_file(test::sourcePath("tests/data/iiwa7.urdf"), dir + "/robots/arm.urdf");
  const sim::Arm arm = sim::loadArm(dir + "/robots/arm.urdf");
  const sim::SimulatedData d = workflow::runSimulate(arm, trackerSpec(60, 16, true), dir + "/data");
  // A description naming the robot through a parent folder.
  const std::string desc = test::slurp(d.data.description);
  std::string edited = std::regex_replace(desc, std::regex("robot: [^\\n]*"), "robot: ../robots/arm.urdf");
  REQUIRE(edited != desc);
  test::write(dir + "/data/up.yaml", edited);
  const sim::MeasuredData data = sim::loadMeasuredData(dir + "/data/up.yaml");
  CHECK(data.robot_file == dir + "/robots/arm.urdf");

  workflow::MeasuredCalibrateOptions o;
  o.description = dir + "/data/up.yaml";
  o.out = dir + "/out/cal";
  o.accept_worse = true;
  const workflow::MeasuredCalibrateResult c = workflow::runMeasuredCalibrate(o);
  REQUIRE_FALSE(c.model_path.empty());
  // Absolute paths in, clean paths out (robot.yaml names the calibrated URDF beside it, relative to
  // its own folder; its header the nominal one, absolute).
  CHECK_THAT(test::slurp(dir + "/out/cal/robot.yaml"), !Contains("/../") && Contains("nominal: " + dir + "/robots/arm.urdf;") &&
                                                           Contains("file: \"robot_calibrated.urdf\""));
  // Relative paths in (the command run in `dir`), the URDF named relative to robot.yaml's own folder.
  const test::OrbcalRun run = test::runOrbcal(dir, "calibrate data/up.yaml -o out/cal2 --accept-worse");
  INFO(run.err);
  REQUIRE(fs::exists(dir + "/out/cal2/robot.yaml"));
  const std::string robot = test::slurp(dir + "/out/cal2/robot.yaml");
  CHECK_FALSE(std::regex_search(robot, std::regex("[^./]/\\.\\./")));  // no "a/../b"; a leading "../../" is clean
  CHECK_THAT(robot, Contains("file: \"robot_calibrated.urdf\"") && Contains("nominal: robots/arm.urdf;"));
  // Read back from its own folder, it names the URDF that exists.
  CHECK(fs::exists(sim::loadArm(dir + "/out/cal2/robot.yaml").urdf.file));
}

TEST_CASE("compliance without torques or masses names the URDF links that lack <inertial>", "[e2e][measured][urdf]") {
  const std::string dir = test::tempDir("no-inertial");
  std::string urdf = test::slurp(test::sourcePath("tests/data/iiwa7.urdf"));
  urdf = std::regex_replace(urdf, std::regex("<inertial>[\\s\\S]*?</inertial>"), "");
  REQUIRE(urdf.find("<inertial>") == std::string::npos);
  test::write(dir + "/arm.urdf", urdf);
  const sim::Arm arm = sim::loadArm(dir + "/arm.urdf");
  REQUIRE(arm.masses.empty());
  REQUIRE_FALSE(arm.urdf.links_without_inertial.empty());
  const sim::SimulatedData d = workflow::runSimulate(arm, trackerSpec(30, 17, true), dir + "/data");
  // The description names the URDF itself (simulate wrote the arm as robot.yaml beside the data).
  const std::string desc = test::slurp(d.data.description);
  test::write(dir + "/data/urdf.yaml", std::regex_replace(desc, std::regex("robot: [^\n]*"), "robot: ../arm.urdf"));
  const test::OrbcalRun run = test::runOrbcal(dir, "calibrate data/urdf.yaml --effects compliance:2 -o cal");
  CHECK(run.status == 1);
  std::string links;
  for (const std::string& l : arm.urdf.links_without_inertial) links += (links.empty() ? "" : ", ") + l;
  CHECK_THAT(run.err, Contains("no <inertial> on the links the chain moves (" + links + ")"));
  CHECK(std::count(run.err.begin(), run.err.end(), '\n') == 1);
  CHECK_FALSE(fs::exists(dir + "/cal/model.yaml"));
}

TEST_CASE("fk prints the position to the nanometre, and --json every number exact", "[e2e][fk]") {
  const std::string dir = test::tempDir("fk-digits");
  const test::OrbcalRun json = test::runOrbcal(dir, "fk --robot builtin:iiwa7.yaml --json 10 20 -30 40 -50 60 70");
  REQUIRE(json.status == 0);
  const sim::Arm arm = sim::loadArm("builtin:iiwa7.yaml");
  Eigen::VectorXd q(7);
  q << 10, 20, -30, 40, -50, 60, 70;
  const Eigen::Isometry3d T = sim::forwardKinematics(arm, q * sim::kDegToRad);
  std::smatch m;
  REQUIRE(std::regex_search(json.out, m, std::regex("\"position_mm\": \\[([^,]+), ([^,]+), ([^\\]]+)\\]")));
  for (int i = 0; i < 3; ++i) CHECK(std::stod(m[i + 1]) == T.translation()[i] * 1e3);  // exact: %.17g reads back
  CHECK_THAT(json.out, Contains("\"within_limits\": true") && Contains("\"base_T_flange\": [["));

  const test::OrbcalRun text = test::runOrbcal(dir, "fk --robot builtin:iiwa7.yaml 10 20 -30 40 -50 60 70");
  REQUIRE(text.status == 0);
  REQUIRE(std::regex_search(text.out, m, std::regex("position_mm: \\[([^,]+), ([^,]+), ([^\\]]+)\\]")));
  for (int i = 0; i < 3; ++i) CHECK(std::abs(std::stod(m[i + 1]) - T.translation()[i] * 1e3) <= 0.5e-6);  // 6 decimals of a mm
}

TEST_CASE("--help shows flags as they are typed: --no-plots, not --no-plots{false}", "[e2e][cli]") {
  const std::string dir = test::tempDir("help-flags");
  for (const char* command : {"calibrate", "experiment", "diagnose", "study run", "study merge"}) {
    const test::OrbcalRun help = test::runOrbcal(dir, std::string(command) + " --help");
    CAPTURE(command, help.out);
    CHECK(help.status == 0);
    CHECK_THAT(help.out, Contains("--no-plots") && !Contains("{false}") && !Contains("{true}"));
  }
}

namespace {
/// A UR5 in standard DH (Universal Robots' published DH parameters), +-360 deg on every joint.
const char* kUr5 =
    "name: UR5 (standard DH)\nconvention: standard\njoints:\n"
    "  - {a_m: 0.0, alpha_deg: 90.0, d_m: 0.089159, theta_offset_deg: 0.0, min_deg: -360, max_deg: 360}\n"
    "  - {a_m: -0.425, alpha_deg: 0.0, d_m: 0.0, theta_offset_deg: 0.0, min_deg: -360, max_deg: 360}\n"
    "  - {a_m: -0.39225, alpha_deg: 0.0, d_m: 0.0, theta_offset_deg: 0.0, min_deg: -360, max_deg: 360}\n"
    "  - {a_m: 0.0, alpha_deg: 90.0, d_m: 0.10915, theta_offset_deg: 0.0, min_deg: -360, max_deg: 360}\n"
    "  - {a_m: 0.0, alpha_deg: -90.0, d_m: 0.09465, theta_offset_deg: 0.0, min_deg: -360, max_deg: 360}\n"
    "  - {a_m: 0.0, alpha_deg: 0.0, d_m: 0.0823, theta_offset_deg: 0.0, min_deg: -360, max_deg: 360}\n";
}  // namespace

TEST_CASE("configs on a 1 m arm: the industrial scene finds views the default scene cannot; a joint box and a floor hold",
          "[e2e][configs]") {
  const std::string dir = test::tempDir("configs-industrial");
  test::write(dir + "/ur5.yaml", kUr5);
  // The default scene's board is 7 m away: a UR5 (0.85 m reach) sees it from nowhere.
  const test::OrbcalRun far = test::runOrbcal(dir, "configs --robot ur5.yaml -n 5 -o far.csv");
  CHECK(far.status == 1);
  CHECK_THAT(far.err, Contains("only 0 of 5 configurations"));

  const std::string box = "--joint-box-deg -150 150 -170 -10 -160 160 -180 180 -180 180 -180 180";
  const test::OrbcalRun near = test::runOrbcal(
      dir, "configs --robot ur5.yaml --scene builtin:industrial_1m_scene.yaml -n 20 --floor-z-m 0.02 " + box + " -o near.csv");
  INFO(near.err);
  REQUIRE(near.status == 0);
  const sim::Arm arm = sim::loadArm(dir + "/ur5.yaml");
  const std::vector<Eigen::VectorXd> q = sim::parseConfigurationsCsv(test::slurp(dir + "/near.csv"), "near.csv", 6);
  REQUIRE(q.size() == 20);
  for (const Eigen::VectorXd& c : q) {
    CAPTURE(c.transpose() * sim::kRadToDeg);
    CHECK(std::abs(c[0]) <= 150 * sim::kDegToRad);
    CHECK((c[1] >= -170 * sim::kDegToRad && c[1] <= -10 * sim::kDegToRad));  // the shoulder above the horizontal
    CHECK(std::abs(c[2]) <= 160 * sim::kDegToRad);
    const std::vector<Eigen::Isometry3d> frames = sim::chainFrames(arm, c);  // [0]: the base's own, fixed
    for (std::size_t f = 1; f < frames.size(); ++f) CHECK(frames[f].translation().z() >= 0.02);
    CHECK(sim::forwardKinematics(arm, c).translation().z() >= 0.02);
  }
  // A floor above everything the arm reaches: refused, the floor counted among the reasons.
  const test::OrbcalRun high = test::runOrbcal(dir, "configs --robot ur5.yaml --scene builtin:industrial_1m_scene.yaml -n 5 --floor-z-m 0.5 -o high.csv");
  CHECK(high.status == 1);
  CHECK(std::regex_search(high.err, std::regex("below the floor [1-9]")));
  // A box outside the robot's limits is named.
  const test::OrbcalRun wrong = test::runOrbcal(dir, "configs --robot ur5.yaml --scene builtin:industrial_1m_scene.yaml -n 5 "
                                                     "--joint-box-deg 400 500 0 1 0 1 0 1 0 1 0 1 -o wrong.csv");
  CHECK(wrong.status == 1);
  CHECK_THAT(wrong.err, Contains("--joint-box-deg: joint 1: the box 400..500 deg leaves no travel"));
}
