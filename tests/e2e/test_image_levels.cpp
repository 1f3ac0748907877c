// Images with joint readings calibrate the robot's parameters through the one pipeline of image descriptions
// (workflow::calibrateImageViews, calib/corner_levels.hpp): a rendered eye-in-hand set of the SSRMS whose true arm
// has seeded joint-offset errors of a few tenths of a degree (joints 2-6; joints 1 and 7 turn about the axes the
// board's and the camera's frames already turn about, so no set of views can tell their offsets from the frames)
// and whose camera mount (the scene's flange_T_camera) the description does not give. `--level offsets` must find
// the offsets within 4 of their 1-sigma and predict the held-out views better than the frames level; auto must not
// stay at frames. A description without joint readings refuses a robot level with one line naming --level.
#include <catch2/catch.hpp>
#include <random>

#include "orbcal/render/dataset_writer.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/image_views.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/workflow/measured_images.hpp"
#include "test_util.hpp"

using namespace orbcal;

namespace {

/// The rendered set and its image description; `offsets_deg` the hidden theta errors (one per joint).
sim::ImageViews renderedSet(const std::string& dir, const std::vector<double>& offsets_deg) {
  std::string errors = "format: orbcal-errors-1\ngeometry:\n";
  for (double o : offsets_deg) errors += "  - {theta_deg: " + sim::formatNumber("%.17g", o) + ", alpha_deg: 0, a_mm: 0, d_mm: 0}\n";
  test::write(dir + "/errors.yaml", errors);
  render::DatasetJob job;
  job.scene = test::sourcePath("scenes/quick_scene.yaml");
  job.count = 20;
  job.errors.name = dir + "/errors.yaml";
  job.joint_noise_sigma_rad = 0.0;  // the corner model's R does not carry joint noise (corner_model.hpp)
  job.out = dir + "/dataset";
  render::renderDataset(job);
  test::write(job.out + "/images.yaml",
              "format: orbcal-measurements-1\nrobot: robot.yaml\nfiles: [samples.csv]\n"
              "joints: {columns: [q1_rad, q2_rad, q3_rad, q4_rad, q5_rad, q6_rad, q7_rad], unit: rad}\nimages: {column: image}\n"
              "camera: {width_px: 640, height_px: 512, fx_px: 700.0, fy_px: 700.0, cx_px: 321.4, cy_px: 254.2, distortion: [0, 0, 0, 0, 0]}\n"
              "board: {chessboard: {squares: [10, 7], square_mm: 80}}\nsetup: eye_in_hand\n");
  return sim::loadImageViews(job.out + "/images.yaml");
}

}  // namespace

TEST_CASE("images with joint readings: --level offsets finds hidden joint offsets, auto leaves the frames level",
          "[e2e][real-images][image-levels]") {
  const std::string dir = test::tempDir("image-levels");
  std::mt19937_64 rng(29);
  std::uniform_real_distribution<double> size(0.1, 0.4);
  std::vector<double> offsets_deg(7, 0.0);
  for (int j = 1; j < 6; ++j) offsets_deg[static_cast<std::size_t>(j)] = (rng() % 2 ? 1.0 : -1.0) * size(rng);
  const sim::ImageViews data = renderedSet(dir, offsets_deg);
  REQUIRE(data.arm);
  const std::vector<vision::ViewMeasurement> det = workflow::detectImageViews(data);

  const workflow::ImageCalibrateResult r = workflow::calibrateImageViews(data, det, calib::parseLevel("offsets", "--level"));
  CAPTURE(r.refusals, r.level_sentence, r.heldout_rms_mm, r.frames_heldout_rms_mm);
  REQUIRE(r.robot);
  CHECK(r.level.kind == calib::LevelKind::kOffsets);
  CHECK(r.refusals.empty());
  REQUIRE(r.tried.size() == 1);
  CHECK(r.tried[0].verdict.gain.significant);
  // The frames level cannot absorb 0.1-0.4 deg offsets of a 7 m arm (tens of mm at the camera); the offsets level
  // predicts the held-out views at the corners' own scale.
  CHECK(r.heldout_rms_mm < 0.05 * r.frames_heldout_rms_mm);
  const calib::CornerLevelFit& f = *r.robot;
  const int g = f.start.layout.block(f.start.layout.find(sim::BlockKind::kGeometry)).offset;
  for (int j = 1; j < 6; ++j) {
    const int i = g + 4 * j;  // theta of joint j + 1
    REQUIRE(f.start.layout.param(i).name == "theta" + std::to_string(j + 1));
    REQUIRE_FALSE(std::binary_search(f.estimate.held.begin(), f.estimate.held.end(), i));
    const double fitted_deg = f.p[i] * sim::kRadToDeg, sigma_fit = std::sqrt(f.estimate.covariance(i, i)) * sim::kRadToDeg;
    const double sigma = std::max(sigma_fit, r.robot_sigma[i] * sim::kRadToDeg);
    CAPTURE(j + 1, offsets_deg[static_cast<std::size_t>(j)], fitted_deg, sigma_fit, r.robot_sigma[i] * sim::kRadToDeg);
    CHECK(std::abs(fitted_deg - offsets_deg[static_cast<std::size_t>(j)]) < 4.0 * sigma);
    CHECK(sigma < 0.01);  // resolved: a small fraction of the 0.1 deg smallest offset
  }
  // The camera mount the description does not give: the scene's {xyz_m: [0.25, 0, 0.10], rpy_deg: [0, 0, 90]}.
  const Eigen::Isometry3d truth = sim::fromXyzRpy(Eigen::Vector3d(0.25, 0.0, 0.10), Eigen::Vector3d(0.0, 0.0, 90.0) * sim::kDegToRad);
  const sim::Vector6d d = sim::poseMinus(r.hand_T_eye, truth);
  CAPTURE(d.transpose(), r.hand_sigma.transpose());
  for (int a = 0; a < 6; ++a) CHECK(std::abs(d[a]) < 4.0 * r.hand_sigma[a]);

  const workflow::ImageCalibrateResult a = workflow::calibrateImageViews(data, det, calib::parseLevel("auto", "--level"));
  CAPTURE(a.level_sentence, a.refusals);
  CHECK(a.level.kind != calib::LevelKind::kFrames);
  CHECK(a.tried.size() == 3);
  CHECK(a.robot);

  // Without joint readings a robot level is refused before any fit, naming the option.
  sim::ImageViews poses = data;
  poses.arm.reset();
  try {
    workflow::calibrateImageViews(poses, det, calib::parseLevel("offsets", "--level"));
    FAIL("a robot level without joint readings was accepted");
  } catch (const sim::InputError& e) {
    CHECK_THAT(e.what(), Catch::StartsWith("--level: offsets: "));
    CHECK(std::string(e.what()).find('\n') == std::string::npos);
  }
}
