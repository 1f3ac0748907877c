// The `distortion` effect end to end: lens distortion injected by an error-set file into the rendered
// images (the dataset's scene.yaml keeps the scene's undistorted camera) is recovered by `orbcal
// calibrate --estimate-frames --effects distortion` on the detected corners within 3 sigma; without the
// distortion block the corners fit clearly worse; a clean render gives a distortion within 3 sigma of 0.
#include <catch2/catch.hpp>
#include <random>

#include "orbcal/workflow/calibrate.hpp"
#include "orbcal/render/dataset_writer.hpp"
#include "orbcal/sim/csv.hpp"
#include "test_util.hpp"

using namespace orbcal;

namespace {

workflow::CalibrateResult renderAndCalibrate(const std::string& dir, const std::string& errors) {
  render::DatasetJob job;
  job.scene = test::sourcePath("scenes/quick_scene.yaml");  // no distortion in its camera
  job.count = 60;
  job.errors.name = errors;
  // No joint noise: the corner model's R does not carry it (corner_model.hpp), and its per-image shift
  // of ~0.5 px would hide the ~0.1-0.3 px the distortion moves the corners of a board near the centre.
  job.joint_noise_sigma_rad = 0.0;
  job.out = dir + "/dataset";
  render::renderDataset(job);
  workflow::CalibrateOptions o;
  o.dataset = job.out;
  o.quiet = true;
  o.estimate_frames = true;
  o.effects = {"distortion"};
  return workflow::runCalibrate(o);
}

}  // namespace

TEST_CASE("calibrate --effects distortion recovers lens distortion injected into the rendered images",
          "[e2e][calibrate][distortion]") {
  const std::string dir = test::tempDir("distortion");
  // An uncalibrated or refocused lens: barrel distortion k1 of -0.05..-0.10 with a k2 of 0..0.04 is
  // what a machine-vision lens of this field of view (+-24 deg) shows when its intrinsics are taken as
  // distortion-free or were calibrated at another focus (typical calibrated values: k1 -0.1..-0.3).
  std::mt19937_64 rng(2027);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double dk1 = -(0.05 + 0.05 * u(rng)), dk2 = 0.04 * u(rng);
  test::write(dir + "/errors.yaml", "format: orbcal-errors-1\ngeometry: table3\neffects:\n  - {spec: distortion, parameters: "
                                    "{dk1: " + sim::formatNumber("%.17g", dk1) + ", dk2: " + sim::formatNumber("%.17g", dk2) +
                                    ", dp1: 0, dp2: 0}}\n");
  const workflow::CalibrateResult r = renderAndCalibrate(dir, dir + "/errors.yaml");
  REQUIRE(r.frames);
  REQUIRE(r.frames->corners);
  const workflow::CornerEstimate& c = *r.frames->corners;
  REQUIRE(c.dk_true);
  CAPTURE(dk1, dk2, c.dk.transpose(), c.dk_sigma.transpose(), c.fit.rms_px, c.without.rms_px, c.heldout_rms_px,
          c.heldout_rms_px_without, c.fit.sigma_px);
  WARN("injected dk1 " << dk1 << " dk2 " << dk2 << "; fitted " << c.dk.transpose() << " +- " << c.dk_sigma.transpose()
                       << "; corner RMS " << c.fit.rms_px << " px (without distortion " << c.without.rms_px
                       << " px), held out " << c.heldout_rms_px << " (" << c.heldout_rms_px_without << ") px");
  CHECK((*c.dk_true)[0] == dk1);
  // dk1, dk2 within 3 sigma. The sigmas assume independent corner errors; a detector's errors within
  // one image are correlated, so they are somewhat optimistic: over 4 more seeds (orbcal render +
  // calibrate) dk1 and dk2 stayed within 2.5 sigma, dp1 and dp2 (injected 0) reached 3.5 sigma.
  for (int i = 0; i < 2; ++i) CHECK(std::abs(c.dk[i] - (*c.dk_true)[i]) < 3.0 * c.dk_sigma[i]);
  for (int i = 2; i < 4; ++i) CHECK(std::abs(c.dk[i] - (*c.dk_true)[i]) < 5.0 * c.dk_sigma[i]);
  CHECK(c.dk_sigma[0] < 0.25 * std::abs(dk1));  // resolved, not merely consistent
  CHECK(c.without.rms_px > 1.5 * c.fit.rms_px);
  CHECK(c.heldout_rms_px_without > 1.5 * c.heldout_rms_px);

  const workflow::CalibrateResult clean = renderAndCalibrate(dir + "/clean", "table3");
  REQUIRE(clean.frames);
  REQUIRE(clean.frames->corners);
  const workflow::CornerEstimate& z = *clean.frames->corners;
  CAPTURE(z.dk.transpose(), z.dk_sigma.transpose(), z.fit.rms_px, z.without.rms_px);
  WARN("clean: fitted " << z.dk.transpose() << " +- " << z.dk_sigma.transpose() << "; corner RMS " << z.fit.rms_px
                        << " px (without distortion " << z.without.rms_px << " px)");
  REQUIRE(z.dk_true);
  CHECK(z.dk_true->isZero());
  for (int i = 0; i < 2; ++i) CHECK(std::abs(z.dk[i]) < 3.0 * z.dk_sigma[i]);
  for (int i = 2; i < 4; ++i) CHECK(std::abs(z.dk[i]) < 5.0 * z.dk_sigma[i]);
}

TEST_CASE("calibrate --effects on an image dataset needs --estimate-frames", "[e2e][calibrate][distortion]") {
  workflow::CalibrateOptions o;
  o.dataset = test::tempDir("distortion-flags");
  o.effects = {"distortion"};
  CHECK_THAT(test::inputError([&] { workflow::runCalibrate(o); }), Catch::Contains("--estimate-frames"));
  o.estimate_frames = true;
  o.effects = {"distortion:2"};
  CHECK_THAT(test::inputError([&] { workflow::runCalibrate(o); }), Catch::Contains("distortion takes no joints"));
}
