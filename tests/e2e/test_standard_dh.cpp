// The whole pipeline on a standard-DH arm (the KUKA iiwa7 and its bench-top scene), not only the SSRMS.
#include <catch2/catch.hpp>

#include "orbcal/workflow/experiment.hpp"
#include "test_util.hpp"

using namespace orbcal;

TEST_CASE("a standard-DH arm goes through render -> detect -> estimators -> validation", "[e2e][standard-dh]") {
  workflow::ExperimentOptions o;
  o.robot = test::sourcePath("scenes/iiwa7.yaml");
  o.scene = test::sourcePath("scenes/iiwa7_scene.yaml");
  o.out = test::tempDir("standard-dh");
  o.identification = 30;
  o.validation = 30;
  o.plots = false;
  o.quiet = true;
  const workflow::Table4Result r = workflow::runTable4(o);
  REQUIRE(r.identification.dataset.arm.convention == sim::DhConvention::kStandard);
  CHECK(r.identification.observations.size() >= 28);
  const calib::MethodOutcome* ekf = calib::bestOfKind(r.comparison, calib::MethodSpec::Kind::kEkf);
  REQUIRE(ekf != nullptr);
  const calib::ErrorSummary& initial = r.comparison.initial;
  const calib::ErrorSummary& floor = r.comparison.floor;
  CAPTURE(initial.position_avg_m, ekf->summary.position_avg_m, floor.position_avg_m);
  INFO("EKF / floor: position " << ekf->summary.position_avg_m / floor.position_avg_m << ", orientation X Y Z "
                                << (ekf->summary.orientation_avg_rad.array() / floor.orientation_avg_rad.array()).transpose());
  // Table 3's errors (0.2-0.3 deg, 0.5-1 mm) on a 1.3 m arm; the same 90% bar as Wang et al. 2023's EKF.
  CHECK(calib::improvement(initial.position_avg_m, ekf->summary.position_avg_m) >= 0.90);
  // That bar alone passes at 5.2 x the floor in position and 2.6-4.9 x in orientation. The estimators
  // land at 1.02-1.09 x floor in the main job's 50-view runs; with 30 + 30 views here, measured position
  // 1.05 and orientation X / Y / Z 0.97 / 1.13 / 1.08 x floor. 1.25 and 1.35 leave margin for another draw.
  CHECK(ekf->summary.position_avg_m <= 1.25 * floor.position_avg_m);
  for (int a = 0; a < 3; ++a) {
    CAPTURE(a, initial.orientation_avg_rad[a], ekf->summary.orientation_avg_rad[a], floor.orientation_avg_rad[a]);
    CHECK(calib::improvement(initial.orientation_avg_rad[a], ekf->summary.orientation_avg_rad[a]) >= 0.90);
    CHECK(ekf->summary.orientation_avg_rad[a] <= 1.35 * floor.orientation_avg_rad[a]);
  }
}
