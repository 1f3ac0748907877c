// The whole pipeline on a standard-DH arm (the KUKA iiwa7 and its bench-top scene), not only the SSRMS.
#include <catch2/catch.hpp>

#include "experiment.hpp"
#include "test_util.hpp"

using namespace orbcal;

TEST_CASE("a standard-DH arm goes through render -> detect -> estimators -> validation", "[e2e][standard-dh]") {
  tools::ExperimentOptions o;
  o.robot = test::sourcePath("scenes/iiwa7.yaml");
  o.scene = test::sourcePath("scenes/iiwa7_scene.yaml");
  o.out = test::tempDir("standard-dh");
  o.identification = 30;
  o.validation = 30;
  o.plots = false;
  o.quiet = true;
  const tools::Table4Result r = tools::runTable4(o);
  REQUIRE(r.identification.dataset.arm.convention == sim::DhConvention::kStandard);
  CHECK(r.identification.observations.size() >= 28);
  const calib::MethodOutcome* ekf = calib::bestOfKind(r.comparison, calib::MethodSpec::Kind::kEkf);
  REQUIRE(ekf != nullptr);
  // Table 3's errors (0.2-0.3 deg, 0.5-1 mm) on a 1.3 m arm; the same 90% bar as seed 000's EKF.
  CHECK(calib::improvement(r.comparison.initial.position_avg_m, ekf->summary.position_avg_m) >= 0.90);
  for (int a = 0; a < 3; ++a) {
    CHECK(calib::improvement(r.comparison.initial.orientation_avg_rad[a], ekf->summary.orientation_avg_rad[a]) >= 0.90);
  }
}
