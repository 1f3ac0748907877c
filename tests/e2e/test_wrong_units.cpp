// Measured data read in the wrong unit or convention, or against the wrong robot file, are refused by
// `orbcal calibrate`, `diagnose` and `evaluate` (calib/plausibility.hpp), whether the description states
// the noise or leaves it to be estimated: exit 1, one line naming the description, the key and what
// fits better, and no result file left behind.
#include <sys/wait.h>

#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>

#include "orbcal/workflow/measured.hpp"
#include "orbcal/calib/plausibility.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/measured.hpp"
#include "run_orbcal.hpp"
#include "test_util.hpp"

using namespace orbcal;

namespace {

using Run = test::OrbcalRun;
using test::runOrbcal;

using test::edited;

/// The description without its noise line (the noise then estimated from the residuals).
std::string withoutNoise(const std::string& text) {
  const std::size_t at = text.find("\nnoise: {");
  REQUIRE(at != std::string::npos);
  return text.substr(0, at + 1) + text.substr(text.find('\n', at + 1) + 1);
}

/// No file of a result that looks valid in `folder` (absent or empty of them).
void checkNoResult(const std::string& folder) {
  for (const char* name : {"model.yaml", "report.md", "report.html", "diagnosis.json", "diagnosis.md", "evaluation.json", "evaluation.md"}) {
    CHECK_FALSE(std::filesystem::exists(folder + "/" + name));
  }
}

struct Case {
  std::string name;         ///< description file name
  std::string key;          ///< the key the message must name
  std::string alternative;  ///< the other reading it must say fits
};

/// calibrate, diagnose (unless `diagnose` is false) and evaluate of `desc` are refused with one line
/// naming it, `c.key` and the alternative.
void checkRefused(const std::string& dir, const std::string& desc, const Case& c, const std::string& truth_model, bool diagnose = true) {
  const std::string tag = std::filesystem::path(desc).stem().string();
  const std::vector<std::pair<std::string, std::string>> commands = {
      {"calibrate", "calibrate '" + desc + "' -o cal-" + tag},
      {"diagnose", "diagnose '" + desc + "' --quiet -o diag-" + tag},
      {"evaluate", "evaluate --model '" + truth_model + "' --data '" + desc + "' -o eval-" + tag}};
  for (const auto& [command, args] : commands) {
    if (command == "evaluate" && c.alternative.empty()) continue;  // a model file brings its own geometry
    if (command == "diagnose" && !diagnose) continue;
    CAPTURE(command, desc);
    const Run r = runOrbcal(dir, args);
    CAPTURE(r.out, r.err);
    CHECK(r.status == 1);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);  // one line
    CHECK(r.err.find(desc) != std::string::npos);
    CHECK(r.err.find(c.key) != std::string::npos);
    CHECK(r.err.find("likely causes") != std::string::npos);
    if (!c.alternative.empty()) CHECK(r.err.find("with " + c.alternative + " the nominal arm's registration residual is") != std::string::npos);
    checkNoResult(dir + "/" + args.substr(args.rfind("-o ") + 3));
  }
}

}  // namespace

TEST_CASE("wrong units and quaternion order are refused by calibrate, diagnose and evaluate, noise stated or estimated",
          "[e2e][measured][plausibility]") {
  const std::string dir = test::tempDir("wrong-units");
  sim::SimulationSpec s;
  s.samples = 60;
  s.seed = 21;
  const sim::SimulatedData d = workflow::runSimulate(sim::loadArm(test::sourcePath("scenes/iiwa7.yaml")), s, dir + "/data");
  const std::string truth = dir + "/data/truth/model.yaml";
  const std::string good = test::slurp(d.data.description);

  // The same samples in millimetres, declared metres: the writer always says length_unit: m.
  sim::MeasuredData in_mm = d.data;
  for (sim::MeasuredPose& p : in_mm.poses) p.world_T_marker.translation() *= 1000.0;
  sim::writeMeasuredData(in_mm, dir + "/data_mm", dir + "/data/robot.yaml");
  const std::string mm_as_m = test::slurp(dir + "/data_mm/measurements.yaml");

  const std::vector<std::pair<Case, std::string>> cases = {
      {{"m_as_mm", "pose.length_unit (mm)", "pose.length_unit: m"}, edited(good, "length_unit: m}", "length_unit: mm}")},
      {{"rad_as_deg", "joints.unit (deg)", "joints.unit: rad"}, edited(good, "unit: rad}", "unit: deg}")},
      {{"xyzw_as_wxyz", "pose.quaternion_wxyz", "the quaternion columns read as x, y, z, w"},
       edited(good, "quaternion_wxyz: [qw, qx, qy, qz]", "quaternion_wxyz: [qx, qy, qz, qw]")},
      {{"mm_as_m", "pose.length_unit (m)", "pose.length_unit: mm"}, mm_as_m}};
  for (const auto& [c, text] : cases) {
    const std::string folder = c.name == "mm_as_m" ? dir + "/data_mm" : dir + "/data";
    for (const bool stated : {true, false}) {
      const std::string desc = folder + "/" + c.name + (stated ? "_stated" : "_estimated") + ".yaml";
      test::write(desc, stated ? text : withoutNoise(text));
      REQUIRE(sim::loadMeasuredData(desc).noise_position_m.has_value() == stated);
      checkRefused(dir, desc, c, truth);
    }
  }

  // The data as they are pass the same checks: calibrate accepts, evaluate predicts to the noise.
  const Run cal = runOrbcal(dir, "calibrate '" + d.data.description + "' -o cal-good");
  CAPTURE(cal.out, cal.err);
  CHECK(cal.status == 0);
  CHECK(std::filesystem::exists(dir + "/cal-good/model.yaml"));
  const Run eval = runOrbcal(dir, "evaluate --model '" + truth + "' --data '" + d.data.description + "' -o eval-good");
  CAPTURE(eval.out, eval.err);
  CHECK(eval.status == 0);
}

TEST_CASE("a wrong robot file whose calibration would move a link beyond its tolerance is refused by calibrate",
          "[e2e][measured][plausibility]") {
  const std::string dir = test::tempDir("wrong-robot");
  sim::SimulationSpec s;
  s.samples = 60;
  s.seed = 22;
  sim::Arm arm = sim::loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  const sim::SimulatedData d = workflow::runSimulate(arm, s, dir + "/data");
  // The robot file of an arm whose third link (d3 = 0.4 m) is 30 mm longer: the registration residual
  // stays within its bound, but the fit must shorten d3 by 30 mm, beyond 5 % of the link (20 mm).
  REQUIRE(arm.joints[2].d_m == Approx(0.4));
  arm.joints[2].d_m += 0.03;
  test::write(dir + "/data/robot_long.yaml", sim::formatArm(arm, "iiwa7 with its third link 30 mm too long"));
  const calib::PlausibilityBounds bounds = calib::plausibilityBounds(arm);
  REQUIRE(bounds.lengthMove(arm, sim::geometryBlock(arm).params[static_cast<std::size_t>(sim::paramIndex(arm, 2, sim::kD))]) < 0.03);
  const std::string good = test::slurp(d.data.description);
  const std::string text = edited(good, "robot: \"robot.yaml\"", "robot: \"robot_long.yaml\"");
  for (const bool stated : {true, false}) {
    const std::string desc = dir + "/data/long_" + (stated ? "stated" : "estimated") + ".yaml";
    test::write(desc, stated ? text : withoutNoise(text));
    const sim::MeasuredData data = sim::loadMeasuredData(desc);
    REQUIRE(data.noise_position_m.has_value() == stated);
    CHECK(calib::nominalRegistration(data).position_rms_m < bounds.position_rms_m);
    // calibrate alone: diagnose holds its base model to no geometric bound, since that model lacks by
    // design the causes whose share its lengths absorb.
    checkRefused(dir, desc, {"long", "moves d3 by", ""}, "", false);
    CHECK(test::slurp(dir + "/stderr.txt").find("robot: " + dir + "/data/robot_long.yaml") != std::string::npos);
  }
}

TEST_CASE("messages point at the fix: a missing column names its key, degrees read as rad joints.unit, an x, y, z, w "
          "quaternion the key to write", "[e2e][measured][badinput]") {
  const std::string dir = test::tempDir("messages-fix");
  sim::SimulationSpec s;
  s.samples = 20;
  s.seed = 23;
  const sim::SimulatedData d = workflow::runSimulate(sim::loadArm(test::sourcePath("scenes/iiwa7.yaml")), s, dir + "/data");
  const std::string good = test::slurp(d.data.description);
  // The same samples with the joints in degrees, the description still saying rad.
  sim::MeasuredData in_deg = d.data;
  for (sim::MeasuredPose& p : in_deg.poses) p.sample.q_rad *= sim::kRadToDeg;
  sim::writeMeasuredData(in_deg, dir + "/data_deg", dir + "/data/robot.yaml");
  test::write(dir + "/data/renamed.yaml", edited(good, "columns: [q1_rad, q2_rad, q3_rad,", "columns: [q1_rad, q2_rad, joint3,"));
  test::write(dir + "/data/xyzw.yaml", edited(good, "quaternion_wxyz: [qw, qx, qy, qz]", "quaternion_xyzw: [qx, qy, qz, qw]"));
  const std::vector<std::pair<std::string, std::string>> cases = {
      {dir + "/data/renamed.yaml", "missing column 'joint3', which joints.columns[2] of " + dir + "/data/renamed.yaml names"},
      {dir + "/data/xyzw.yaml", "pose.quaternion_xyzw: orbcal reads a quaternion's columns in w, x, y, z order: list the same "
                                "columns in that order under quaternion_wxyz (here quaternion_wxyz: [qw, qx, qy, qz])"},
      {dir + "/data_deg/measurements.yaml",
       "read in deg it is within them: if the columns hold degrees, write joints.unit: deg in " + dir + "/data_deg/measurements.yaml"}};
  for (const auto& [desc, message] : cases) {
    CAPTURE(desc);
    const Run r = runOrbcal(dir, "calibrate '" + desc + "' -o cal");
    CAPTURE(r.out, r.err);
    CHECK(r.status == 1);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);  // one line
    CHECK(r.err.find(message) != std::string::npos);
    checkNoResult(dir + "/cal");
  }
}
