// The sign convention of torques and compliance (sim/gravity.hpp, sim/src/effects/compliance.cpp): tau_j
// is the torque joint j's actuator applies, dU/dq_j at rest (U the potential energy), and a joint that
// sags under gravity has a positive compliance c. The sagging data here is made from physics alone:
// the link turns from the reading by -c dU/dq, towards lower potential energy, with U from the robot
// file's masses and the forward kinematics (neither orbcal's gravity torques nor its compliance
// effect). simulate, calibrate and diagnose must all give c > 0 for it.
#include <sys/wait.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <random>

#include "orbcal/sim/io.hpp"
#include "orbcal/sim/measured.hpp"
#include "orbcal/sim/model_io.hpp"
#include "orbcal/sim/se3.hpp"
#include "test_util.hpp"

using namespace orbcal;
using Catch::Matchers::Contains;
using Catch::Matchers::StartsWith;
namespace fs = std::filesystem;

namespace {

int runOrbcal(const std::string& dir, const std::string& args, std::string* err = nullptr) {
  const int rc = std::system(("cd '" + dir + "' && '" + std::string(ORBCAL_BINARY) + "' " + args + " >>'" + dir +
                              "/stdout.txt' 2>'" + dir + "/stderr.txt'").c_str());
  if (err) *err = test::slurp(dir + "/stderr.txt");
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

/// The arm's potential energy at q (J): every link's mass at its centre of mass (link i's COM in DH
/// frame i) and `payload_kg` at the flange origin, in the robot file's gravity.
double potentialEnergy(const sim::Arm& arm, const Eigen::VectorXd& q, double payload_kg) {
  const std::vector<Eigen::Isometry3d> frames = sim::chainFrames(arm, q);
  const Eigen::Vector3d& g = arm.masses.gravity_base;
  double u = -payload_kg * g.dot(frames.back().translation());
  for (std::size_t i = 0; i < arm.masses.links.size(); ++i) {
    u -= arm.masses.links[i].mass_kg * g.dot(frames[i + 1] * arm.masses.links[i].com_m);
  }
  return u;
}

/// dU/dq by central differences.
Eigen::VectorXd energyGradient(const sim::Arm& arm, const Eigen::VectorXd& q, double payload_kg) {
  Eigen::VectorXd grad(q.size());
  const double h = 1e-6;
  for (Eigen::Index j = 0; j < q.size(); ++j) {
    Eigen::VectorXd a = q, b = q;
    a[j] += h;
    b[j] -= h;
    grad[j] = (potentialEnergy(arm, a, payload_kg) - potentialEnergy(arm, b, payload_kg)) / (2 * h);
  }
  return grad;
}

/// The value of the compliance parameter `name` ("c2") in a model file.
double complianceIn(const std::string& model_file, const std::string& name) {
  const sim::LoadedModel m = sim::loadModelFile(model_file);
  for (const sim::ParamBlock& b : m.model.layout.blocks()) {
    for (int i = 0; i < b.size(); ++i) {
      if (b.params[static_cast<std::size_t>(i)].name == name) return m.p[b.offset + i];
    }
  }
  FAIL("no parameter " << name << " in " << model_file);
  return 0.0;
}

/// Tracker data of the built-in iiwa7 whose joint 2 sags by c dU/dq2 (c = 1e-4 rad/(N m)): frames
/// identity but estimated (shared), 0.01 mm / 0.001 deg noise (stated), sessions at the payloads given
/// (kg, at the flange origin); with `torques`, a torque column of dU/dq (the stated convention), else
/// none (then orbcal computes them from the masses, which needs a single payload-free session).
std::string saggingData(const std::string& folder, const std::vector<double>& payloads, bool torques) {
  sim::MeasuredData d;
  d.arm = sim::loadArm("builtin:iiwa7.yaml");
  d.base = d.marker = sim::FrameSharing::kShared;
  d.noise_position_m = 0.01e-3;
  d.noise_rotation_rad = 0.001 * sim::kDegToRad;
  d.has_torque = torques;
  std::mt19937_64 rng = sim::makeRng(11);
  std::normal_distribution<double> n01(0.0, 1.0);
  const double c = 1e-4;
  for (std::size_t s = 0; s < payloads.size(); ++s) {
    d.files.push_back("session_" + std::to_string(s + 1) + ".csv");
    for (const Eigen::VectorXd& q : test::randomConfigs(d.arm, 150, 20 + s)) {
      const Eigen::VectorXd grad = energyGradient(d.arm, q, payloads[s]);
      Eigen::VectorXd link = q;
      link[1] -= c * grad[1];  // towards lower potential energy: the joint sags
      sim::MeasuredPose p;
      p.sample.session = static_cast<int>(s);
      p.sample.q_rad = q;
      if (torques) p.sample.tau_Nm = grad;
      sim::Vector6d e;
      for (int i = 0; i < 3; ++i) e[i] = *d.noise_position_m * n01(rng);
      for (int i = 3; i < 6; ++i) e[i] = *d.noise_rotation_rad * n01(rng);
      p.world_T_marker = sim::posePlus(sim::forwardKinematics(d.arm, link), e);
      d.poses.push_back(p);
    }
  }
  sim::fillApproachDirections(d.poses);
  return sim::writeMeasuredData(d, folder, "builtin:iiwa7.yaml");
}

}  // namespace

TEST_CASE("a joint that sags under gravity has a positive compliance in calibrate and diagnose", "[e2e][sign]") {
  const std::string dir = test::tempDir("sign-sag");
  // Torques from the robot file's masses (no torque column).
  saggingData(dir + "/computed", {0.0}, false);
  REQUIRE(runOrbcal(dir, "calibrate computed/measurements.yaml --effects compliance:2 -o cal-computed") == 0);
  CHECK(complianceIn(dir + "/cal-computed/model.yaml", "c2") == Approx(1e-4).epsilon(0.02));
  CHECK_THAT(test::slurp(dir + "/cal-computed/report.md"), Contains("positive c means the joint sags under gravity"));

  // Torques measured in the stated sense (dU/dq), two payloads.
  saggingData(dir + "/measured", {0.0, 2.0}, true);
  REQUIRE(runOrbcal(dir, "calibrate measured/measurements.yaml --effects compliance:2 -o cal-measured") == 0);
  CHECK(complianceIn(dir + "/cal-measured/model.yaml", "c2") == Approx(1e-4).epsilon(0.02));
  REQUIRE(runOrbcal(dir, "diagnose measured/measurements.yaml -o diagnosis --no-plots --quiet") == 0);
  CHECK_THAT(test::slurp(dir + "/diagnosis/diagnosis.json"), Contains("{\"effect\": \"compliance\", \"joints\": [2], \"parameters\": [{\"name\": \"c2\", "));
  CHECK(complianceIn(dir + "/diagnosis/model.yaml", "c2") == Approx(1e-4).epsilon(0.02));
  CHECK_THAT(test::slurp(dir + "/diagnosis/report.md"), Contains("positive c means the joint sags under gravity"));
}

TEST_CASE("simulate: a positive compliance sags, and a drawn one is positive", "[e2e][sign]") {
  const std::string dir = test::tempDir("sign-simulate");
  const std::string common = " -n 40 --sessions 1 --geometry zero --base known --marker known --noise-position-mm 1e-6 "
                             "--noise-rotation-deg 1e-7 --quiet --inject compliance:2 ";
  for (const std::string values : {"--values 1e-4", ""}) {  // given, then drawn
    const std::string out = values.empty() ? "drawn" : "given";
    REQUIRE(runOrbcal(dir, "simulate -o " + out + common + values + " --seed 3") == 0);
    const double c = complianceIn(dir + "/" + out + "/truth/model.yaml", "c2");
    CHECK(c > 0.0);
    if (!values.empty()) CHECK(c == 1e-4);
    const sim::MeasuredData d = sim::loadMeasuredData(dir + "/" + out + "/measurements.yaml");
    REQUIRE(d.has_torque);
    for (const sim::MeasuredPose& p : d.poses) {
      const Eigen::VectorXd grad = energyGradient(d.arm, p.sample.q_rad, 0.0);
      // The written torque is the actuator's, dU/dq (plus the simulated sensor noise, 0.05 N m).
      CHECK(std::abs(p.sample.tau_Nm[1] - grad[1]) < 0.3);
      Eigen::VectorXd sag = p.sample.q_rad, rise = p.sample.q_rad;
      sag[1] -= c * grad[1];
      rise[1] += c * grad[1];
      const Eigen::Vector3d x = p.world_T_marker.translation();
      CHECK((x - sim::forwardKinematics(d.arm, sag).translation()).norm() < 1e-7);
      if (std::abs(grad[1]) > 1.0) CHECK((x - sim::forwardKinematics(d.arm, rise).translation()).norm() > 1e-5);
    }
  }
}

TEST_CASE("the real iiwa7: its files' torques are the load's (sense: load), and joint 2 comes out sagging", "[e2e][sign][iiwa7]") {
  if (!fs::exists(test::sharedDataPath("iiwa7/run1_0kg.csv"))) {
    ORBCAL_SKIP("the real iiwa7 data is not at " << test::sharedDataPath("iiwa7"));
    return;
  }
  // Read with the description's `sense: load`, the torques follow dU/dq of iiwa7.yaml's masses (with
  // the payload of each run) closely in joints 2 and 4, the joints gravity loads most.
  const sim::MeasuredData d = sim::loadMeasuredData(test::sourcePath("scenes/iiwa7_measurements.yaml"));
  for (const int j : {1, 3}) {
    double sxy = 0, sxx = 0, syy = 0;
    for (const sim::MeasuredPose& p : d.poses) {
      const double g = energyGradient(d.arm, p.sample.q_rad, p.sample.session == 0 ? 0.0 : 1.25)[j];
      sxy += g * p.sample.tau_Nm[j];
      sxx += g * g;
      syy += p.sample.tau_Nm[j] * p.sample.tau_Nm[j];
    }
    INFO("joint " << j + 1);
    CHECK(sxy / std::sqrt(sxx * syy) > 0.99);  // (uncentred) correlation
  }
  const std::string dir = test::tempDir("sign-iiwa7");
  REQUIRE(runOrbcal(dir, "calibrate '" + test::sourcePath("scenes/iiwa7_measurements.yaml") + "' --effects compliance:2 -o cal") == 0);
  const double c2 = complianceIn(dir + "/cal/model.yaml", "c2");
  CHECK(c2 > 0.0);
  CHECK(c2 < 1e-3);  // a stiffness above 1000 N m/rad
}

TEST_CASE("a torque sense other than actuator or load is refused at its key", "[e2e][sign][badinput]") {
  const std::string dir = test::tempDir("sign-sense");
  const std::string desc = saggingData(dir + "/data", {0.0}, true);
  std::string text = test::slurp(desc);
  const std::string from = "unit: N*m}";
  REQUIRE(text.find(from) != std::string::npos);
  test::write(desc, text.replace(text.find(from), from.size(), "unit: N*m, sense: motor}"));
  std::string err;
  CHECK(runOrbcal(dir, "calibrate data/measurements.yaml --effects compliance:2 -o cal", &err) == 1);
  CHECK(err == "orbcal: data/measurements.yaml: covariates.torque.sense: expected actuator (the torque the joint's actuator "
               "applies, orbcal's sense) or load (the load's torque on the joint, the negative), got 'motor'\n");
  CHECK_FALSE(fs::exists(dir + "/cal"));
}

TEST_CASE("a model file of format orbcal-model-1 with a compliance is refused at its spec", "[e2e][sign][badinput]") {
  const std::string dir = test::tempDir("sign-model-1");
  REQUIRE(runOrbcal(dir, "simulate -o data -n 30 --sessions 1 --inject compliance:2 --quiet") == 0);
  std::string text = test::slurp(dir + "/data/truth/model.yaml");
  const std::string from = "format: orbcal-model-2";
  REQUIRE(text.find(from) != std::string::npos);
  test::write(dir + "/data/truth/old.yaml", text.replace(text.find(from), from.size(), "format: orbcal-model-1"));
  std::string err;
  CHECK(runOrbcal(dir, "evaluate --model data/truth/old.yaml --data data/measurements.yaml -o eval", &err) == 1);
  CHECK_THAT(err, StartsWith("orbcal: data/truth/old.yaml: ") && Contains("effects[0].spec: a format orbcal-model-1 file gave "
                                                                           "compliance the other sign"));
  CHECK(std::count(err.begin(), err.end(), '\n') == 1);
  CHECK_FALSE(fs::exists(dir + "/eval"));
}
