// The real KUKA iiwa7 measurements (../shared/data/iiwa7, never copied into the project) through the
// descriptions shipped in scenes/: geometry-only and geometry + compliance fitted on the 0 kg run,
// both predicting the 1.25 kg run with `orbcal evaluate` (the marker was re-mounted: refitted); and
// diagnose's selection on the 0 kg run with the alternatives the 0 kg run cannot tell from it, each
// predicting the 1.25 kg run.
#include <catch2/catch.hpp>
#include <algorithm>
#include <filesystem>

#include "orbcal/workflow/diagnose.hpp"
#include "orbcal/workflow/measured.hpp"
#include "test_util.hpp"

using namespace orbcal;

namespace {
bool haveData() {
  if (std::filesystem::exists(test::sharedDataPath("iiwa7/run1_0kg.csv"))) return true;
  ORBCAL_SKIP("the real iiwa7 data is not at " << test::sharedDataPath("iiwa7"));
  return false;
}
}  // namespace

TEST_CASE("iiwa7: compliance fitted on 0 kg predicts 1.25 kg better than geometry alone", "[e2e][iiwa7]") {
  if (!haveData()) return;
  const std::string dir = test::tempDir("iiwa7-measured");
  const auto calibrate = [&](const std::vector<std::string>& effects, const std::string& name, bool accept) {
    workflow::MeasuredCalibrateOptions o;
    o.description = test::sourcePath("scenes/iiwa7_0kg.yaml");
    o.effects = effects;
    o.out = dir + "/" + name;
    o.accept_worse = accept;
    return workflow::runMeasuredCalibrate(o);
  };
  // Geometry alone barely beats the nominal arm on the held-out configurations (gravity's sag is what
  // is left): not significant, refused; written with --accept-worse to compare on the other payload.
  const workflow::MeasuredCalibrateResult refused = calibrate({}, "refused", false);
  CHECK(refused.model_path.empty());
  CHECK_THAT(refused.refusal, Catch::Contains("the held-out gain is not significant"));
  const workflow::MeasuredCalibrateResult geometry = calibrate({}, "geometry", true);
  const workflow::MeasuredCalibrateResult compliance = calibrate({"compliance:2,4"}, "compliance", false);
  REQUIRE(geometry.samples == 198);
  REQUIRE_FALSE(geometry.model_path.empty());
  REQUIRE_FALSE(compliance.model_path.empty());
  CHECK(compliance.gain.significant);
  // Only joints 1 and 2 move in these files: the DH parameters of joints 3..7 cannot all be
  // identified, and the report must say so rather than fit noise.
  CHECK(geometry.fit.estimate.held.size() >= 6);
  CHECK(compliance.heldout_after.position_rms_m < geometry.heldout_after.position_rms_m);

  const std::string data = test::sourcePath("scenes/iiwa7_1.25kg.yaml");
  const workflow::EvaluateResult eg = workflow::runEvaluate(geometry.model_path, data, dir + "/eval-geometry");
  const workflow::EvaluateResult ec = workflow::runEvaluate(compliance.model_path, data, dir + "/eval-compliance");
  CHECK(eg.fit.residuals.samples == 198);
  CHECK(ec.fit.residuals.position_rms_m < eg.fit.residuals.position_rms_m);
  const std::string json = test::slurp(ec.json_path);
  for (const char* key : {"position_mean_mm", "position_rms_mm", "position_max_mm", "rotation_rms_deg"}) {
    CHECK(json.find(key) != std::string::npos);
  }
}

TEST_CASE("iiwa7: diagnose on 0 kg writes its confounded alternatives, evaluate on 1.25 kg compares them where the torques leave the fitted range",
          "[e2e][iiwa7][diagnose]") {
  if (!haveData()) return;
  const std::string dir = test::tempDir("iiwa7-extrapolation");
  workflow::DiagnoseRunOptions o;
  o.input = test::sourcePath("scenes/iiwa7_0kg.yaml");
  o.out = dir + "/d";
  o.plots = false;
  o.quiet = true;
  const workflow::DiagnoseRunResult d = workflow::runDiagnose(o);
  REQUIRE_FALSE(d.diagnosis.selected.empty());
  // The 0 kg run cannot tell a compliance of joint 4 from one of joint 2 (their torques both follow q2):
  // the alternatives are written beside model.yaml, each effect with the torque range it was fitted on.
  REQUIRE_FALSE(d.diagnosis.alternatives.empty());
  const std::string model = test::slurp(d.model_path);
  CHECK(model.find("range: {tau") != std::string::npos);
  CHECK(model.find("alternatives: [\"alternative1.yaml\"") != std::string::npos);
  const workflow::EvaluateResult e = workflow::runEvaluate(d.model_path, test::sourcePath("scenes/iiwa7_1.25kg.yaml"), dir + "/e");
  REQUIRE(e.alternatives.size() == d.diagnosis.alternatives.size());
  // Each alternative predicts the other run on its own (marker refitted): a real prediction, not the
  // model's copy, and its predictions part from the model's somewhere. Selection holds beyond its data:
  // the selected model predicts the heavier run no worse than any member of its confounded set.
  CHECK(e.fit.residuals.position_rms_m < e.baseline.position_rms_m);
  for (const workflow::AlternativePrediction& a : e.alternatives) {
    CAPTURE(a.effects, a.residuals.position_rms_m, e.fit.residuals.position_rms_m);
    CHECK(a.residuals.samples == 198);
    CHECK(e.fit.residuals.position_rms_m <= a.residuals.position_rms_m);
    REQUIRE(a.divergence_m.size() == 198);
    CHECK(*std::max_element(a.divergence_m.begin(), a.divergence_m.end()) > 0.0);
  }
  // The heavier payload loads the joints beyond what the 0 kg run saw: evaluate counts those samples.
  CHECK(std::any_of(e.excess.begin(), e.excess.end(), [](const sim::RangeExcess& x) { return x.outside > 0 && x.max_excess > 0.0; }));
  const std::string report = test::slurp(e.report_path);
  CHECK(report.find("## Where the model extrapolates") != std::string::npos);
  CHECK(test::slurp(e.residuals_path).find(",beyond_range,alternative1_mm") != std::string::npos);
}
