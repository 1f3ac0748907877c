// One model file for both data paths: an image calibration writes model.yaml (sim/model_io.hpp) as a
// measured-data calibration does, its robot_calibrated.yaml is that model's arm, and `orbcal evaluate`
// predicts measured data of the same arm with it.
#include <catch2/catch.hpp>

#include <filesystem>

#include "orbcal/render/dataset_writer.hpp"
#include "orbcal/sim/camera_io.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/export.hpp"
#include "orbcal/workflow/calibrate.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/model_io.hpp"
#include "run_orbcal.hpp"
#include "test_util.hpp"

using namespace orbcal;

namespace {

/// The names of the geometric parameters of a model's arm (sim::geometryBlock), in the layout's order.
std::vector<std::string> geometryNames(const sim::KinematicModel& m) {
  std::vector<std::string> names;
  for (const sim::ParamInfo& p : sim::geometryBlock(m.arm).params) names.push_back(p.name);
  return names;
}

}  // namespace

TEST_CASE("an image calibration and a measured-data calibration of the same arm write the same kind of model.yaml",
          "[e2e][calibrate][model]") {
  const std::string dir = test::tempDir("image-model");
  render::DatasetJob job;
  job.scene = test::sourcePath("scenes/quick_scene.yaml");
  job.count = 40;
  job.out = dir + "/dataset";
  render::renderDataset(job);
  const sim::Dataset d = sim::loadDataset(job.out);
  const test::OrbcalRun images = test::runOrbcal(dir, "calibrate dataset -o cal-images --quiet --no-plots");
  REQUIRE(images.status == 0);
  CHECK(images.out.find("model: cal-images/model.yaml\n") != std::string::npos);

  // Measured data of the same arm (its frames refitted per session by evaluate), calibrated as such.
  const std::string robot = d.path(d.manifest.robot_file);
  REQUIRE(test::runOrbcal(dir, "simulate --robot '" + robot + "' -o data -n 60 --sessions 1 --seed 3 --base per_session "
                               "--marker per_session --quiet").status == 0);
  REQUIRE(test::runOrbcal(dir, "calibrate data/measurements.yaml -o cal-measured").status == 0);

  // The one loader reads both, to models of the same arm with the same geometry parameters.
  const sim::LoadedModel from_images = sim::loadModelFile(dir + "/cal-images/model.yaml");
  const sim::LoadedModel from_measured = sim::loadModelFile(dir + "/cal-measured/model.yaml");
  CHECK(test::slurp(dir + "/cal-images/model.yaml").find("format: orbcal-model-2\n") != std::string::npos);
  CHECK(from_images.model.arm.numJoints() == from_measured.model.arm.numJoints());
  CHECK(geometryNames(from_images.model) == geometryNames(from_measured.model));
  // The image model's registration: world = the board, marker = the camera, as the scene has them.
  REQUIRE(from_images.model.world_T_base.size() == 1);
  CHECK((from_images.model.world_T_base.front().matrix() - d.scene.base_T_board.inverse().matrix()).norm() < 1e-9);
  CHECK((from_images.model.flange_T_marker.front().matrix() - d.scene.flange_T_camera.matrix()).norm() < 1e-9);

  // robot_calibrated.yaml is the model's arm: the same forward kinematics (and not the nominal arm's).
  const sim::Arm calibrated = sim::loadArm(dir + "/cal-images/robot_calibrated.yaml");
  double same = 0.0, moved = 0.0;
  for (const Eigen::VectorXd& q : test::randomConfigs(d.arm, 20, 5)) {
    const Eigen::Vector3d p = sim::forwardKinematics(calibrated, q).translation();
    same = std::max(same, (sim::forwardKinematics(from_images.model.arm, q).translation() - p).norm());
    moved = std::max(moved, (sim::forwardKinematics(d.arm, q).translation() - p).norm());
  }
  CHECK(same < 1e-9);   // both printed with exact numbers
  CHECK(moved > 1e-5);  // 10 um: the rendered arm's errors were identified into it

  // evaluate takes the image path's model on measured data of the same arm.
  const test::OrbcalRun eval = test::runOrbcal(dir, "evaluate --model cal-images/model.yaml --data data/measurements.yaml -o eval");
  CAPTURE(eval.err);
  CHECK(eval.status == 0);
}

TEST_CASE("an image calibration with --estimate-frames --effects writes the frames and effects it fitted to model.yaml",
          "[e2e][calibrate][model]") {
  // The model written is the one fitted on the detected corners (geometry, both frames, scale on joint 2
  // and the lens distortion); the held-out rule judges that model, and what it writes holds its numbers.
  const std::string dir = test::tempDir("image-model-effects");
  render::DatasetJob job;
  job.scene = test::sourcePath("scenes/quick_scene.yaml");
  job.count = 40;
  job.joint_noise_sigma_rad = 0.0;  // the corner model's R has no joint noise (calib/corner_model.hpp)
  job.out = dir + "/dataset";
  render::renderDataset(job);
  const sim::Dataset d = sim::loadDataset(job.out);
  workflow::CalibrateOptions o;
  o.dataset = job.out;
  o.out = dir + "/cal";
  o.quiet = true;
  o.plots = false;
  o.estimate_frames = true;
  o.effects = {"scale:2", "distortion"};
  const workflow::CalibrateResult r = workflow::runCalibrate(o);
  CAPTURE(r.refusals);
  REQUIRE(r.frames);
  REQUIRE(r.frames->corners);
  REQUIRE(r.written);
  CHECK(r.verdict.gain.configurations == 10);  // 20 % of 40 is 8: the default holds out the 10 the test needs
  CHECK(r.verdict.gain.significant);

  // model.yaml: the corner fit's scale and frames (the loader folds geometry and frames into the model).
  const workflow::CornerEstimate& c = *r.frames->corners;
  const sim::LoadedModel m = sim::loadModelFile(o.out + "/model.yaml");
  const int scale = m.model.layout.find("scale");
  REQUIRE(scale >= 0);
  const int fitted_scale = c.layout.find("scale");
  REQUIRE(fitted_scale >= 0);
  CHECK(m.p[m.model.layout.block(scale).offset] == Approx(c.fit.p[c.layout.block(fitted_scale).offset]).epsilon(1e-9));
  // The frames it holds are the corner fit's (folded from its parameters here), not the scene's.
  const sim::FoldedModel folded = sim::foldParameters(c.model, c.fit.p.head(c.model.layout.size()));
  REQUIRE(m.model.world_T_base.size() == 1);
  CHECK((m.model.world_T_base.front().matrix() - folded.model.world_T_base.front().matrix()).norm() < 1e-9);
  CHECK((m.model.flange_T_marker.front().matrix() - folded.model.flange_T_marker.front().matrix()).norm() < 1e-9);
  CHECK((m.model.world_T_base.front().matrix() - d.scene.base_T_board.inverse().matrix()).norm() > 1e-7);
  // effects.yaml names the same effect and value; estimates.csv lists every parameter of the model.
  const sim::LoadedEffects e = sim::loadEffectsFile(o.out + "/effects.yaml");
  REQUIRE(e.p.size() == 1);
  CHECK(e.p[0] == Approx(m.p[m.model.layout.block(scale).offset]).epsilon(1e-12));
  const sim::CsvTable estimates = sim::CsvTable::parse(test::slurp(o.out + "/estimates.csv"), "estimates.csv");
  CHECK(static_cast<int>(estimates.rows()) == c.layout.size() - 4);  // the distortion block is the camera's
  // The camera with the fitted distortion added, as a camera file a scene reads back.
  const sim::Camera camera = sim::loadCameraFile(o.out + "/camera_calibrated.yaml");
  for (int i = 0; i < 4; ++i) CHECK(camera.distortion[static_cast<std::size_t>(i)] == Approx(d.scene.camera.distortion[static_cast<std::size_t>(i)] + c.dk[i]).margin(1e-15));
  CHECK(camera.fx_px == d.scene.camera.fx_px);
  CHECK(std::filesystem::exists(o.out + "/robot_calibrated.urdf"));
  CHECK(std::filesystem::exists(o.out + "/scene_frames.yaml"));
  // d7 slides the flange along joint 7's axis, as the camera mount's z does: only their combination is
  // determined, and the report's table says so for the model written.
  const std::string report = test::slurp(o.out + "/report.md");
  const std::size_t row = report.find("| d7 | geometry |");
  REQUIRE(row != std::string::npos);
  CHECK(report.substr(row, report.find('\n', row) - row).find("only in a combination with") != std::string::npos);
}
