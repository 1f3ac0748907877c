// A measured-data calibration's files for programs outside orbcal: robot_calibrated.urdf gives the
// flange pose robot.yaml gives (a URDF arm with the description's links, a DH arm from the URDF's
// root to its only leaf), frames.yaml holds model.yaml's frames, effects.yaml the model's effects
// (read back by sim::loadEffectsFile and by the reference implementation examples/apply_effects.py).
// That a refused calibration writes none of them: tests/e2e/test_measured_tools.cpp.
#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/export.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/model_io.hpp"
#include "orbcal/workflow/measured.hpp"
#include "run_orbcal.hpp"
#include "test_util.hpp"

using namespace orbcal;
using Catch::Matchers::Contains;

namespace {

// Rebuilding the chain from exact decimal origins leaves round-off of ~1e-15 per link; 1e-9 m and
// 1e-9 rad are "the same pose" for any use.
constexpr double kSamePoseM = 1e-9, kSamePoseRad = 1e-9;

sim::SimulationSpec spec(int samples, std::uint64_t seed, std::vector<sim::Effect> effects) {
  sim::SimulationSpec s;
  s.samples = samples;
  s.sessions = 2;
  s.payload_kg = {0.0, 1.25};
  s.seed = seed;
  s.effects = std::move(effects);
  return s;
}

/// The description `d` with its robot line replaced by `robot`, written as `name` beside it.
std::string describeRobot(const std::string& description, const std::string& robot, const std::string& name) {
  const std::string text = test::slurp(description);
  const std::size_t at = text.find("\nrobot: ");
  REQUIRE(at != std::string::npos);
  const std::string path = std::filesystem::path(description).parent_path().string() + "/" + name;
  test::write(path, text.substr(0, at + 1) + "robot: " + robot + text.substr(text.find('\n', at + 1)));
  return path;
}

/// FK of the calibrated URDF (with `links`) against robot.yaml at 50 seeded configurations, in the library
/// and, at one configuration, through `orbcal fk` (the same text after its first line, which names the arm).
void checkUrdfMatchesYaml(const std::string& cal, const std::string& links, const sim::Arm& nominal) {
  const sim::Arm yaml = sim::loadArm(cal + "/robot.yaml");
  const std::filesystem::path urdf_path = cal + "/robot_calibrated.urdf";
  sim::RobotSource source{urdf_path.string(), "", ""};
  if (!links.empty()) source = {urdf_path.string(), yaml.urdf.base_link, yaml.urdf.tip_link};
  const sim::Arm urdf = sim::loadArm(source);
  double dp = 0.0, dr = 0.0;
  for (const Eigen::VectorXd& q : test::randomConfigs(yaml, 50, 31)) {
    const Eigen::Isometry3d a = sim::forwardKinematics(yaml, q), b = sim::forwardKinematics(urdf, q);
    dp = std::max(dp, (a.translation() - b.translation()).norm());
    dr = std::max(dr, Eigen::AngleAxisd(Eigen::Quaterniond(a.linear().transpose() * b.linear())).angle());
  }
  CHECK(dp < kSamePoseM);
  CHECK(dr < kSamePoseRad);
  // The calibration moved the flange: a URDF of the nominal arm would not pass the check above.
  const Eigen::VectorXd q0 = test::randomConfigs(yaml, 1, 2).front();
  CHECK((sim::forwardKinematics(nominal, q0).translation() - sim::forwardKinematics(yaml, q0).translation()).norm() > 1e-4);

  const std::string angles = "10 -20 30 -40 50 -60 70";
  const test::OrbcalRun from_yaml = test::runOrbcal(cal, "fk --robot robot.yaml " + angles);
  const test::OrbcalRun from_urdf = test::runOrbcal(cal, "fk --robot robot_calibrated.urdf " + links + " " + angles);
  REQUIRE(from_yaml.status == 0);
  REQUIRE(from_urdf.status == 0);
  CHECK(from_urdf.out.substr(from_urdf.out.find('\n')) == from_yaml.out.substr(from_yaml.out.find('\n')));
}

/// frames.yaml against model.yaml's registration: the same frames, written exactly.
void checkFramesFile(const std::string& cal) {
  const sim::LoadedModel m = sim::loadModelFile(cal + "/model.yaml");
  const sim::ConfigNode frames = sim::ConfigNode::load(cal + "/frames.yaml");
  CHECK(frames["format"].asString() == "orbcal-frames-1");
  CHECK(frames["sessions"].asInt() == m.model.sessions);
  for (const auto& [key, list] : {std::pair<const char*, const std::vector<Eigen::Isometry3d>*>{"world_T_base", &m.model.world_T_base},
                                  {"flange_T_marker", &m.model.flange_T_marker}}) {
    CAPTURE(key);
    REQUIRE(frames[key]["frames"].size() == list->size());
    for (std::size_t k = 0; k < list->size(); ++k) {
      const sim::ConfigNode f = frames[key]["frames"][k];
      // model.yaml writes xyz and rpy (deg), frames.yaml the matrix: equal to round-off.
      CHECK((f["xyz_m"].asVector(3) - (*list)[k].translation()).norm() < 1e-12);
      Eigen::Matrix3d R;
      for (int r = 0; r < 3; ++r) R.row(r) = f["matrix"][static_cast<std::size_t>(r)].asVector(4).head(3).transpose();
      CHECK((R - (*list)[k].linear()).norm() < 1e-12);
    }
  }
  // A tracker's base sits metres from the robot: a file of identities would fail.
  CHECK(m.model.world_T_base.front().translation().norm() > 0.1);
}

std::string pythonInterpreter() {
  const char* python = std::getenv("ORBCAL_PYTHON");
  return python ? python : (access("/usr/bin/python3", X_OK) == 0 ? "/usr/bin/python3" : "python3");
}

/// effects.yaml read back by sim::loadEffectsFile and by examples/apply_effects.py: the joint corrections
/// of model.yaml at 50 seeded samples.
void checkEffectsFile(const std::string& cal, int joints) {
  const sim::LoadedModel m = sim::loadModelFile(cal + "/model.yaml");
  const sim::LoadedEffects e = sim::loadEffectsFile(cal + "/effects.yaml");
  auto rng = sim::makeRng(41);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::ostringstream csv;
  for (const char* name : {"q", "tau", "dir"}) {
    for (int j = 1; j <= joints; ++j) csv << (csv.tellp() > 0 ? "," : "") << name << j;
  }
  csv << "\n";
  std::vector<Eigen::VectorXd> expected;
  for (int k = 0; k < 50; ++k) {
    sim::JointSample s;
    s.q_rad = Eigen::VectorXd::NullaryExpr(joints, [&] { return 2.0 * u(rng); });
    s.tau_Nm = Eigen::VectorXd::NullaryExpr(joints, [&] { return 60.0 * u(rng); });
    s.direction = Eigen::VectorXd::NullaryExpr(joints, [&] { return u(rng) < 0.0 ? -1.0 : 1.0; });
    expected.push_back(sim::jointCorrections(m.model, m.p, s));
    REQUIRE(expected.back().cwiseAbs().maxCoeff() > 1e-6);  // the fitted effect moves a joint
    CHECK(sim::jointCorrections(e.model, e.p, s) == expected.back());
    std::string row;
    for (const Eigen::VectorXd* v : {&s.q_rad, &s.tau_Nm, &s.direction}) {
      for (int j = 0; j < joints; ++j) row += (row.empty() ? "" : ",") + sim::exactNumber((*v)[j]);
    }
    csv << row << "\n";
  }
  test::write(cal + "/../samples.csv", csv.str());
  const std::string out = cal + "/../apply_effects.csv";
  const std::string command = "'" + pythonInterpreter() + "' '" + test::sourcePath("examples/apply_effects.py") + "' '" + cal +
                              "/effects.yaml' '" + cal + "/../samples.csv' > '" + out + "'";
  REQUIRE(std::system(command.c_str()) == 0);
  std::istringstream lines(test::slurp(out));
  std::string line;
  std::getline(lines, line);
  CHECK(line.rfind("dq1,dq2", 0) == 0);
  for (const Eigen::VectorXd& dq : expected) {
    REQUIRE(std::getline(lines, line));
    std::istringstream cells(line);
    std::string cell;
    for (int j = 0; j < joints && std::getline(cells, cell, ','); ++j) {
      // The same formulas in double precision, terms summed in another order: round-off only.
      CHECK(std::abs(std::stod(cell) - dq[j]) < 1e-15);
    }
  }
}

}  // namespace

TEST_CASE("a measured-data calibration of a URDF arm writes a URDF with the calibrated model's FK, frames and effects files",
          "[e2e][measured][urdf][export]") {
  const std::string dir = test::tempDir("export-urdf");
  const std::string urdf = test::sourcePath("tests/data/iiwa7.urdf");
  const sim::Arm arm = sim::loadArm(sim::RobotSource{urdf, "iiwa_link_0", "iiwa_link_7"});
  const sim::SimulatedData d = workflow::runSimulate(arm, spec(120, 5, {sim::Cyclic{{2}, 2}}), dir + "/data");
  workflow::MeasuredCalibrateOptions o;
  o.description = describeRobot(d.data.description, "{file: '" + urdf + "', base_link: iiwa_link_0, tip_link: iiwa_link_7}", "urdf.yaml");
  o.effects = {"cyclic:3"};
  o.out = dir + "/cal";
  const workflow::MeasuredCalibrateResult r = workflow::runMeasuredCalibrate(o);
  REQUIRE_FALSE(r.model_path.empty());
  // The URDF is the original with the chain's origins replaced: its other joints and links are kept.
  const std::string text = test::slurp(o.out + "/robot_calibrated.urdf");
  CHECK_THAT(text, Contains("<joint name=\"iiwa_joint_ee\" type=\"fixed\">") && Contains("<link name=\"iiwa_link_ee\"/>") &&
                       Contains("effort=\"300\" velocity=\"10\""));
  // robot.yaml names the calibrated URDF (beside it), not the original.
  CHECK_THAT(test::slurp(o.out + "/robot.yaml"), Contains("file: \"robot_calibrated.urdf\""));
  checkUrdfMatchesYaml(o.out, "--base-link iiwa_link_0 --tip-link iiwa_link_7", arm);
  checkFramesFile(o.out);
  checkEffectsFile(o.out, 7);
  CHECK_THAT(test::slurp(o.out + "/effects.yaml"), Contains("joint_name: \"iiwa_joint_3\""));
}

TEST_CASE("a cyclic error on a prismatic joint is exported with its lead screw's phase, and the reference implementation agrees",
          "[e2e][measured][export][prismatic]") {
  // The torso of the mobile manipulator slides on a lead screw: its cyclic error is periodic in the travel
  // with the screw's lead, 2 pi q / 0.005 per harmonic (sim/src/effects/cyclic.cpp), not in q itself.
  const std::string dir = test::tempDir("export-prismatic");
  const sim::Arm arm = sim::loadArm(sim::RobotSource{"builtin:mobile_manipulator.urdf", "", ""});
  REQUIRE(arm.isPrismatic(0));
  const sim::SimulatedData d = workflow::runSimulate(arm, spec(150, 7, {sim::Cyclic{{0}, 1}}), dir + "/data");
  workflow::MeasuredCalibrateOptions o;
  o.description = d.data.description;
  o.effects = {"cyclic:1/1"};
  o.level = {calib::LevelKind::kFull, {}};
  o.out = dir + "/cal";
  o.accept_worse = true;  // the export is under test here, whatever the held-out gain of a micrometre effect
  const workflow::MeasuredCalibrateResult r = workflow::runMeasuredCalibrate(o);
  REQUIRE_FALSE(r.model_path.empty());
  const std::string text = test::slurp(o.out + "/effects.yaml");
  CHECK_THAT(text, Contains("dq1 = cyclic1_sin1 * sin(1 * 2 * pi * q1 / 0.005) + cyclic1_cos1 * cos(1 * 2 * pi * q1 / 0.005)") &&
                       Contains("type: prismatic"));
  checkEffectsFile(o.out, arm.numJoints());
}

TEST_CASE("a measured-data calibration of a DH arm writes a URDF of its chain with the calibrated model's FK", "[e2e][measured][export]") {
  const std::string dir = test::tempDir("export-dh");
  const sim::Arm arm = sim::loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  const sim::SimulatedData d = workflow::runSimulate(arm, spec(120, 6, {sim::Compliance{{1}}}), dir + "/data");
  workflow::MeasuredCalibrateOptions o;
  o.description = d.data.description;
  o.effects = {"compliance:2"};
  o.out = dir + "/cal";
  const workflow::MeasuredCalibrateResult r = workflow::runMeasuredCalibrate(o);
  REQUIRE_FALSE(r.model_path.empty());
  checkUrdfMatchesYaml(o.out, "", arm);
  checkFramesFile(o.out);
  checkEffectsFile(o.out, 7);
  CHECK_THAT(test::slurp(o.out + "/effects.yaml"), Contains("formula: \"dq2 = -(c2 * tau2)\""));
  CHECK_THAT(test::slurp(r.report_path), Contains("robot_calibrated.urdf") && Contains("effects.yaml"));
}
