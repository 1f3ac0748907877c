// The reduced Table 4 through real rendered images: render -> detect -> PnP -> estimators -> validation.
#include <catch2/catch.hpp>
#include <fstream>

#include "orbcal/workflow/experiment.hpp"
#include "test_util.hpp"

using namespace orbcal;

TEST_CASE("reduced table4 from rendered images: the EKF improves every error by 90%", "[e2e][table4]") {
  workflow::ExperimentOptions o;
  o.scene = test::sourcePath("scenes/quick_scene.yaml");  // the default scene at 640 x 512
  o.out = test::tempDir("table4");
  o.identification = 30;
  o.validation = 50;
  o.plots = false;
  o.quiet = true;
  const workflow::Table4Result r = workflow::runTable4(o);
  const calib::Comparison& c = r.comparison;

  // Every image of the clean rendered views gives a pose (the generator keeps a 20 px margin).
  CHECK(r.identification.observations.size() >= 28);
  CHECK(r.validation.summary.found >= 48);

  const calib::MethodOutcome* ekf = calib::bestOfKind(c, calib::MethodSpec::Kind::kEkf);
  REQUIRE(ekf != nullptr);
  CAPTURE(ekf->method.name, c.initial.position_avg_m, ekf->summary.position_avg_m, c.floor.position_avg_m);
  // Wang et al. 2023's EKF: 90.4% in position, 91.0 / 95.2 / 93.0% in X / Y / Z orientation.
  CHECK(calib::improvement(c.initial.position_avg_m, ekf->summary.position_avg_m) >= 0.90);
  for (int a = 0; a < 3; ++a) {
    CAPTURE(a);
    CHECK(calib::improvement(c.initial.orientation_avg_rad[a], ekf->summary.orientation_avg_rad[a]) >= 0.90);
  }
  // The control noise sets the floor; 30 views of 26 identifiable combinations add estimation error on
  // top, but a correctly weighted estimator stays near it (the full 50-view run measures 1.02-1.09).
  // The 90% bars above pass at up to 3.2 x the floor in position and 3.2-5.0 x in orientation; these
  // are the checks with teeth. Measured: position 1.04, orientation X / Y / Z 1.10 / 1.16 / 1.16 x
  // floor; 1.35 on orientation leaves ~15% over the worst axis for another draw of 30 + 50 views.
  INFO("EKF / floor: position " << ekf->summary.position_avg_m / c.floor.position_avg_m << ", orientation X Y Z "
                                << (ekf->summary.orientation_avg_rad.array() / c.floor.orientation_avg_rad.array()).transpose());
  CHECK(ekf->summary.position_avg_m <= 1.2 * c.floor.position_avg_m);
  CHECK(ekf->summary.position_avg_m >= c.floor.position_avg_m * 0.95);  // nothing beats the floor by much
  for (int a = 0; a < 3; ++a) {
    CAPTURE(a, c.initial.orientation_avg_rad[a], c.floor.orientation_avg_rad[a], ekf->summary.orientation_avg_rad[a]);
    CHECK(ekf->summary.orientation_avg_rad[a] <= 1.35 * c.floor.orientation_avg_rad[a]);
  }

  // What the settings change: the paper-literal EKF (0.01 deg / 0.01 mm prior, joint noise not in R) is
  // worse than orbcal's default EKF on the same data.
  const auto find = [&](const std::string& name) -> const calib::MethodOutcome& {
    for (const auto& m : c.methods) {
      if (m.method.name == name) return m;
    }
    FAIL("no method " << name);
    return c.methods.front();
  };
  CHECK(find("EKF").summary.position_avg_m < find("EKF (paper)").summary.position_avg_m);
  // The report and the tables are written.
  CHECK(std::ifstream(o.out + "/table4/report.md").good());
  CHECK(std::ifstream(o.out + "/table4/validation_errors.csv").good());
}
