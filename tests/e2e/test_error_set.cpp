// `--errors FILE`: an error-set file with a physical effect reaches the rendered images, the dataset,
// the calibration's truth comparison and the experiment's floor.
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>

#include "orbcal/workflow/calibrate.hpp"
#include "orbcal/workflow/experiment.hpp"
#include "orbcal/render/dataset_writer.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/sim/truth.hpp"
#include "test_util.hpp"

using namespace orbcal;
using Catch::Matchers::Contains;
using orbcal::test::slurp;

namespace {

// Table 3 + a transmission error on joint 2 big enough to see: 0.05 deg sin(q2) + 0.02 deg cos(2 q2).
constexpr double kA1 = 0.05 * sim::kDegToRad, kB2 = 0.02 * sim::kDegToRad;
std::string cyclicFile(double a1) {
  return "format: orbcal-errors-1\ngeometry: table3\neffects:\n  - {spec: \"cyclic:2\", parameters: {cyclic2_sin1: " +
         sim::formatNumber("%.17g", a1) + ", cyclic2_cos1: 0, cyclic2_sin2: 0, cyclic2_cos2: " +
         sim::formatNumber("%.17g", kB2) + "}}\n";
}

}  // namespace

TEST_CASE("render with an error-set file: the camera sees the geared arm, errors.yaml copied, resumed, compared",
          "[e2e][error-set]") {
  const std::string dir = test::tempDir("error-set-render");
  const std::string errors = dir + "/cyclic.yaml";
  test::write(errors, cyclicFile(kA1));
  render::DatasetJob job;
  job.scene = test::sourcePath("scenes/quick_scene.yaml");
  job.count = 20;
  job.errors.name = errors;
  job.configuration_seed = job.noise_seed = job.render_seed = 3;
  job.out = dir + "/ds";
  const render::DatasetRunReport first = render::renderDataset(job);
  CHECK(first.rendered == 20);

  // The dataset stands alone: the file copied in, named by the manifest, the DH part as true_errors.
  CHECK(slurp(job.out + "/errors.yaml") == slurp(errors));
  const sim::Dataset d = sim::loadDataset(job.out);
  CHECK(d.manifest.error_set == "file");
  CHECK(d.manifest.error_set_file == "errors.yaml");
  REQUIRE(d.manifest.true_errors);
  const Eigen::VectorXd y = sim::paperTable3Errors();
  CHECK((*d.manifest.true_errors - y).cwiseAbs().maxCoeff() < 1e-15);
  const std::optional<sim::TrueArm> truth = sim::datasetTrueArm(d);
  REQUIRE(truth);
  CHECK(truth->hasEffects());

  // The ground truth the renderer drew, against the formula at the true joints: joint 2 turned by
  // a1 sin(q2) + b2 cos(2 q2). Against the same arm without the effect it moves by that much.
  const sim::Arm geometric = sim::withErrors(d.arm, y);
  double largest = 0.0;
  REQUIRE(d.samples.size() == 20);
  for (const sim::DatasetSample& s : d.samples) {
    CAPTURE(s.index);
    REQUIRE(s.q_true_rad);
    REQUIRE(s.camera_T_board_true);
    Eigen::VectorXd turned = *s.q_true_rad;
    turned[1] += kA1 * std::sin(turned[1]) + kB2 * std::cos(2.0 * turned[1]);
    const Eigen::Isometry3d expected = sim::cameraTBoard(geometric, d.scene, turned);
    const Eigen::Isometry3d plain = sim::cameraTBoard(geometric, d.scene, *s.q_true_rad);
    CHECK((s.camera_T_board_true->matrix() - expected.matrix()).cwiseAbs().maxCoeff() < 1e-9);
    const double moved = (s.camera_T_board_true->translation() - plain.translation()).norm();
    const double moved_expected = (expected.translation() - plain.translation()).norm();
    CHECK(std::abs(moved - moved_expected) < 1e-9);
    largest = std::max(largest, moved);
  }
  CAPTURE(largest);
  CHECK(largest > 0.5e-3);  // the board seen half a millimetre or more away from where the DH errors alone put it

  // The same command again resumes: nothing rendered.
  const render::DatasetRunReport again = render::renderDataset(job);
  CHECK(again.resumed);
  CHECK(again.rendered == 0);
  CHECK(again.skipped == 20);

  // The truth comparison of `orbcal calibrate` uses the true arm with its effect.
  workflow::CalibrateOptions co;
  co.dataset = job.out;
  co.quiet = true;
  const workflow::CalibrateResult cal = workflow::runCalibrate(co);
  REQUIRE(cal.has_truth);
  CHECK_THAT(slurp(cal.report_path), Contains("effects of `errors.yaml`") && Contains("cyclic2_sin1 +0.05"));

  // A changed error-set file (same DH errors, so the manifest is the same) is refused, naming errors.yaml.
  test::write(errors, cyclicFile(2.0 * kA1));
  REQUIRE_THROWS_WITH(render::renderDataset(job), Contains(job.out + "/manifest.yaml") && Contains("differs: errors.yaml") &&
                                                      Contains("--force"));
  render::DatasetJob forced = job;
  forced.force = true;
  CHECK(render::renderDataset(forced).rendered == 20);
  CHECK(slurp(job.out + "/errors.yaml") == cyclicFile(2.0 * kA1));

  // A named set in the folder of a file's dataset: refused (true_errors.name, .file); forced, errors.yaml goes.
  render::DatasetJob named = job;
  named.errors.name = "table3";
  REQUIRE_THROWS_WITH(render::renderDataset(named), Contains("true_errors.name") && Contains("true_errors.file"));
  named.force = true;
  render::renderDataset(named);
  CHECK_FALSE(std::filesystem::exists(job.out + "/errors.yaml"));
  CHECK(sim::loadDataset(job.out).manifest.error_set_file.empty());
}

TEST_CASE("orbcal run with an error-set file: the report lists the effect, the floor is the true model's",
          "[e2e][error-set]") {
  const std::string dir = test::tempDir("error-set-run");
  workflow::ExperimentOptions o;
  o.scene = test::sourcePath("scenes/quick_scene.yaml");
  o.errors.name = dir + "/cyclic.yaml";
  test::write(o.errors.name, cyclicFile(kA1));
  o.out = dir + "/out";
  o.identification = 20;
  o.validation = 20;
  o.plots = false;
  o.quiet = true;
  const workflow::Table4Result r = workflow::runTable4(o, "main");
  const calib::Comparison& c = r.comparison;

  // The floor is the true model with its effect at the commanded joints: what the control noise alone
  // leaves. The DH errors alone leave the cyclic error on top.
  const sim::TrueArm truth = *sim::datasetTrueArm(r.validation.dataset);
  const sim::Arm geometric = sim::withErrors(r.validation.dataset.arm, truth.geometryErrors());
  const calib::ErrorSummary dh_only = calib::summarize(calib::poseErrors(geometric, r.validation.plant));
  CAPTURE(c.floor.position_avg_m, dh_only.position_avg_m);
  CHECK(c.floor.position_avg_m == calib::summarize(calib::poseErrors(truth, r.validation.plant)).position_avg_m);
  CHECK(c.floor.position_avg_m < 0.9 * dh_only.position_avg_m);
  // The plant's true poses are the rendered ones (the camera's ground truth back to the flange).
  for (std::size_t k = 0; k < r.validation.dataset.samples.size(); ++k) {
    const sim::DatasetSample& s = r.validation.dataset.samples[k];
    const Eigen::Isometry3d base_T_flange = r.validation.dataset.scene.base_T_board * s.camera_T_board_true->inverse() *
                                            r.validation.dataset.scene.flange_T_camera.inverse();
    CHECK((base_T_flange.matrix() - r.validation.plant.base_T_flange_true[k].matrix()).cwiseAbs().maxCoeff() < 1e-9);
  }
  // The report lists the injected effect in display units under the injected errors.
  const std::string report = slurp(r.report_path);
  CHECK_THAT(report, Contains("Injected errors") && Contains("Injected effects") && Contains("cyclic2_sin1 +0.05") &&
                         Contains("cyclic2_cos2 +0.02"));
  CHECK(report.find("Injected errors") < report.find("Injected effects"));
}
