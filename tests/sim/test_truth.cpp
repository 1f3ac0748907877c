// sim/truth.hpp: the plant of a simulation, from a named error set or an error-set file with effects.
#include <catch2/catch.hpp>
#include <cmath>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/gravity.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/sim/truth.hpp"
#include "test_util.hpp"

using namespace orbcal;
using namespace orbcal::sim;
using Catch::Matchers::Contains;

namespace {

/// Joint angles drawn uniformly within 80% of each joint's range.
Eigen::VectorXd randomJoints(const Arm& arm, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-0.8, 0.8);
  Eigen::VectorXd q(arm.numJoints());
  for (int j = 0; j < arm.numJoints(); ++j) {
    q[j] = 0.5 * (arm.lower_rad[j] + arm.upper_rad[j]) + 0.5 * (arm.upper_rad[j] - arm.lower_rad[j]) * u(rng);
  }
  return q;
}

/// Writes an error-set file into the test's folder and returns its path.
std::string errorFile(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = dir + "/" + name;
  test::write(path, text);
  return path;
}

TrueArm load(const Arm& arm, const std::string& path) {
  ErrorSetSpec spec;
  spec.name = path;
  return makeTrueArm(arm, spec, "--errors");
}

const char* kCyclic = R"(format: orbcal-errors-1
geometry: table3
effects:
  - {spec: "cyclic:2", parameters: {cyclic2_sin1: 3.0e-4, cyclic2_cos1: -1.0e-4, cyclic2_sin2: 0.5e-4, cyclic2_cos2: 2.0e-4}}
)";

}  // namespace

TEST_CASE("a plant without effects is the DH errors alone, bit for bit", "[sim][truth]") {
  const std::string dir = test::tempDir("truth-geometry");
  for (const std::string& robot : {std::string(kDefaultRobot), test::sourcePath("scenes/iiwa7.yaml")}) {
    CAPTURE(robot);
    const Arm nominal = loadArm(robot);
    std::vector<std::string> sets{"zero", "random"};
    if (nominal.numJoints() == 7 && nominal.convention == DhConvention::kModified) sets.push_back("table3");
    sets.push_back(errorFile(dir, "plain.yaml", "format: orbcal-errors-1\ngeometry: {random: {seed: 4, angle_sigma_deg: 0.2}}\n"));
    for (const std::string& name : sets) {
      CAPTURE(name);
      ErrorSetSpec spec;
      spec.name = name;
      const TrueArm t = makeTrueArm(nominal, spec, "--errors");
      CHECK_FALSE(t.hasEffects());
      CHECK(t.fromFile() == !isNamedErrorSet(name));
      Eigen::VectorXd y;
      if (isNamedErrorSet(name)) {
        y = makeErrorSet(nominal, spec, "test");
      } else {
        ErrorSetSpec r;
        r.name = "random";
        r.seed = 4;
        r.angle_sigma_rad = 0.2 * kDegToRad;  // the file's; its length sigma is the default 1 mm
        y = makeErrorSet(nominal, r, "test");
      }
      REQUIRE(t.geometryErrors() == y);
      const Arm truth = withErrors(nominal, y);
      std::mt19937_64 rng = makeRng(7);
      Eigen::VectorXd previous = randomJoints(nominal, rng);
      for (int k = 0; k < 25; ++k) {
        const Eigen::VectorXd q = randomJoints(nominal, rng);
        CHECK(t.flangePose(k, q, k == 0 ? nullptr : &previous).matrix() == forwardKinematics(truth, q).matrix());
        previous = q;
      }
    }
  }
}

TEST_CASE("a cyclic effect turns its joint by its harmonics of the joint angle", "[sim][truth]") {
  const std::string dir = test::tempDir("truth-cyclic");
  const Arm nominal = loadArm(kDefaultRobot);
  const TrueArm t = load(nominal, errorFile(dir, "cyclic.yaml", kCyclic));
  REQUIRE(t.hasEffects());
  CHECK(t.fromFile());
  CHECK(t.file_text == kCyclic);
  const Arm truth = withErrors(nominal, paperTable3Errors());
  REQUIRE(t.geometryErrors() == paperTable3Errors());
  std::mt19937_64 rng = makeRng(8);
  double largest = 0.0;
  for (int k = 0; k < 40; ++k) {
    const Eigen::VectorXd q = randomJoints(nominal, rng);
    const double q2 = q[1];
    const double dq2 = 3.0e-4 * std::sin(q2) - 1.0e-4 * std::cos(q2) + 0.5e-4 * std::sin(2 * q2) + 2.0e-4 * std::cos(2 * q2);
    Eigen::VectorXd q_turned = q;
    q_turned[1] += dq2;
    const Eigen::Isometry3d T = t.flangePose(k, q, nullptr);
    CHECK((T.matrix() - forwardKinematics(truth, q_turned).matrix()).cwiseAbs().maxCoeff() < 1e-12);
    largest = std::max(largest, (T.translation() - forwardKinematics(truth, q).translation()).norm());
  }
  // The effect is there: 0.02 deg on joint 2 of a 15 m arm moves the flange by millimetres.
  CHECK(largest > 1e-3);
  // In display units, for reports.
  CHECK_THAT(formatEffects(t), Contains("cyclic:2:") && Contains("cyclic2_sin1 +0.0171887 deg") &&
                                   Contains("cyclic2_cos1 -0.00572958 deg"));
}

TEST_CASE("compliance deflects the joints under the gravity torques of the masses and the payload", "[sim][truth]") {
  const std::string dir = test::tempDir("truth-compliance");
  const Arm iiwa = loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  REQUIRE(!iiwa.masses.links.empty());
  const TrueArm t = load(iiwa, errorFile(dir, "c.yaml", R"(format: orbcal-errors-1
geometry: zero
effects:
  - {spec: "compliance:2,4", parameters: {c2: 1.0e-4, c4: 3.0e-4}}
covariates: {payload_kg: 1.5}
)"));
  Arm loaded = iiwa;
  loaded.masses.payload_kg = 1.5;
  CHECK(t.covariates.payload_kg == 1.5);
  std::mt19937_64 rng = makeRng(9);
  for (int k = 0; k < 10; ++k) {
    const Eigen::VectorXd q = randomJoints(iiwa, rng);
    const JointSample s = t.sample(k, q, nullptr);
    const Eigen::VectorXd tau = gravityTorques(loaded, loaded.masses, q);
    REQUIRE(s.tau_Nm.size() == 7);
    CHECK(s.tau_Nm == tau);
    CHECK(std::abs(tau[1]) + std::abs(tau[3]) > 1.0);  // the payload and the links load joints 2 and 4
    Eigen::VectorXd deflected = q;
    deflected[1] -= 1.0e-4 * tau[1];  // c > 0: the joint yields to its load, against the actuator's torque
    deflected[3] -= 3.0e-4 * tau[3];
    CHECK((t.flangePose(s).matrix() - forwardKinematics(iiwa, deflected).matrix()).cwiseAbs().maxCoeff() < 1e-12);
  }

  // Without payload_kg the robot file's payload; a payload alone is enough masses for the SSRMS, which has none.
  const TrueArm own = load(iiwa, errorFile(dir, "own.yaml", "format: orbcal-errors-1\ngeometry: zero\n"
                                                           "effects: [{spec: \"compliance:2\", parameters: {c2: 1.0e-4}}]\n"));
  CHECK(own.covariates.payload_kg == iiwa.masses.payload_kg);
  const Arm ssrms = loadArm(kDefaultRobot);
  const TrueArm payload = load(ssrms, errorFile(dir, "payload.yaml", "format: orbcal-errors-1\ngeometry: zero\n"
                                                                     "effects: [{spec: \"compliance:2\", parameters: {c2: 1.0e-6}}]\n"
                                                                     "covariates: {payload_kg: 100}\n"));
  const Eigen::VectorXd q = randomJoints(ssrms, rng);
  Arm carried = ssrms;
  carried.masses.payload_kg = 100;
  CHECK(payload.sample(0, q, nullptr).tau_Nm == gravityTorques(carried, carried.masses, q));
}

TEST_CASE("the plant's covariates: time, warm-up temperature, approach direction, drift of the base", "[sim][truth]") {
  const std::string dir = test::tempDir("truth-covariates");
  const Arm nominal = loadArm(kDefaultRobot);
  const TrueArm t = load(nominal, errorFile(dir, "warm.yaml", R"(format: orbcal-errors-1
geometry: zero
effects:
  - {spec: "thermal", parameters: {alpha_thermal: 2.3e-5}}
  - {spec: "backlash:3", parameters: {b3: 1.0e-4}}
  - {spec: "drift", parameters: {drift_vx: 2.0e-7, drift_vy: 0, drift_vz: 0, drift_wx: 0, drift_wy: 0, drift_wz: 0}}
covariates:
  temperature: {start_C: 18, rise_C: 10, tau_s: 1800}
  sample_period_s: 15
)"));
  std::mt19937_64 rng = makeRng(10);
  const Eigen::VectorXd q0 = randomJoints(nominal, rng), q1 = randomJoints(nominal, rng);
  const JointSample first = t.sample(0, q0, nullptr);
  CHECK(first.time_s == 0.0);
  CHECK(first.temperature_C == 18.0);
  CHECK(first.direction == Eigen::VectorXd::Zero(7));
  const JointSample s = t.sample(120, q1, &q0);
  CHECK(s.time_s == 1800.0);
  CHECK(s.temperature_C == Approx(18.0 + 10.0 * (1.0 - std::exp(-1.0))).epsilon(1e-14));
  CHECK_FALSE(s.hasTorque());  // no effect reads torques
  for (int j = 0; j < 7; ++j) CHECK(s.direction[j] == (q1[j] > q0[j] ? 1.0 : -1.0));

  // The chain by hand: lengths expanded, joint 3 shifted by its backlash, the base moved by v t.
  Arm warm = nominal;
  const double scale = 1.0 + 2.3e-5 * (s.temperature_C - 20.0);
  for (DhRow& r : warm.joints) {
    r.a_m *= scale;
    r.d_m *= scale;
  }
  Eigen::VectorXd q = q1;
  q[2] += 1.0e-4 * s.direction[2];
  Eigen::Isometry3d expected = forwardKinematics(warm, q);
  expected.translation().x() += 2.0e-7 * 1800.0;
  CHECK((t.flangePose(120, q1, &q0).matrix() - expected.matrix()).cwiseAbs().maxCoeff() < 1e-12);
  CHECK_THAT(formatEffects(t), Contains("temperature 18 degC + 10 degC (1 - exp(-t / 1800 s))") &&
                                   Contains("drift_vx +0.72 mm/h") && Contains("alpha_thermal +23 ppm/K"));
}

TEST_CASE("error-set file errors name the file and the key", "[sim][truth]") {
  const std::string dir = test::tempDir("truth-errors");
  const Arm ssrms = loadArm(kDefaultRobot);
  const auto message = [&](const std::string& text) {
    const std::string path = errorFile(dir, "bad.yaml", text);
    const std::string msg = test::inputError([&] { load(ssrms, path); });
    CHECK_THAT(msg, Contains(path + ": "));
    return msg;
  };
  const std::string head = "format: orbcal-errors-1\ngeometry: table3\n";
  CHECK_THAT(message(head + "colour: blue\n"), Contains("colour: unknown key"));
  CHECK_THAT(message("format: orbcal-errors-2\ngeometry: table3\n"), Contains("format: expected orbcal-errors-1"));
  CHECK_THAT(message("format: orbcal-errors-1\n"), Contains("geometry: missing"));
  CHECK_THAT(message("format: orbcal-errors-1\ngeometry: table4\n"), Contains("geometry: expected table3, zero, random"));
  CHECK_THAT(message("format: orbcal-errors-1\ngeometry: {random: {seed: 1, sigma: 2}}\n"),
             Contains("geometry.random.sigma: unknown key"));
  CHECK_THAT(message("format: orbcal-errors-1\ngeometry: [{theta_deg: 0, alpha_deg: 0, a_mm: 0, d_mm: 0}]\n"),
             Contains("geometry: expected one row per joint: 7"));
  CHECK_THAT(message(head + "covariates: {payload: 1}\n"), Contains("covariates.payload: unknown key"));
  CHECK_THAT(message(head + "covariates: {sample_period_s: 0}\n"), Contains("covariates.sample_period_s: must be positive"));
  CHECK_THAT(message(head + "effects: [{spec: \"cyclic:2\", parameters: {cyclic2_sin1: 1e-4, cyclic2_cos1: 0, cyclic2_sin2: 0}}]\n"),
             Contains("effects[0].parameters.cyclic2_cos2: missing"));
  CHECK_THAT(message(head + "effects: [{spec: \"scale:1\", parameters: {s1: 1e-4, s2: 1e-4}}]\n"),
             Contains("effects[0].parameters.s2: unknown key"));
  CHECK_THAT(message(head + "effects: [{spec: \"scale:1\"}]\n"), Contains("effects[0].parameters: missing"));
  CHECK_THAT(message(head + "effects: [{spec: \"scale:9\", parameters: {s9: 0}}]\n"),
             Contains("effects[0].spec") && Contains("out of range"));
  CHECK_THAT(message(head + "effects: [{spec: \"scale:1\", parameters: {s1: 0}}, {spec: \"scale:2\", parameters: {s2: 0}}]\n"),
             Contains("effects[1].spec: a second scale effect"));
  // Compliance needs torques: the SSRMS file has no masses and the payload is 0.
  CHECK_THAT(message(head + "effects: [{spec: \"compliance:2\", parameters: {c2: 1e-4}}]\n"),
             Contains("effects[0].spec: compliance") && Contains("no masses") && Contains(ssrms.source));
  CHECK_THAT(message(head + "effects: [{spec: \"mount\", parameters: {}}]\n"), Contains("effects[0].spec: mount"));
  CHECK_THAT(message(head + "effects: [{spec: \"thermal\", parameters: {alpha_thermal: 2e-5}}]\n"),
             Contains("effects[0].spec: thermal reads the temperature") && Contains("covariates.temperature"));
  CHECK_THAT(message(head + "effects: [{spec: \"distortion\", parameters: {dk1: 0, dk2: 0, dp1: 0}}]\n"),
             Contains("effects[0].parameters.dp2: missing"));
  CHECK_THAT(message(head + "effects: [{spec: \"distortion:1\", parameters: {}}]\n"),
             Contains("effects[0].spec") && Contains("distortion takes no joints"));
  CHECK_THAT(message(head + "effects: [{spec: distortion, parameters: {dk1: 0, dk2: 0, dp1: 0, dp2: 0}}, "
                            "{spec: distortion, parameters: {dk1: 0, dk2: 0, dp1: 0, dp2: 0}}]\n"),
             Contains("effects[1].spec: a second distortion effect"));
  // A name that is neither a set nor a file.
  CHECK_THAT(test::inputError([&] { load(ssrms, dir + "/no_such.yaml"); }),
             Contains("--errors: '" + dir + "/no_such.yaml' is neither table3, zero, random nor a readable error-set file"));
}

TEST_CASE("the distortion effect changes the plant's camera, not its chain", "[sim][truth]") {
  const std::string dir = test::tempDir("truth-distortion");
  const Arm ssrms = loadArm(kDefaultRobot);
  const std::string path = errorFile(dir, "d.yaml",
                                     "format: orbcal-errors-1\ngeometry: table3\neffects:\n"
                                     "  - {spec: \"cyclic:2\", parameters: {cyclic2_sin1: 1e-4, cyclic2_cos1: 0, cyclic2_sin2: 0, cyclic2_cos2: 0}}\n"
                                     "  - {spec: distortion, parameters: {dk1: -0.05, dk2: 0.02, dp1: 1e-4, dp2: -2e-4}}\n");
  const TrueArm t = load(ssrms, path);
  REQUIRE(t.has_camera_distortion);
  REQUIRE(t.model.effects.size() == 1);  // cyclic only: the chain
  CHECK(t.camera_distortion_delta.isApprox(Eigen::Vector4d(-0.05, 0.02, 1e-4, -2e-4)));
  CHECK(t.hasEffects());
  Camera c;
  c.distortion = {0.1, 0.2, 0.3, 0.4, 0.5};
  const Camera taken = t.camera(c);
  CHECK(taken.distortion[0] == Approx(0.05));
  CHECK(taken.distortion[1] == Approx(0.22));
  CHECK(taken.distortion[3] == Approx(0.4 - 2e-4));
  CHECK(taken.distortion[4] == 0.5);
  CHECK_THAT(formatEffects(t), Contains("distortion") && Contains("dk1 -0.05"));
  // parseEffect keeps the chain: distortion is named as a camera effect there.
  CHECK_THAT(test::inputError([&] { parseEffect("distortion", 7, "--effects"); }), Contains("camera effect"));
  CHECK(isCameraEffect("distortion", "--effects"));
  CHECK_FALSE(isCameraEffect("cyclic:2", "--effects"));
}
