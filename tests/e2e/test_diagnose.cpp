// orbcal diagnose: each catalog effect hidden in simulated tracker data (seeded joint and magnitude) is
// named, with the right joint; clean data over 20 seeds gives at most one false alarm; the real iiwa7
// runs are diagnosed and the selected model predicts held-out data better than geometry alone.
#include <catch2/catch.hpp>
#include <filesystem>

#include <random>
#include <regex>

#include "orbcal/workflow/diagnose.hpp"
#include "orbcal/render/dataset_writer.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/simulate.hpp"
#include "test_util.hpp"

using namespace orbcal;

TEST_CASE("diagnose names each hidden effect with its joint, and says clean on clean data", "[e2e][diagnose]") {
  workflow::StudyOptions o;
  o.robot = test::sourcePath("scenes/iiwa7.yaml");
  o.per_effect = 1;  // the full study (orbcal diagnose-study, 20 per effect) is in docs/results.md
  o.clean = 20;
  o.seed = 2026;
  o.quiet = true;
  const workflow::StudyResult r = workflow::runDiagnoseStudy(o);
  REQUIRE(r.rows.size() == o.effects.size() + 1);  // every catalog kind drawn, and clean
  int wrong_joint = 0;
  for (const workflow::StudyRow& row : r.rows) {
    CAPTURE(row.injected, row.named, row.wrong_joint, row.other, row.clean_verdict, row.misses);
    if (row.injected == "clean") {
      CHECK(row.datasets == 20);
      CHECK(row.clean_verdict >= 19);  // at most one false alarm in 20
    } else {
      CHECK(row.named + row.wrong_joint == row.datasets);  // the kind named every time
      wrong_joint += row.wrong_joint;
    }
  }
  // On its joint too, but for one at most: the power study (docs/results.md) names coupling on the wrong joint
  // in 1 of 20 datasets, every other kind on its joint in 20 of 20.
  CHECK(wrong_joint <= 1);
}

TEST_CASE("diagnose writes its report, diagnosis.json and a model evaluate can read", "[e2e][diagnose]") {
  const std::string dir = test::tempDir("diagnose-files");
  workflow::DiagnoseRunOptions o;
  o.input = test::sourcePath("scenes/iiwa7_0kg.yaml");
  if (!std::filesystem::exists(test::sharedDataPath("iiwa7/run1_0kg.csv"))) {
    ORBCAL_SKIP("the real iiwa7 data is not at " << test::sharedDataPath("iiwa7"));
    return;
  }
  o.out = dir;
  o.plots = false;
  o.quiet = true;
  const workflow::DiagnoseRunResult r = workflow::runDiagnose(o);
  const calib::Diagnosis& d = r.diagnosis;
  CHECK_FALSE(d.clean);
  CHECK(d.heldout.selected.position_rms_m < d.heldout.base.position_rms_m);
  const std::string json = test::slurp(r.json_path);
  // effects, or unexplained when the selected model's held-out residuals still show structure.
  CHECK(json.find(d.unexplained ? "\"verdict\": \"unexplained\"" : "\"verdict\": \"effects\"") != std::string::npos);
  for (const char* key : {"\"selected\"", "\"confounded\"", "\"heldout\"", "\"position_rms_mm\"", "\"unexplained\": [",
                          "\"noise_position_rms_mm\"", "\"lack_of_fit\""}) {
    CHECK(json.find(key) != std::string::npos);
  }
  for (const calib::VariableTest& t : d.lack_of_fit.unexplained) CHECK(json.find("{\"variable\": \"" + t.variable + "\"") != std::string::npos);
  const std::string report = test::slurp(r.report_path);
  CHECK(report.find(d.verdict) != std::string::npos);
  CHECK(report.find("## What is left unexplained") != std::string::npos);
  const std::string csv = test::slurp(r.json_path.substr(0, r.json_path.rfind('/')) + "/residuals.csv");
  CHECK(csv.find("selected_x_mm,selected_y_mm,selected_z_mm,unexplained_axis") != std::string::npos);
  CHECK(std::filesystem::exists(r.model_path));
}

TEST_CASE("diagnose names a cyclic error of joint 2 from rendered images alone, clean images stay clean",
          "[e2e][diagnose][images][slow]") {
  const std::string dir = test::tempDir("diagnose-images");
  // A seeded amplitude of 0.04..0.08 deg (random sign) on sin(q2): 4 to 8 times the 0.01 deg control
  // noise of the plant; the 0.01 deg of scenes/errors_cyclic.yaml is below what 100 views resolve.
  std::mt19937_64 rng(77);
  const double amplitude = (0.04 + 0.04 * std::uniform_real_distribution<double>(0.0, 1.0)(rng)) * (rng() % 2 ? 1.0 : -1.0);
  test::write(dir + "/errors.yaml", "format: orbcal-errors-1\ngeometry: table3\neffects:\n  - spec: \"cyclic:2\"\n    parameters: {cyclic2_sin1: " +
                                        std::to_string(amplitude * 3.14159265358979 / 180.0) +
                                        ", cyclic2_cos1: 0, cyclic2_sin2: 0, cyclic2_cos2: 0}\n");
  const auto renderAndDiagnose = [&](const std::string& name, const std::string& errors) {
    render::DatasetJob job;
    job.scene = test::sourcePath("scenes/quick_scene.yaml");
    job.count = 100;
    job.errors.name = errors;
    job.out = dir + "/" + name;
    render::renderDataset(job);
    workflow::DiagnoseRunOptions o;
    o.input = job.out;
    o.out = job.out + "/diagnosis";
    o.plots = false;
    o.quiet = true;
    return workflow::runDiagnose(o);
  };
  const calib::Diagnosis hidden = renderAndDiagnose("cyclic", dir + "/errors.yaml").diagnosis;
  CAPTURE(amplitude, hidden.verdict);
  REQUIRE_FALSE(hidden.clean);
  // The hidden error is the first harmonic alone: the orders chosen by cross-validation must hold it,
  // either order 1 exactly ("cyclic:2/1") or the default orders 1-2 ("cyclic:2"), and no higher one.
  const std::string named = sim::formatEffect(hidden.selected.front());
  CAPTURE(named);
  CHECK((named == "cyclic:2/1" || named == "cyclic:2"));
  const workflow::DiagnoseRunResult clean = renderAndDiagnose("clean", "table3");
  CAPTURE(clean.diagnosis.verdict);
  CHECK(clean.diagnosis.clean);
  CHECK(clean.distortion.tested);
  CHECK_FALSE(clean.distortion.selected);

  // Lens distortion the scene's camera does not model (a re-focused or never-calibrated lens): dk1
  // drawn in [-0.10, -0.05], dk2 in [0, 0.04] (the corners then move by 0.1-0.3 px at the edge of the
  // quick scene's views, against the detector's ~0.035 px).
  const double dk1 = -0.05 - 0.05 * std::uniform_real_distribution<double>(0.0, 1.0)(rng);
  const double dk2 = 0.04 * std::uniform_real_distribution<double>(0.0, 1.0)(rng);
  test::write(dir + "/lens.yaml", "format: orbcal-errors-1\ngeometry: table3\neffects:\n  - {spec: distortion, parameters: {dk1: " +
                                      std::to_string(dk1) + ", dk2: " + std::to_string(dk2) + ", dp1: 0, dp2: 0}}\n");
  const workflow::DiagnoseRunResult lens = renderAndDiagnose("lens", dir + "/lens.yaml");
  CAPTURE(dk1, dk2, lens.diagnosis.verdict, lens.distortion.dk[0], lens.distortion.dk_sigma[0]);
  CHECK(lens.distortion.selected);
  CHECK_FALSE(lens.diagnosis.clean);
  CHECK(std::abs(lens.distortion.dk[0] - dk1) < 3.0 * lens.distortion.dk_sigma[0]);
  CHECK(test::slurp(lens.json_path).find("\"effect\": \"distortion\"") != std::string::npos);
}

TEST_CASE("diagnose names causes the data cannot separate as a set, and says how to separate them", "[e2e][diagnose]") {
  // As in the real iiwa7 runs: one payload, only joints 1 and 2 move. The torques of joints 2 and 4
  // then both follow q2, so a compliance of joint 2 and one of joint 4 explain nearly the same motion.
  const sim::Arm arm = sim::loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  sim::SimulationSpec spec;
  spec.samples = 200;
  spec.seed = 31;
  spec.payload_kg = {0.0};
  spec.marker = sim::FrameSharing::kShared;
  spec.still_joints = {2, 3, 4, 5, 6};
  spec.effects = {sim::Compliance{{1}}};
  spec.effect_values = Eigen::VectorXd::Constant(1, 1e-4);
  const sim::SimulatedData s = sim::simulateMeasured(arm, spec);
  const calib::Diagnosis d = calib::diagnose(s.data, calib::observationsFrom(s.data, true), {});
  CAPTURE(d.verdict);
  REQUIRE_FALSE(d.clean);
  REQUIRE_FALSE(d.confounded.empty());
  std::vector<std::string> set;
  for (const sim::Effect& e : d.confounded.front().effects) set.push_back(sim::formatEffect(e));
  CAPTURE(set);
  CHECK(std::find(set.begin(), set.end(), "compliance:2") != set.end());
  CHECK(set.size() >= 2);
  CHECK(d.confounded.front().separate_by.find("payload") != std::string::npos);
}

TEST_CASE("diagnose: joint reading noise is no effect, and an effect under it is still named", "[e2e][diagnose]") {
  // Encoders 0.01 deg off the true angles (Wang et al. 2023's control noise), not stated anywhere:
  // their share of the residuals grows with the configuration's lever arms, which a fit that whitens
  // with the tracker's noise alone took for structure (5 false alarms in 10 seeds before the joint
  // noise was estimated as a variance component). Seeded; the family-wise error rate is 0.01.
  const sim::Arm arm = sim::loadArm(test::sourcePath("scenes/iiwa7.yaml"));
  const auto simulate = [&](std::uint64_t seed, std::vector<sim::Effect> effects, Eigen::VectorXd values) {
    sim::SimulationSpec spec;
    spec.samples = 200;
    spec.sessions = 2;
    spec.payload_kg = {0.0, 1.25};
    spec.seed = seed;
    spec.geometry.seed = seed;
    spec.joint_noise_rad = 0.01 * sim::kDegToRad;
    spec.effects = std::move(effects);
    spec.effect_values = std::move(values);
    sim::SimulatedData s = sim::simulateMeasured(arm, spec);
    REQUIRE(s.data.noise_joint_rad);  // the simulator states it, as noise.joint_deg ...
    s.data.noise_joint_rad.reset();   // ... which this user's description does not
    return s;
  };
  int false_alarms = 0;
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    const sim::SimulatedData s = simulate(seed, {}, {});
    const calib::Diagnosis d = calib::diagnose(s.data, calib::observationsFrom(s.data, false), {});
    CAPTURE(seed, d.verdict);
    false_alarms += d.clean ? 0 : 1;
    CHECK(d.base_fit.noise.joint_noise_sigma_rad == Approx(0.01 * sim::kDegToRad).epsilon(0.2));
  }
  CHECK(false_alarms <= 1);
  // A cyclic error of joint 2, 0.02 deg cos(q2) + 0.01 deg sin(2 q2), twice the joint noise, is still
  // named (a sin(q2) alone would be confounded with a scale error over q2's range, and said so).
  for (std::uint64_t seed = 11; seed <= 13; ++seed) {
    Eigen::VectorXd values = Eigen::VectorXd::Zero(4);  // sin1, cos1, sin2, cos2
    values[1] = 0.02 * sim::kDegToRad;
    values[2] = 0.01 * sim::kDegToRad;
    const sim::SimulatedData s = simulate(seed, {sim::Cyclic{{1}, 2}}, values);
    const calib::Diagnosis d = calib::diagnose(s.data, calib::observationsFrom(s.data, false), {});
    CAPTURE(seed, d.verdict);
    REQUIRE_FALSE(d.clean);
    // The cause on its joint: a cyclic error of joint 2. Its order is the lowest that predicts the
    // angle extremes as well (diagnose.md, "leave the extremes out"): over q2's range a 2nd harmonic and
    // a scale error part only beyond it, so cyclic:2/1 with scale:2 may stand for cyclic:2.
    CHECK(sim::formatEffect(d.selected.front()).rfind("cyclic:2", 0) == 0);
    // The verdict's "from A to B" shows a difference (micrometres where millimetres would not).
    std::smatch m;
    REQUIRE(std::regex_search(d.verdict, m, std::regex("from ([0-9.]+ [mu]m) to ([0-9.]+ [mu]m)")));
    CHECK(m[1].str() != m[2].str());
  }
}
