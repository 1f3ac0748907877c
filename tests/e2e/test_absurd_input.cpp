// Numbers that cannot lie: a measured value far outside what any arm or instrument gives crashes
// nothing and reaches no fit; every absurd value of every file orbcal reads is refused at its own key
// with its physical range; messages are one line that names the file and the key (and the file that
// named a missing one); figures that fail for another reason than a missing matplotlib fail the run.
// Each case checks the one-line message, and, where a command runs, its exit status and that it left
// no result that looks valid (no model.yaml, evaluation.json, diagnosis.json, task folder).
#include <sys/wait.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <functional>

#include "orbcal/workflow/calibrate.hpp"
#include "orbcal/workflow/measured.hpp"
#include "orbcal/render/dataset_writer.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/measured.hpp"
#include "orbcal/sim/model_io.hpp"
#include "orbcal/sim/truth.hpp"
#include "orbcal/vision/measurement.hpp"
#include "orbcal/workflow/study.hpp"
#include "dataset_fixture.hpp"
#include "test_util.hpp"

using namespace orbcal;
using Catch::Matchers::Contains;
using Catch::Matchers::StartsWith;
namespace fs = std::filesystem;

namespace {

using test::inputError;
using test::slurp;
using test::write;

using test::edited;
void editFile(const std::string& path, const std::string& from, const std::string& to) { write(path, edited(slurp(path), from, to)); }

/// Sets the cell of column `column` on data row `row` (0-based, after the header) of a CSV file.
void setCell(const std::string& path, std::size_t row, const std::string& column, const std::string& value) {
  std::vector<std::string> lines;
  std::istringstream in(slurp(path));
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  const auto split = [](const std::string& l) {
    std::vector<std::string> cells;
    std::istringstream s(l);
    for (std::string c; std::getline(s, c, ',');) cells.push_back(c);
    return cells;
  };
  const std::vector<std::string> header = split(lines.at(0));
  const auto col = std::find(header.begin(), header.end(), column);
  REQUIRE(col != header.end());
  std::vector<std::string> cells = split(lines.at(row + 1));
  cells.at(static_cast<std::size_t>(col - header.begin())) = value;
  std::string joined, out;
  for (const std::string& c : cells) joined += (joined.empty() ? "" : ",") + c;
  lines[row + 1] = joined;
  for (const std::string& l : lines) out += l + "\n";
  write(path, out);
}

/// Tracker-style data of the built-in iiwa7 (torques, temperature, time; 2 sessions), seeded, with the
/// truth as DIR/truth/model.yaml. Returns the description's path.
std::string simulated(const std::string& dir, int samples = 40, std::vector<sim::Effect> effects = {sim::Compliance{{1}}}) {
  sim::SimulationSpec s;
  s.samples = samples;
  s.sessions = 2;
  s.payload_kg = {0.0, 1.25};
  s.seed = 5;
  s.effects = std::move(effects);
  return workflow::runSimulate(sim::loadArm(test::sourcePath("scenes/iiwa7.yaml")), s, dir).data.description;
}

struct Run {
  int status = -1;
  std::string out, err;
};
/// `orbcal args` from `dir` (with `env` assignments before it, e.g. "ORBCAL_PLOT_SCRIPT=x"); its exit
/// status and what it printed.
Run runOrbcal(const std::string& dir, const std::string& args, const std::string& env = "") {
  const std::string cmd = "cd '" + dir + "' && " + env + (env.empty() ? "" : " ") + ORBCAL_BINARY + " " + args + " >'" + dir +
                          "/stdout.txt' 2>'" + dir + "/stderr.txt'";
  const int rc = std::system(cmd.c_str());
  return {WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, slurp(dir + "/stdout.txt"), slurp(dir + "/stderr.txt")};
}

/// A refusal on the terminal: exit status 1 and exactly `line` on stderr (one line), nothing else.
void checkRefused(const Run& r, const std::string& line) {
  INFO(r.err);
  CHECK(r.status == 1);
  CHECK(r.err == "orbcal: " + line + "\n");
}

std::string datasetWithoutImages(const std::string& dir, int n) { return test::datasetWithoutImages(dir, n, true); }

/// The message of loading the dataset once `edit` has changed its file `name`.
std::string datasetError(const std::string& dir, const std::string& name, const std::function<void(const std::string&)>& edit) {
  const std::string ds = datasetWithoutImages(dir, 6);
  edit(ds + "/" + name);
  return inputError([&] { sim::loadDataset(ds); });
}

/// The message of loading a copy of the shipped robot file `shipped` edited.
std::string robotError(const std::string& dir, const std::string& shipped, const std::string& from, const std::string& to) {
  const std::string path = dir + "/" + fs::path(shipped).filename().string();
  write(path, edited(slurp(test::sourcePath(shipped)), from, to));
  return inputError([&] { sim::loadArm(path); });
}

}  // namespace

// ---- no crash, no non-finite number anywhere ----

TEST_CASE("absurd input: a measured x_m of -1e308 is refused by calibrate, diagnose and evaluate at its cell", "[e2e][absurd]") {
  const std::string dir = test::tempDir("absurd-1e308");
  const std::string desc = simulated(dir + "/data");
  setCell(dir + "/data/session_1.csv", 4, "x_m", "-1e308");
  const std::string line = dir + "/data/session_1.csv: line 6: x_m: -1e+308 m is outside -10000 m to 10000 m (a position within 10 km)";
  // Before: calibrate and diagnose died of SIGSEGV in an SVD, evaluate wrote `inf` into evaluation.json
  // after 38 lines of Ceres log. Now each says the file, line and column, and writes nothing.
  checkRefused(runOrbcal(dir, "calibrate " + desc + " -o cal"), line);
  checkRefused(runOrbcal(dir, "diagnose " + desc + " -o diag --no-plots"), line);
  checkRefused(runOrbcal(dir, "evaluate --model data/truth/model.yaml --data " + desc + " -o eval"), line);
  for (const char* out : {"cal", "diag", "eval"}) CHECK_FALSE(fs::exists(dir + "/" + out));
}

TEST_CASE("absurd input: a fit whose residual is not finite throws one line before any SVD or solver runs", "[e2e][absurd]") {
  const std::string dir = test::tempDir("absurd-fit");
  const sim::MeasuredData data = sim::loadMeasuredData(simulated(dir, 30, {}));
  std::vector<calib::MarkerObservation> obs = calib::observationsFrom(data, false);
  const sim::KinematicModel start = calib::startingModel(data, obs, {});
  obs[3].world_T_marker.translation().x() = std::numeric_limits<double>::infinity();  // past every reader's check
  for (const char* method : {"LM", "LSE", "EKF"}) {
    calib::FitOptions fo;
    fo.method = method;
    fo.sigma_position_m = 0.05e-3;
    fo.sigma_rotation_rad = 0.01 * sim::kDegToRad;
    try {
      calib::fitMarkerModel(start, obs, fo);
      FAIL("expected a refusal");
    } catch (const std::runtime_error& e) {
      const std::string msg = e.what();
      CHECK(msg.find('\n') == std::string::npos);
      CHECK_THAT(msg, StartsWith("fit: sample 4 of the fitted samples: its residual, Jacobian or covariance is not finite"));
    }
  }
}

TEST_CASE("absurd input: JSON orbcal writes never holds a non-finite number, strings are escaped", "[e2e][absurd]") {
  CHECK(sim::jsonNumber(0.25, "x.json: a") == "0.25");
  CHECK_THROWS_WITH(sim::jsonNumber(std::numeric_limits<double>::infinity(), "evaluation.json: position_rms_mm"),
                    "evaluation.json: position_rms_mm: inf is not a finite number (JSON holds none); nothing written");
  CHECK_THROWS_WITH(sim::jsonNumber(std::nan(""), "diagnosis.json: lack_of_fit.p"), StartsWith("diagnosis.json: lack_of_fit.p: nan is"));
  calib::ResidualStats s;
  s.samples = 3;
  s.position_rms_m = std::numeric_limits<double>::infinity();
  CHECK_THROWS_WITH(workflow::residualJson(s, "evaluation.json"), StartsWith("evaluation.json.position_rms_mm: inf"));
  CHECK(sim::jsonString("a\"b\\c\nd\x01") == "\"a\\\"b\\\\c\\u000ad\\u0001\"");
}

TEST_CASE("absurd input: a PNG cut short is an unreadable image, without libpng's complaint on the terminal", "[e2e][absurd]") {
  const std::string dir = test::tempDir("absurd-truncated-png");
  render::DatasetJob job;
  job.scene = test::sourcePath("scenes/quick_scene.yaml");
  job.count = 2;
  job.out = dir + "/dataset";
  render::renderDataset(job);
  const std::string png = job.out + "/images/000001.png";
  write(png, slurp(png).substr(0, 100));  // as a full disk or a killed writer leaves it
  const Run r = runOrbcal(dir, "measure dataset -o m.csv");
  CHECK(r.status == 0);
  CHECK(r.err.empty());  // before: "libpng error: Read Error"
  CHECK_THAT(r.out, Contains("1 x unreadable: cannot decode"));
  CHECK_THAT(slurp(dir + "/m.csv"), Contains("images/000001.png: truncated (no end marker)"));
}

// ---- every measured column within its physical range ----

TEST_CASE("absurd input: measured torques, temperatures and times are refused outside their physical ranges", "[e2e][absurd]") {
  const std::string dir = test::tempDir("absurd-covariates");
  const std::string desc = simulated(dir);
  const std::string csv = dir + "/session_2.csv", good = slurp(csv);
  const auto message = [&](std::size_t row, const std::string& column, const std::string& value) {
    write(csv, good);
    setCell(csv, row, column, value);
    return inputError([&] { sim::loadMeasuredData(desc); });
  };
  CHECK(message(2, "tau2_Nm", "1e12") ==
        csv + ": line 4: tau2_Nm: 1e+12 N*m is outside -1000000 N*m to 1000000 N*m (a joint torque within 1e6 N*m)");
  CHECK(message(0, "temperature_C", "1e6") == csv + ": line 2: temperature_C: 1000000 degC is outside -150 degC to 200 degC (an arm's temperature)");
  CHECK(message(0, "time_s", "1e11") ==
        csv + ": line 2: time_s: 1e+11 s is outside -1e+10 s to 1e+10 s (a time within 1e10 s, about 300 years: Unix time stamps fit)");
  // Row 3 (line 5) taken before row 2: the sample order is the order the rows say.
  const std::string earlier = message(3, "time_s", "0");
  CHECK_THAT(earlier, StartsWith(csv + ": line 5: time_s: 0 s is earlier than ") &&
                          Contains(" s on line 4 (time runs backwards; the rows of a file are samples in the order taken)"));
  // In the file's own unit: 20 degC declared as K is 20 K, colder than any arm.
  write(csv, good);
  editFile(desc, "unit: degC", "unit: K");
  CHECK(inputError([&] { sim::loadMeasuredData(desc); }) ==
        dir + "/session_1.csv: line 2: temperature_C: 20 K is outside 123.15 K to 473.15 K (an arm's temperature)");
}

TEST_CASE("absurd input: a pose matrix translation of 1e308 mm is refused at its column in mm", "[e2e][absurd]") {
  const std::string dir = test::tempDir("absurd-matrix");
  // The real iiwa7 data's layout: a row-major matrix, translation in mm.
  write(dir + "/robot.yaml", slurp(test::sourcePath("scenes/iiwa7.yaml")));
  const std::string header = "theta_1,theta_2,theta_3,theta_4,theta_5,theta_6,theta_7,m_00,m_01,m_02,m_03,m_10,m_11,m_12,m_13,m_20,m_21,m_22,m_23,m_30,m_31,m_32,m_33\n";
  write(dir + "/run.csv", header + "0,0,0,0,0,0,0,1,0,0,2.4,0,1,0,2.5,0,0,1,1327.8,0,0,0,1\n0,0.1,0,0,0,0,0,1,0,0,1e308,0,1,0,2.5,0,0,1,1327.8,0,0,0,1\n");
  write(dir + "/desc.yaml", "format: orbcal-measurements-1\nrobot: robot.yaml\nfiles: [run.csv]\n"
                            "joints: {columns: [theta_1, theta_2, theta_3, theta_4, theta_5, theta_6, theta_7], unit: rad}\n"
                            "pose: {matrix: [m_00, m_01, m_02, m_03, m_10, m_11, m_12, m_13, m_20, m_21, m_22, m_23, m_30, m_31, m_32, m_33], length_unit: mm}\n"
                            "registration: {base: shared, marker: shared}\n");
  CHECK(inputError([&] { sim::loadMeasuredData(dir + "/desc.yaml"); }) ==
        dir + "/run.csv: line 3: m_03: 1e+308 mm is outside -10000000 mm to 10000000 mm (a position within 10 km)");
}

// ---- the description ----

TEST_CASE("absurd input: a column a description names twice is refused at the second key", "[e2e][absurd]") {
  const std::string dir = test::tempDir("absurd-column-twice");
  const std::string desc = simulated(dir);
  editFile(desc, "columns: [q1_rad, q2_rad,", "columns: [q1_rad, q1_rad,");
  CHECK(inputError([&] { sim::loadMeasuredData(desc); }) ==
        desc + ": joints.columns[1]: column 'q1_rad' is named twice (also at joints.columns[0]); a column holds one quantity");
  // Across quantities too: a torque column read as the temperature.
  const std::string desc2 = simulated(dir + "/b");
  editFile(desc2, "{column: temperature_C,", "{column: tau1_Nm,");
  CHECK(inputError([&] { sim::loadMeasuredData(desc2); }) ==
        desc2 + ": covariates.temperature.column: column 'tau1_Nm' is named twice (also at covariates.torque.columns[0]); a column holds one quantity");
}

TEST_CASE("absurd input: a description's noise of 1e9 mm is refused with the command line's range", "[e2e][absurd]") {
  const std::string dir = test::tempDir("absurd-noise");
  const std::string desc = simulated(dir);
  const std::string good = slurp(desc);
  write(desc, edited(good, "position_mm: 0.050000000000000003", "position_mm: 1e9"));
  CHECK(inputError([&] { sim::loadMeasuredData(desc); }) == desc + ": noise.position_mm: '1e9' is outside 1e-06 mm to 100 mm (1 sigma per axis)");
  write(desc, edited(good, "rotation_deg: 0.01", "rotation_deg: 0"));
  CHECK(inputError([&] { sim::loadMeasuredData(desc); }) == desc + ": noise.rotation_deg: '0' is outside 1e-07 deg to 10 deg (1 sigma per axis)");
  write(desc, edited(good, "rotation_deg: 0.01", "rotation_deg: 0.01, joint_deg: -1"));
  CHECK(inputError([&] { sim::loadMeasuredData(desc); }) == desc + ": noise.joint_deg: '-1' is outside 0 to 10 deg (0: readings exact)");
}

// ---- model files ----

TEST_CASE("absurd input: a model's effect parameter of -5 rad/(N m) is refused, and evaluate writes nothing", "[e2e][absurd]") {
  const std::string dir = test::tempDir("absurd-model-effect");
  const std::string desc = simulated(dir + "/data");
  const std::string model = dir + "/data/truth/model.yaml";
  const std::string text = slurp(model);
  const std::size_t at = text.find("parameters: {c2: ");
  REQUIRE(at != std::string::npos);
  write(model, text.substr(0, at) + "parameters: {c2: -5}}" + text.substr(text.find('\n', at)));
  const std::string line = model + ": effects[0].parameters.c2: '-5' is outside -1 to 1 rad/(N*m) (1e4 times its typical magnitude, 0.0001 rad/(N*m))";
  CHECK(inputError([&] { sim::loadModelFile(model); }) == line);
  checkRefused(runOrbcal(dir, "evaluate --model " + model + " --data " + desc + " -o eval"), line);
  CHECK_FALSE(fs::exists(dir + "/eval"));
}

TEST_CASE("absurd input: model.yaml's parameter list is read and must agree with the model above it", "[e2e][absurd]") {
  const std::string dir = test::tempDir("absurd-model-list");
  simulated(dir);
  const std::string model = dir + "/truth/model.yaml", good = slurp(model);
  REQUIRE_NOTHROW(sim::loadModelFile(model));  // as written by orbcal: it agrees
  const auto message = [&](const std::string& from, const std::string& to) {
    write(model, edited(good, from, to));
    return inputError([&] { sim::loadModelFile(model); });
  };
  const std::string theta1 = "{name: theta1, effect: geometry, value: ";
  CHECK_THAT(message(theta1, theta1 + "1e308, x: "), StartsWith(model + ": parameters[18].x: unknown key (expected one of: name, "));
  const std::size_t v = good.find(theta1) + theta1.size();
  const std::string value = good.substr(v, good.find(',', v) - v);
  CHECK(message(theta1 + value, theta1 + ".nan") == model + ": parameters[18].value: expected a finite number, got '.nan'");
  CHECK(message(theta1 + value, theta1 + "1e308") == model + ": parameters[18].value: '1e308' is outside -3.14159 to 3.14159 rad (half a turn)");
  CHECK(message(theta1 + value, theta1 + "[1, 2]") == model + ": parameters[18].value: expected a number, got a sequence");
  CHECK(message("{name: theta1,", "{name: theta9,") ==
        model + ": parameters[18].name: expected 'theta1' (parameter 19 of the model above), got 'theta9'");
  CHECK_THAT(message("held: false}\n", "held: maybe}\n"), Contains("held: expected true or false, got 'maybe'"));
  CHECK(message("  - {name: base_x,", "  - {name: base_x, effect: base, value: 0, sigma: 0, unit: \"m\", held: false}\n  - {name: base_x,") ==
        model + ": parameters: expected 47 rows, one per parameter of the model above (geometry, registration, effects), got 48");
  // The list may not contradict the effect the model applies.
  const std::size_t c = good.find("{name: c2, effect: compliance, value: ");
  REQUIRE(c != std::string::npos);
  const std::string row = good.substr(c, good.find('\n', c) - c);
  CHECK_THAT(message(row, edited(row, row.substr(row.find("value: "), row.find(", sigma") - row.find("value: ")), "value: 1e-4")),
             StartsWith(model + ": parameters[46].value: 0.0001 differs from the value in effects, "));
}

// ---- error-set files ----

TEST_CASE("absurd input: error-set effect parameters and covariates outside their physical ranges", "[e2e][absurd]") {
  const sim::Arm iiwa = sim::loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  const auto message = [&](const std::string& text) { return inputError([&] { sim::parseTrueArm(iiwa, text, "e.yaml"); }); };
  const std::string head = "format: orbcal-errors-1\ngeometry: zero\n";
  CHECK(message(head + "effects: [{spec: \"cyclic:2\", parameters: {cyclic2_sin1: 1e308, cyclic2_cos1: 0, cyclic2_sin2: 0, cyclic2_cos2: 0}}]\n") ==
        "e.yaml: effects[0].parameters.cyclic2_sin1: '1e308' is outside -3.14159 to 3.14159 rad (half a turn)");
  CHECK(message(head + "effects: [{spec: \"scale:1\", parameters: {s1: 1e308}}]\n") ==
        "e.yaml: effects[0].parameters.s1: '1e308' is outside -2 to 2 1 (1e4 times its typical magnitude, 0.0002 1)");
  CHECK(message(head + "effects: [{spec: distortion, parameters: {dk1: 1e308, dk2: 0, dp1: 0, dp2: 0}}]\n") ==
        "e.yaml: effects[0].parameters.dk1: '1e308' is outside -100 to 100 1 (1e4 times its typical magnitude, 0.01 1)");
  CHECK(message(head + "effects: [{spec: thermal, parameters: {alpha_thermal: 2.3e-5}}]\ncovariates: {temperature: {start_C: 1e6}}\n") ==
        "e.yaml: covariates.temperature.start_C: '1e6' is outside -150 degC to 200 degC (an arm's temperature)");
  CHECK(message(head + "covariates: {temperature: {start_C: 20, rise_C: 1e6}}\n") ==
        "e.yaml: covariates.temperature.rise_C: start_C + rise_C = 1000020 degC is outside -150 degC to 200 degC (an arm's temperature)");
  CHECK(message(head + "covariates: {sample_period_s: 1e308}\n") ==
        "e.yaml: covariates.sample_period_s: '1e308' is outside more than 0 s to 1e6 s (11 days)");
  CHECK(message(head + "covariates: {payload_kg: 1e9}\n") == "e.yaml: covariates.payload_kg: '1e9' is outside 0 kg to 1e6 kg");
  CHECK(message("format: orbcal-errors-1\ngeometry: {random: {length_sigma_mm: 1e308}}\n") ==
        "e.yaml: geometry.random.length_sigma_mm: '1e308' is outside 0 mm to 10000 mm (a length error)");
}

// ---- image datasets ----

TEST_CASE("absurd input: a manifest's joint_noise_deg of -1 or 1e6 and a negative seed are refused", "[e2e][absurd]") {
  const std::string dir = test::tempDir("absurd-manifest");
  const auto message = [&](const std::string& from, const std::string& to) {
    return datasetError(dir, "manifest.yaml", [&](const std::string& p) { editFile(p, from, to); });
  };
  const std::string manifest = dir + "/dataset/manifest.yaml";
  CHECK(message("joint_noise_deg: 0", "joint_noise_deg: -1") ==
        manifest + ": joint_noise_deg: '-1' is outside 0 to 10 deg (1 sigma; 0: readings exact)");
  CHECK(message("joint_noise_deg: 0", "joint_noise_deg: 1e6") ==
        manifest + ": joint_noise_deg: '1e6' is outside 0 to 10 deg (1 sigma; 0: readings exact)");
  CHECK(message("configurations: 0", "configurations: -1") ==
        manifest + ": seeds.configurations: expected a whole number from 0 to 18446744073709551615, got '-1'");
  // calibrate refuses it before writing anything (the manifest's joint noise enters R).
  datasetWithoutImages(dir, 6);
  editFile(manifest, "joint_noise_deg: 0", "joint_noise_deg: 1e6");
  workflow::CalibrateOptions o;
  o.dataset = dir + "/dataset";
  o.out = dir + "/out";
  o.quiet = true;
  CHECK_THAT(inputError([&] { workflow::runCalibrate(o); }), StartsWith(manifest + ": joint_noise_deg: "));
  CHECK_FALSE(fs::exists(o.out));
}

TEST_CASE("absurd input: samples.csv truth columns outside physical ranges, and image paths leaving the folder", "[e2e][absurd]") {
  const std::string dir = test::tempDir("absurd-samples");
  const std::string samples = dir + "/dataset/samples.csv";
  const auto message = [&](const std::string& column, const std::string& value) {
    return datasetError(dir, "samples.csv", [&](const std::string& p) { setCell(p, 1, column, value); });
  };
  CHECK(message("q2_true_rad", "1e308") ==
        samples + ": line 3: q2_true_rad: 1e+308 rad is outside the joint limits of " + dir +
            "/dataset/robot.yaml widened by 60 deg (6 sigma of the largest joint noise), -5.75958653 to 5.75958653 rad");
  CHECK(message("cam_board_x_m", "1e9") == samples + ": line 3: cam_board_x_m: 1e+09 m is outside -10000 m to 10000 m");
  CHECK(message("cam_board_rz_rad", "1e6") ==
        samples + ": line 3: cam_board_rx_rad..cam_board_rz_rad: a rotation vector of 1000000 rad, more than one turn (2 pi rad)");
  CHECK(message("image", "../../../etc/passwd") ==
        samples + ": line 3: image: '../../../etc/passwd' leaves the dataset folder (image paths are relative to it and stay inside)");
  CHECK(message("image", "/etc/passwd") ==
        samples + ": line 3: image: '/etc/passwd' leaves the dataset folder (image paths are relative to it and stay inside)");
  CHECK(message("image", "images/../../x.png") ==
        samples + ": line 3: image: 'images/../../x.png' leaves the dataset folder (image paths are relative to it and stay inside)");
  datasetWithoutImages(dir, 6);
  setCell(samples, 1, "image", "images/../images/1b.png");  // inside: accepted
  CHECK(sim::loadDataset(dir + "/dataset").samples[1].image == "images/../images/1b.png");
}

// ---- robot files ----

TEST_CASE("absurd input: robot com_m of 1e9 m and gravity_m_s2 of 1e9 are refused at their entries", "[e2e][absurd]") {
  const std::string dir = test::tempDir("absurd-robot");
  const std::string robot = dir + "/iiwa7.yaml";
  CHECK(robotError(dir, "scenes/iiwa7.yaml", "com_m: [0, 0.0695, -0.0347]", "com_m: [0, 1e9, -0.0347]") ==
        robot + ": masses.links[0].com_m[1]: '1e9' is outside -10000 m to 10000 m");
  CHECK(robotError(dir, "scenes/iiwa7.yaml", "gravity_m_s2: [0, 0, -9.80665]", "gravity_m_s2: [0, 0, 1e9]") ==
        robot + ": masses.gravity_m_s2[2]: '1e9' is outside -100 m/s^2 to 100 m/s^2 (10 g)");
  // A robot YAML in the urdf convention (what calibrate writes for a URDF arm): the joint origins too.
  const sim::Arm urdf = sim::loadArm(sim::RobotSource{test::sourcePath("tests/data/iiwa7.urdf"), "iiwa_link_0", "iiwa_link_7"});
  write(dir + "/u.yaml", edited(sim::formatArm(urdf), "xyz_m: [0, 0, 0.34000000000000002]", "xyz_m: [0, 0, 1e9]"));
  CHECK(inputError([&] { sim::loadArm(dir + "/u.yaml"); }) == dir + "/u.yaml: joints[1].xyz_m[2]: '1e9' is outside -10000 m to 10000 m");
}

TEST_CASE("absurd input: a URDF joint origin 1e9 m away or a limit of 1e308 is refused naming the joint", "[e2e][absurd][urdf]") {
  const std::string dir = test::tempDir("absurd-urdf");
  const std::string good = slurp(test::sourcePath("tests/data/iiwa7.urdf"));
  const auto message = [&](const std::string& from, const std::string& to) {
    write(dir + "/arm.urdf", edited(good, from, to));
    return inputError([&] { sim::loadArm(sim::RobotSource{dir + "/arm.urdf", "iiwa_link_0", "iiwa_link_7"}); });
  };
  CHECK(message("<origin xyz=\"0 0 0.34\"", "<origin xyz=\"0 0 1e9\"") ==
        dir + "/arm.urdf: joint 'iiwa_joint_2': <origin xyz>: 1e+09 m is outside -10000 m to 10000 m");
  CHECK(message("upper=\"2.0943951023931953\"", "upper=\"1e308\"") ==
        dir + "/arm.urdf: joint 'iiwa_joint_2': <limit upper>: 1e+308 rad is outside -62.83 rad to 62.83 rad (ten turns)");
}

TEST_CASE("absurd input: the base link's inertial origin 1e9 m away is refused though no joint moves it", "[e2e][absurd][urdf]") {
  const std::string dir = test::tempDir("absurd-urdf-base-inertial");
  const std::string good = slurp(test::sourcePath("tests/data/iiwa7_inertial.urdf"));
  write(dir + "/arm.urdf", edited(good, "<origin xyz=\"-0.1 0 0.07\"", "<origin xyz=\"1e9 0 0.07\""));
  checkRefused(runOrbcal(dir, "simulate --robot arm.urdf -o out -n 10 --quiet"),
               "arm.urdf: link 'iiwa_link_0': <inertial>: <origin xyz>: 1e+09 m is outside -10000 m to 10000 m");
  CHECK_FALSE(fs::exists(dir + "/out"));  // no measured data, no truth
}

// ---- simulate's settings ----

// (NaN stops earlier, at the command line: test_fuzz_findings.cpp)
TEST_CASE("absurd input: simulate refuses a payload of -1 kg and an effect value of 1e308, writing nothing", "[e2e][absurd]") {
  const std::string dir = test::tempDir("absurd-simulate");
  checkRefused(runOrbcal(dir, "simulate -o a -n 10 --inject compliance:2 --payload-kg -1"),
               "simulate: payload_kg: value 1, -1 kg, is outside 0 kg to 1e6 kg");
  checkRefused(runOrbcal(dir, "simulate -o b -n 10 --inject compliance:2 --values 1e308"),
               "simulate: effect values: value 1 (c2), 1e+308 rad/(N*m), is outside -1 to 1 rad/(N*m) (1e4 times its typical "
               "magnitude, 0.0001 rad/(N*m))");
  checkRefused(runOrbcal(dir, "simulate -o c -n 10 --error-angle-deg 1e9"),
               "simulate: geometry: an angle error spread of 1e+09 deg is outside 0 deg to 180 deg");
  for (const char* out : {"a", "b", "c"}) CHECK_FALSE(fs::exists(dir + "/" + out));
}

// ---- clear messages ----

TEST_CASE("clear messages: study option values are checked before any task runs", "[e2e][absurd][study]") {
  const std::string dir = test::tempDir("absurd-study-values");
  write(dir + "/s.yaml", "format: orbcal-study-1\njob: experiment\npreset: floor\nseeds: [1, 2]\noptions: {joint-noise-deg: 50}\n");
  checkRefused(runOrbcal(dir, "study run s.yaml -o st --no-plots"),
               "s.yaml: options.joint-noise-deg: --joint-noise-deg: Value 50 not in range 0.000000 to 10.000000 (orbcal experiment would "
               "refuse it)");
  CHECK_FALSE(fs::exists(dir + "/st"));
  // A grid value: named at its own index.
  write(dir + "/g.yaml", "format: orbcal-study-1\njob: experiment\npreset: floor\nseeds: [1]\ngrid: {joint-noise-deg: [0.01, abc]}\n");
  const Run g = runOrbcal(dir, "study run g.yaml -o gt --no-plots");
  CHECK(g.status == 1);
  CHECK_THAT(g.err, StartsWith("orbcal: g.yaml: grid.joint-noise-deg[1]: ") && Contains("abc"));
  CHECK(std::count(g.err.begin(), g.err.end(), '\n') == 1);
  CHECK_FALSE(fs::exists(dir + "/gt"));
}

TEST_CASE("clear messages: a file that cannot be read is named with the file and key that named it", "[e2e][absurd]") {
  const std::string dir = test::tempDir("absurd-cannot-read");
  const std::string desc = simulated(dir + "/data");
  editFile(desc, "\"session_2.csv\"", "\"session_9.csv\"");
  CHECK(inputError([&] { sim::loadMeasuredData(desc); }) ==
        desc + ": files[1]: " + dir + "/data/session_9.csv: cannot read: no such file or not readable");
  editFile(desc, "robot: \"robot.yaml\"", "robot: \"no-robot.yaml\"");
  CHECK(inputError([&] { sim::loadMeasuredData(desc); }) ==
        desc + ": robot: " + dir + "/data/no-robot.yaml: cannot read: no such file or not readable");
  const std::string model = dir + "/data/truth/model.yaml";
  editFile(model, "robot: robot.yaml", "robot: gone.yaml");
  CHECK(inputError([&] { sim::loadModelFile(model); }) ==
        model + ": robot: " + dir + "/data/truth/gone.yaml: cannot read: no such file or not readable");
  CHECK(datasetError(dir, "manifest.yaml", [](const std::string& p) { editFile(p, "samples: samples.csv", "samples: rows.csv"); }) ==
        dir + "/dataset/manifest.yaml: samples: " + dir + "/dataset/rows.csv: cannot read: no such file or not readable");
}

TEST_CASE("clear messages: orbcal's own line breaks never print as a literal \\x0A", "[e2e][absurd]") {
  // A dataset whose images are all missing: calibrate's refusal quotes the image summary, which a
  // report prints on several lines.
  const std::string dir = test::tempDir("absurd-one-line");
  datasetWithoutImages(dir, 6);
  workflow::CalibrateOptions o;
  o.dataset = dir + "/dataset";
  o.out = dir + "/out";
  o.quiet = true;
  const std::string msg = inputError([&] { workflow::runCalibrate(o); });
  CHECK(msg.find("\\x0A") == std::string::npos);
  CHECK_THAT(msg, Contains("(6 images: 0 used, 0 not found, 0 rejected, 6 unreadable; 6 x unreadable"));
  vision::MeasurementSummary s;
  s.total = 2;
  s.found = 1;
  s.unreadable = 1;
  s.median_rms_px = 0.25;
  s.reasons["unreadable: no file"] = 1;
  CHECK(vision::summaryLine(s) == "2 images: 1 used, 0 not found, 0 rejected, 1 unreadable; median reprojection RMS of the used ones: "
                                  "0.250 px; 1 x unreadable: no file");
  CHECK(vision::formatSummary(s) == "2 images: 1 used, 0 not found, 0 rejected, 1 unreadable\n  median reprojection RMS of the used "
                                    "ones: 0.250 px\n  1 x unreadable: no file\n");
}

TEST_CASE("clear messages: a figure that fails for another reason than a missing matplotlib fails the run, saying why",
          "[e2e][absurd]") {
  const std::string dir = test::tempDir("absurd-figures");
  const std::string desc = simulated(dir + "/data", 60);
  // A plot script that fails as a full disk makes matplotlib fail.
  write(dir + "/full.sh", "#!/bin/sh\necho 'Traceback (most recent call last):'\necho \"OSError: [Errno 28] No space left on device: '$5'\"\nexit 1\n");
  write(dir + "/nomodule.sh", "#!/bin/sh\necho \"ModuleNotFoundError: No module named 'matplotlib'\"\nexit 1\n");
  fs::permissions(dir + "/full.sh", fs::perms::owner_all);
  fs::permissions(dir + "/nomodule.sh", fs::perms::owner_all);
  const Run full = runOrbcal(dir, "diagnose " + desc + " -o diag", "ORBCAL_PYTHON=/bin/sh ORBCAL_PLOT_SCRIPT=" + dir + "/full.sh");
  INFO(full.err);
  CHECK(full.status == 1);
  CHECK_THAT(full.err, StartsWith("orbcal: figure samples.png not drawn: OSError: [Errno 28] No space left on device"));
  CHECK(full.err.find("matplotlib") == std::string::npos);
  CHECK(std::count(full.err.begin(), full.err.end(), '\n') == 1);
  CHECK_FALSE(fs::exists(dir + "/diag/diagnosis.json"));  // the run failed: no result left that looks valid
  // Without matplotlib, figures stay optional: a warning, and the run completes.
  const Run missing = runOrbcal(dir, "diagnose " + desc + " -o diag2", "ORBCAL_PYTHON=/bin/sh ORBCAL_PLOT_SCRIPT=" + dir + "/nomodule.sh");
  CHECK(missing.status == 0);
  CHECK_THAT(missing.err, Contains("not drawn (python3 with matplotlib is needed): ModuleNotFoundError"));
}
