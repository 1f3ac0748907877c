// `orbcal simulate` -> `orbcal calibrate DESCRIPTION` -> `orbcal evaluate` through the tools library:
// the truth file predicts its own data to the noise; a calibration that would predict held-out
// samples worse than the nominal arm is refused and writes no model; bad model files name the key.
#include <sys/wait.h>

#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "orbcal/workflow/measured.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/model_io.hpp"
#include "test_util.hpp"

using namespace orbcal;

namespace {
sim::SimulationSpec spec(int samples, std::uint64_t seed) {
  sim::SimulationSpec s;
  s.samples = samples;
  s.sessions = 2;
  s.payload_kg = {0.0, 1.25};
  s.seed = seed;
  return s;
}
}  // namespace

TEST_CASE("simulate, calibrate with the hidden effect, evaluate on a second simulated run", "[e2e][measured]") {
  const std::string dir = test::tempDir("measured-tools");
  sim::SimulationSpec s = spec(200, 3);
  s.effects = {sim::Compliance{{1}}};
  const sim::SimulatedData d = workflow::runSimulate(sim::loadArm(test::sourcePath("scenes/iiwa7.yaml")), s, dir + "/data");
  REQUIRE(std::filesystem::exists(dir + "/data/truth/model.yaml"));

  workflow::MeasuredCalibrateOptions o;
  o.description = d.data.description;
  o.effects = {"compliance:2"};
  o.out = dir + "/cal";
  const workflow::MeasuredCalibrateResult r = workflow::runMeasuredCalibrate(o);
  REQUIRE_FALSE(r.worse);
  // Held-out error of the calibrated model: the tracker noise (0.05 mm per axis: 0.087 mm RMS of the
  // 3-D error) plus a small estimation error; 0.12 mm allows 40% for the latter.
  CHECK(r.heldout_after.position_rms_m < 0.12e-3);
  CHECK(r.heldout_before.position_rms_m > 5.0 * r.heldout_after.position_rms_m);

  // A second run of the same arm from another tracker placement (other configurations and frames,
  // its description says so: per-session base; the same true geometry and effect values).
  sim::SimulationSpec s2 = s;
  s2.seed = 4;
  s2.base = sim::FrameSharing::kPerSession;
  s2.effect_values = d.p_true.tail(1);
  const sim::SimulatedData d2 = workflow::runSimulate(sim::loadArm(test::sourcePath("scenes/iiwa7.yaml")), s2, dir + "/data2");
  const workflow::EvaluateResult truth = workflow::runEvaluate(dir + "/data/truth/model.yaml", d2.data.description, dir + "/eval-truth");
  const workflow::EvaluateResult fitted = workflow::runEvaluate(r.model_path, d2.data.description, dir + "/eval-fit");
  CHECK(truth.fit.residuals.position_rms_m < 0.1e-3);
  CHECK(fitted.fit.residuals.position_rms_m < 0.12e-3);
}

TEST_CASE("a calibration that predicts held-out samples worse is refused and writes no model", "[e2e][measured][export]") {
  const std::string dir = test::tempDir("measured-worse");
  sim::SimulationSpec s = spec(40, 4);
  s.sessions = 1;
  s.payload_kg = {0.0};
  s.geometry.name = "zero";  // the nominal arm is the truth: every added parameter can only fit noise
  const sim::SimulatedData d = workflow::runSimulate(sim::loadArm(test::sourcePath("scenes/iiwa7.yaml")), s, dir + "/data");
  workflow::MeasuredCalibrateOptions o;
  o.description = d.data.description;
  o.effects = {"cyclic:1,2,3,4,5,6/3", "backlash:1,2,3,4,5,6"};
  o.out = dir + "/cal";
  const workflow::MeasuredCalibrateResult r = workflow::runMeasuredCalibrate(o);
  CHECK(r.worse);
  CHECK(r.model_path.empty());
  const char* files[] = {"model.yaml", "robot.yaml", "robot_calibrated.urdf", "frames.yaml", "effects.yaml"};
  for (const char* name : files) CHECK_FALSE(std::filesystem::exists(dir + "/cal/" + name));
  CHECK(test::slurp(r.report_path).find("WORSE") != std::string::npos);
  // report.html says so first too (the verdict, before any section), and claims no acceptance.
  const std::string html = test::slurp(dir + "/cal/report.html");
  CHECK(html.find("<p class=\"verdict\"><strong>The calibrated model predicts the held-out samples WORSE") < html.find("<h2>"));
  CHECK(html.find("Accepted") == std::string::npos);
  o.accept_worse = true;
  CHECK_FALSE(workflow::runMeasuredCalibrate(o).model_path.empty());
  for (const char* name : files) CHECK(std::filesystem::exists(dir + "/cal/" + name));
}

TEST_CASE("model files: errors name the file and the key", "[e2e][measured]") {
  const std::string dir = test::tempDir("model-file");
  sim::SimulationSpec s = spec(20, 1);
  s.effects = {sim::Scale{{0}}};
  workflow::runSimulate(sim::loadArm(test::sourcePath("scenes/iiwa7.yaml")), s, dir);
  const std::string good = test::slurp(dir + "/truth/model.yaml");
  const auto messageFor = [&](const std::string& from, const std::string& to) {
    std::string text = good;
    const auto at = text.find(from);
    REQUIRE(at != std::string::npos);
    text.replace(at, from.size(), to);
    { std::ofstream(dir + "/truth/bad.yaml") << text; }
    try {
      sim::loadModelFile(dir + "/truth/bad.yaml");
    } catch (const sim::InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  CHECK_THAT(messageFor("format: orbcal-model-2", "format: orbcal-model-9"), Catch::Contains("bad.yaml") && Catch::Contains("format"));
  CHECK_THAT(messageFor("{s1: ", "{s9: "), Catch::Contains("bad.yaml") && Catch::Contains("parameters.s1"));
  CHECK_THAT(messageFor("base: shared", "base: sometimes"), Catch::Contains("registration.base"));
  CHECK_THAT(messageFor("sessions: 2", "sessions: 3"), Catch::Contains("registration.flange_T_marker"));
  CHECK(sim::loadModelFile(dir + "/truth/model.yaml").model.effects.size() == 1);
}

TEST_CASE("measured data: a fit inconsistent with the given noise is refused, with the hidden effect modelled it is not",
          "[e2e][measured]") {
  const std::string dir = test::tempDir("measured-inconsistent");
  sim::SimulationSpec s = spec(120, 7);
  s.effects = {sim::Compliance{{1}}};  // joint 2's compliance, drawn from the seed: hidden in the data
  const sim::SimulatedData d = workflow::runSimulate(sim::loadArm(test::sourcePath("scenes/iiwa7.yaml")), s, dir + "/data");
  workflow::MeasuredCalibrateOptions o;
  o.description = d.data.description;
  o.noise_position_m = s.noise_position_m;  // the tracker's true noise, given
  o.noise_rotation_rad = s.noise_rotation_rad;
  o.out = dir + "/geometry-only";
  const workflow::MeasuredCalibrateResult bad = workflow::runMeasuredCalibrate(o);
  CHECK(bad.inconsistent);  // geometry alone cannot absorb the compliance: residuals far above the noise
  CHECK(bad.consistency_p < 1e-3);
  CHECK(bad.fit.chi2 > 2.0 * bad.fit.dof);
  CHECK(bad.model_path.empty());
  CHECK_FALSE(std::filesystem::exists(dir + "/geometry-only/model.yaml"));
  const std::string report = test::slurp(bad.report_path);
  const std::size_t said = report.find("**The fit is inconsistent with the given measurement noise: chi-square");
  REQUIRE(said != std::string::npos);
  CHECK(said < report.find("Description `"));  // said first, before anything else of the report
  o.effects = {"compliance:2"};
  o.out = dir + "/with-compliance";
  const workflow::MeasuredCalibrateResult good = workflow::runMeasuredCalibrate(o);
  CHECK_FALSE(good.inconsistent);  // chi-square(dof) at the true noise: p >= 0.001 but for 1 run in 1000
  CHECK(good.fit.chi2 / good.fit.dof == Approx(1.0).margin(0.2));
  CHECK_FALSE(good.model_path.empty());
  // --accept-worse writes the inconsistent one, and the report still says so first.
  o.effects.clear();
  o.accept_worse = true;
  o.out = dir + "/accepted";
  const workflow::MeasuredCalibrateResult accepted = workflow::runMeasuredCalibrate(o);
  CHECK_FALSE(accepted.model_path.empty());
  CHECK(test::slurp(accepted.report_path).find("model.yaml was written because --accept-worse was given") != std::string::npos);
}

TEST_CASE("measured data name a URDF's chain: robot {file, base_link, tip_link} is the arm the data were simulated on",
          "[e2e][measured][urdf]") {
  const std::string dir = test::tempDir("measured-urdf");
  const std::string urdf = test::sourcePath("tests/data/iiwa7.urdf");
  // Tip iiwa_link_7, not the URDF's only leaf (iiwa_link_ee, 0.126 m further): a description that
  // ignored tip_link would put the flange elsewhere.
  const sim::Arm arm = sim::loadArm(sim::RobotSource{urdf, "iiwa_link_0", "iiwa_link_7"});
  const sim::SimulatedData d = workflow::runSimulate(arm, spec(40, 5), dir + "/data");
  // The description as a user with the URDF writes it: robot names the chain instead of robot.yaml.
  const std::string text = test::slurp(d.data.description);
  const std::size_t at = text.find("\nrobot: ");
  REQUIRE(at != std::string::npos);
  const std::string head = text.substr(0, at + 1), tail = text.substr(text.find('\n', at + 1));
  const auto describe = [&](const std::string& robot, const std::string& name) {
    test::write(dir + "/data/" + name, head + "robot: " + robot + tail);
    return dir + "/data/" + name;
  };
  const sim::MeasuredData yaml = sim::loadMeasuredData(d.data.description);
  const sim::MeasuredData chain =
      sim::loadMeasuredData(describe("{file: '" + urdf + "', base_link: iiwa_link_0, tip_link: iiwa_link_7}", "urdf.yaml"));
  REQUIRE(chain.arm.convention == sim::DhConvention::kUrdf);
  CHECK(chain.arm.urdf.tip_link == "iiwa_link_7");
  CHECK(chain.poses.size() == yaml.poses.size());
  for (const Eigen::VectorXd& q : test::randomConfigs(arm, 50, 11)) {
    const Eigen::Isometry3d a = sim::forwardKinematics(yaml.arm, q), b = sim::forwardKinematics(chain.arm, q);
    CHECK((a.translation() - b.translation()).norm() < 1e-12);
    CHECK((a.linear() - b.linear()).norm() < 1e-12);
  }
  // Without tip_link the chain runs to the only leaf: a different flange.
  const sim::MeasuredData leaf = sim::loadMeasuredData(describe("{file: '" + urdf + "'}", "leaf.yaml"));
  CHECK((sim::forwardKinematics(leaf.arm, Eigen::VectorXd::Zero(7)).translation() -
         sim::forwardKinematics(chain.arm, Eigen::VectorXd::Zero(7)).translation())
            .norm() == Approx(0.126).margin(1e-12));

  // Links for a robot YAML, an unknown link and an unknown key name the description and the key.
  const std::string links_for_yaml = describe("{file: robot.yaml, tip_link: iiwa_link_7}", "bad1.yaml");
  CHECK_THROWS_WITH(sim::loadMeasuredData(links_for_yaml),
                    Catch::Contains(links_for_yaml) && Catch::Contains("robot") &&
                        Catch::Contains("base_link and tip_link choose a chain in a URDF"));
  const std::string no_link = describe("{file: '" + urdf + "', tip_link: iiwa_link_9}", "bad2.yaml");
  CHECK_THROWS_WITH(sim::loadMeasuredData(no_link), Catch::Contains(urdf) && Catch::Contains("iiwa_link_9"));
  const std::string unknown = describe("{file: '" + urdf + "', tip: iiwa_link_7}", "bad3.yaml");
  CHECK_THROWS_WITH(sim::loadMeasuredData(unknown), Catch::Contains(unknown) && Catch::Contains("tip"));
}

TEST_CASE("orbcal simulate: the built-in iiwa7 from any folder, a URDF's chain by --base-link and --tip-link", "[e2e][measured][urdf]") {
  const std::string dir = test::tempDir("simulate-cli");
  const auto run = [&](const std::string& args) {  // from `dir`, not the source tree: no relative scenes/ path
    const int rc = std::system(("cd '" + dir + "' && " + std::string(ORBCAL_BINARY) + " " + args + " >>'" + dir + "/log.txt' 2>&1").c_str());
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  };
  REQUIRE(run("simulate -o builtin -n 30 --sessions 1") == 0);
  const sim::MeasuredData builtin = sim::loadMeasuredData(dir + "/builtin/measurements.yaml");
  const sim::Arm iiwa7 = sim::loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  CHECK(builtin.arm.name == iiwa7.name);
  CHECK(builtin.has_torque);  // the built-in file keeps its masses
  const Eigen::VectorXd q = test::randomConfigs(iiwa7, 1, 3)[0];
  CHECK((sim::forwardKinematics(builtin.arm, q).translation() - sim::forwardKinematics(iiwa7, q).translation()).norm() < 1e-12);

  REQUIRE(run("simulate -o urdf -n 30 --sessions 1 --robot '" + test::sourcePath("tests/data/iiwa7.urdf") +
              "' --base-link iiwa_link_0 --tip-link iiwa_link_7") == 0);
  const sim::MeasuredData urdf = sim::loadMeasuredData(dir + "/urdf/measurements.yaml");
  CHECK(urdf.arm.convention == sim::DhConvention::kUrdf);
  CHECK(urdf.arm.urdf.tip_link == "iiwa_link_7");
  CHECK(run("simulate -o bad -n 30 --robot '" + test::sourcePath("tests/data/iiwa7.urdf") + "' --tip-link no_such_link") == 1);
  CHECK(test::slurp(dir + "/log.txt").find("no_such_link") != std::string::npos);
}
