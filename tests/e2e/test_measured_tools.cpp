// `orbcal simulate` -> `orbcal calibrate DESCRIPTION` -> `orbcal evaluate` through the tools library:
// the truth file predicts its own data to the noise; a calibration that would predict held-out
// samples worse than the nominal arm is refused and writes no model; bad model files name the key.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>

#include "measured.hpp"
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
  const sim::SimulatedData d = tools::runSimulate(test::sourcePath("scenes/iiwa7.yaml"), s, dir + "/data");
  REQUIRE(std::filesystem::exists(dir + "/data/truth/model.yaml"));

  tools::MeasuredCalibrateOptions o;
  o.description = d.data.description;
  o.effects = {"compliance:2"};
  o.out = dir + "/cal";
  const tools::MeasuredCalibrateResult r = tools::runMeasuredCalibrate(o);
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
  const sim::SimulatedData d2 = tools::runSimulate(test::sourcePath("scenes/iiwa7.yaml"), s2, dir + "/data2");
  const tools::EvaluateResult truth = tools::runEvaluate(dir + "/data/truth/model.yaml", d2.data.description, dir + "/eval-truth");
  const tools::EvaluateResult fitted = tools::runEvaluate(r.model_path, d2.data.description, dir + "/eval-fit");
  CHECK(truth.fit.residuals.position_rms_m < 0.1e-3);
  CHECK(fitted.fit.residuals.position_rms_m < 0.12e-3);
}

TEST_CASE("a calibration that predicts held-out samples worse is refused and writes no model", "[e2e][measured]") {
  const std::string dir = test::tempDir("measured-worse");
  sim::SimulationSpec s = spec(40, 4);
  s.sessions = 1;
  s.payload_kg = {0.0};
  s.geometry.name = "zero";  // the nominal arm is the truth: every added parameter can only fit noise
  const sim::SimulatedData d = tools::runSimulate(test::sourcePath("scenes/iiwa7.yaml"), s, dir + "/data");
  tools::MeasuredCalibrateOptions o;
  o.description = d.data.description;
  o.effects = {"cyclic:1,2,3,4,5,6/3", "backlash:1,2,3,4,5,6"};
  o.out = dir + "/cal";
  const tools::MeasuredCalibrateResult r = tools::runMeasuredCalibrate(o);
  CHECK(r.worse);
  CHECK(r.model_path.empty());
  CHECK_FALSE(std::filesystem::exists(dir + "/cal/model.yaml"));
  CHECK(test::slurp(r.report_path).find("WORSE") != std::string::npos);
  o.accept_worse = true;
  CHECK_FALSE(tools::runMeasuredCalibrate(o).model_path.empty());
}

TEST_CASE("model files: errors name the file and the key", "[e2e][measured]") {
  const std::string dir = test::tempDir("model-file");
  sim::SimulationSpec s = spec(20, 1);
  s.effects = {sim::Scale{{0}}};
  tools::runSimulate(test::sourcePath("scenes/iiwa7.yaml"), s, dir);
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
  CHECK_THAT(messageFor("format: orbcal-model-1", "format: orbcal-model-9"), Catch::Contains("bad.yaml") && Catch::Contains("format"));
  CHECK_THAT(messageFor("{s1: ", "{s9: "), Catch::Contains("bad.yaml") && Catch::Contains("parameters.s1"));
  CHECK_THAT(messageFor("base: shared", "base: sometimes"), Catch::Contains("registration.base"));
  CHECK_THAT(messageFor("sessions: 2", "sessions: 3"), Catch::Contains("registration.flange_T_marker"));
  CHECK(sim::loadModelFile(dir + "/truth/model.yaml").model.effects.size() == 1);
}

TEST_CASE("measured data: a fit inconsistent with the given noise is refused; with the hidden effect modelled it is not",
          "[e2e][measured]") {
  const std::string dir = test::tempDir("measured-inconsistent");
  sim::SimulationSpec s = spec(120, 7);
  s.effects = {sim::Compliance{{1}}};  // joint 2's compliance, drawn from the seed: hidden in the data
  const sim::SimulatedData d = tools::runSimulate(test::sourcePath("scenes/iiwa7.yaml"), s, dir + "/data");
  tools::MeasuredCalibrateOptions o;
  o.description = d.data.description;
  o.noise_position_m = s.noise_position_m;  // the tracker's true noise, given
  o.noise_rotation_rad = s.noise_rotation_rad;
  o.out = dir + "/geometry-only";
  const tools::MeasuredCalibrateResult bad = tools::runMeasuredCalibrate(o);
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
  const tools::MeasuredCalibrateResult good = tools::runMeasuredCalibrate(o);
  CHECK_FALSE(good.inconsistent);  // chi-square(dof) at the true noise: p >= 0.001 but for 1 run in 1000
  CHECK(good.fit.chi2 / good.fit.dof == Approx(1.0).margin(0.2));
  CHECK_FALSE(good.model_path.empty());
  // --accept-worse writes the inconsistent one, and the report still says so first.
  o.effects.clear();
  o.accept_worse = true;
  o.out = dir + "/accepted";
  const tools::MeasuredCalibrateResult accepted = tools::runMeasuredCalibrate(o);
  CHECK_FALSE(accepted.model_path.empty());
  CHECK(test::slurp(accepted.report_path).find("model.yaml was written because --accept-worse was given") != std::string::npos);
}
