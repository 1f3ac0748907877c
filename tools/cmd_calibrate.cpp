// `orbcal calibrate <dataset | description.yaml>`: the parameter errors from a dataset's images and
// joint readings, or geometry + registration + effects from measured data (a measurement description).
#include <cstdio>
#include <filesystem>
#include <optional>

#include "orbcal/workflow/calibrate.hpp"
#include "cli.hpp"
#include "figures.hpp"
#include "orbcal/workflow/measured.hpp"
#include "orbcal/workflow/measured_images.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/effect_syntax.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::tools {

namespace {

/// A description of images: its refusals on stderr, then the frames, the cross-validated residuals and the files.
void printImageViews(const workflow::ImageCalibrateResult& r, const std::string& description) {
  for (const std::string& why : r.refusals) std::fprintf(stderr, "orbcal: calibrate: %s: %s\n", description.c_str(), why.c_str());
  for (const std::string& w : r.warnings) std::fprintf(stderr, "orbcal: calibrate: warning: %s\n", w.c_str());
  std::printf("%zu images, board found in %d (%d configurations); %s\n", r.views.size(), r.used, r.configurations,
              sim::handEyeSetupName(r.setup));
  std::printf("%s\n", r.level_sentence.c_str());
  if (r.fit.corners > 0 && r.cross_validated) {
    const Eigen::Vector3d t = r.hand_T_eye.translation() * 1e3;
    std::printf("%s: [%.2f, %.2f, %.2f] mm (1-sigma per axis at most %.2f mm, %.3f deg)\n",
                r.setup == sim::HandEyeSetup::kEyeInHand ? "flange_T_camera" : "flange_T_board", t.x(), t.y(), t.z(),
                r.hand_sigma.head<3>().maxCoeff() * 1e3, r.hand_sigma.tail<3>().maxCoeff() * sim::kRadToDeg);
    std::printf("cross-validated per-view residual RMS: %.3f px, %.3f mm (closed form %.3f px, %.3f mm; fitted %.3f px, %.3f mm; "
                "detection noise %.3f px)\n",
                r.heldout_rms_px, r.heldout_rms_mm, r.heldout_start_rms_px, r.heldout_start_rms_mm, r.fitted_rms_px, r.fitted_rms_mm,
                r.detection_sigma_px);
  }
  if (!r.frames_path.empty()) std::printf("frames: %s\n", r.frames_path.c_str());
  std::printf("report: %s\n", r.report_path.c_str());
}

void printMeasured(const workflow::MeasuredCalibrateResult& r, const std::string& description) {
  if (r.images) return printImageViews(*r.images, description);
  const char* not_written = r.model_path.empty() ? "; model.yaml not written (--accept-worse writes it)" : "";
  const auto refused = [&](const std::string& why) {
    std::fprintf(stderr, "orbcal: calibrate: %s: %s%s\n", description.c_str(), why.c_str(), not_written);
  };
  for (const std::string& w : r.warnings) std::fprintf(stderr, "warning: %s: %s\n", description.c_str(), w.c_str());
  for (const std::string& why : r.refusals) refused(why);
  std::printf("%s\n", calib::levelSentence(r.level).c_str());
  std::printf("%d samples: %d fitted, %d held out; %d parameters, %zu held (by the level or as unidentifiable)\n", r.samples,
              r.identification, r.held_out, r.fit.model.layout.size(), r.fit.estimate.held.size());
  std::printf("noise (1 sigma per axis): %s%s\n", workflow::noiseText(r.fit.noise, r.fit.residuals.rotation_samples > 0).c_str(),
              r.fit.noise_estimated ? " (estimated)" : "");
  if (r.cross_validated) {
    std::printf("cross-validated position RMS (each of the %d configurations predicted by fits to the others): nominal arm %.4f mm -> "
                "calibrated %.4f mm (t = %.2f, p = %.2g)\n", r.gain.configurations, r.heldout_before.position_rms_m * 1e3,
                r.heldout_after.position_rms_m * 1e3, r.gain.t, r.gain.p_value);
  }
  if (r.fit.prior_scale > 0.0) {
    std::printf("map: the geometry's prior at %.3g times its typical sizes leaves %.1f effective parameters\n", r.fit.prior_scale,
                r.fit.effective_parameters);
  }
  if (r.held_out > 0) {
    std::printf("held-out position RMS: nominal arm %.4f mm -> calibrated %.4f mm (max %.4f -> %.4f mm)\n",
                r.heldout_before.position_rms_m * 1e3, r.heldout_after.position_rms_m * 1e3, r.heldout_before.position_max_m * 1e3,
                r.heldout_after.position_max_m * 1e3);
  }
  for (const std::string& w : r.extrapolation) std::printf("held out beyond the fitted range: %s\n", w.c_str());
  if (!r.structure_left.empty()) std::printf("%s.\n", r.structure_left.c_str());
  if (!r.model_path.empty()) std::printf("model: %s\n", r.model_path.c_str());
  std::printf("report: %s\n", r.report_path.c_str());
}

/// What an image calibration prints: its refusals on stderr, then the split, the gain and the files.
void printImages(const workflow::CalibrateResult& r) {
  for (const std::string& line : r.refusals) std::fprintf(stderr, "orbcal: calibrate: %s\n", line.c_str());
  if (!r.refusals.empty() && !r.written) {
    std::fprintf(stderr, "orbcal: calibrate: no calibrated robot file written (--accept-worse writes it); report: %s\n",
                 r.report_path.c_str());
  }
  std::printf("%d images, %d usable: %d for identification, %d held out; model %s (rank %d of %d)\n", r.images, r.usable,
              r.identification, r.held_out, r.model.c_str(), r.classes.rank, static_cast<int>(r.classes.names.size()));
  std::printf("%s\n", workflow::formatKeptAndHeld(r.classes).c_str());
  if (r.held_out > 0) {
    std::printf("held-out camera position RMS: nominal arm %.4f mm -> model %.4f mm (%d configurations; t = %.2f, p = %.2g)\n",
                r.verdict.gain.before_rms_m * 1e3, r.verdict.gain.after_rms_m * 1e3, r.verdict.gain.configurations,
                r.verdict.gain.t, r.verdict.gain.p_value);
    std::printf("held-out average flange position error of the DH estimate, scene frames: %.3f mm -> %.3f mm (%.1f%%)\n",
                r.before.position_avg_m * 1e3, r.after.position_avg_m * 1e3,
                100.0 * calib::improvement(r.before.position_avg_m, r.after.position_avg_m));
  }
  if (r.relative_before) {
    std::printf("held-out pairs with the first identification image:");
    if (r.relative_before->distance_pairs > 0) {
      std::printf(" distance RMS %.4f -> %.4f mm", r.relative_before->distance_rms_m * 1e3, r.relative_after->distance_rms_m * 1e3);
    }
    if (r.relative_before->angle_pairs > 0) {
      std::printf(" angle RMS %.5f -> %.5f deg", r.relative_before->angle_rms_rad * sim::kRadToDeg,
                  r.relative_after->angle_rms_rad * sim::kRadToDeg);
    }
    std::printf("\n");
  }
  if (r.has_truth) {
    std::printf("held-out average position error against the true poses: %.3f mm -> %.3f mm\n",
                r.truth_before.position_avg_m * 1e3, r.truth_after.position_avg_m * 1e3);
  }
  if (r.frames) {
    std::printf("with base_T_board and flange_T_camera estimated: held-out camera position RMS %.4f mm (nominal arm, frames "
                "refitted: %.4f mm); chi-square %.1f for %d degrees of freedom\n",
                r.frames->heldout_after.position_rms_m * 1e3, r.frames->heldout_before.position_rms_m * 1e3, r.frames->fit.chi2,
                r.frames->fit.dof);
  }
  if (r.frames && r.frames->corners) {
    const workflow::CornerEstimate& ce = *r.frames->corners;
    std::printf("on the detected corners: residual RMS %.4f px (held out %.4f px)", ce.fit.rms_px, ce.heldout_rms_px);
    if (ce.distortion) {
      std::printf("; without the distortion block %.4f px (held out %.4f px)\n", ce.without.rms_px, ce.heldout_rms_px_without);
      for (int i = 0; i < 4; ++i) {
        std::printf("  %s %+.5f +- %.5f%s", ce.layout.param(ce.layout.size() - 4 + i).name.c_str(), ce.dk[i], ce.dk_sigma[i],
                    ce.dk_true ? sim::formatNumber(" (injected %+.5f)", (*ce.dk_true)[i]).c_str() : "");
        std::printf("\n");
      }
    } else {
      std::printf("\n");
    }
  }
  std::printf("consistency%s: %s\n", r.frames ? " of the DH estimate with the scene's frames" : "",
              calib::formatConsistency(r.consistency).c_str());
  if (r.written) std::printf("model: %s\n", r.model_path.c_str());
  if (r.written) std::printf("calibrated robot: %s\n", r.robot_path.c_str());
  if (r.written && !r.urdf_path.empty()) std::printf("calibrated URDF: %s\n", r.urdf_path.c_str());
  std::printf("report: %s\n", r.report_path.c_str());
}

void addCalibrateCommand(CLI::App& app) {
  struct Opts {
    workflow::CalibrateOptions images;
    workflow::MeasuredCalibrateOptions measured;
    std::string method;
    std::string level = "auto";
    std::optional<double> holdout;  ///< empty: calib::defaultHoldout
    std::uint64_t seed = 1;
    std::string out;
    double noise_position_mm = -1, noise_rotation_deg = -1;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand(
      "calibrate",
      "Calibrate an arm. From an image dataset (folder): the DH errors (with --estimate-frames also base_T_board and "
      "flange_T_camera, and with --effects the effects, fitted on the detected corners). From measured data (a "
      "measurement description, .yaml): geometry + the unknown registration frames + the chosen effects (--effects). "
      "Both are written as model.yaml (and, for other programs, robot_calibrated.urdf, frames.yaml, effects.yaml), with "
      "report.md and report.html (every file written: docs/reports.md). "
      "Both are judged by one rule on held-out configurations: a model that predicts them worse than the nominal arm, or "
      "not significantly better, a fit inconsistent with its noise (chi-square test; measured data: when the noise is "
      "given), is refused (exit 1, no calibrated file) unless --accept-worse. Measured data whose registration or "
      "calibrated geometry no real arm can show (wrong units or quaternion order) are refused at once.");
  cmd->add_option("dataset", o->images.dataset, "image dataset folder, or measurement description (.yaml)")->required();
  cmd->add_option("--method", o->method,
                  "estimator, for images and measured data alike: " + calib::methodNames() + " (default " +
                      calib::kDefaultMethod + ")");
  cmd->add_option("--effects", o->measured.effects,
                  "effects to fit, e.g. compliance:2,4 cyclic:2/3; the catalog: " + sim::effectSyntaxList() +
                      " (J a joint from 1, K the order: cyclic:2/3 has 3 harmonics); image datasets (with --estimate-frames, "
                      "fitted on the detected corners): these and distortion (lens distortion the scene's camera lacks)");
  cmd->add_option("--level", o->level,
                  "measured data: which geometric parameters are free: frames (the registration frames only, the nominal "
                  "geometry kept), offsets (joint zero offsets + frames), map (every parameter, the geometry shrunk toward the "
                  "nominal arm by a prior of typical sizes whose strength the data set: a maximum a-posteriori fit), full "
                  "(every identifiable parameter), a list of parameter names (theta1,theta3,d2; + frames), or auto: the "
                  "level of the smallest held-out error in cross-validation repeated with several splits of the fitted "
                  "configurations. Effects come on top")
      ->capture_default_str();
  cmd->add_option_function<double>(
         "--joint-noise-deg", [o](double d) { o->images.joint_noise_sigma_rad = d * sim::kDegToRad; },
         "images: joint noise carried into R, 1 sigma [deg] (default: the manifest's, else 0.01)")
      ->check(CLI::Range(0.0, sim::kMaxNoiseJointDeg));
  cmd->add_option("--noise-position-mm", o->noise_position_mm,
                  "measured data: tracker position noise, 1 sigma per axis [mm] (default: the description's, else estimated)")
      ->check(CLI::Range(sim::kMinNoisePositionMm, sim::kMaxNoisePositionMm));
  cmd->add_option("--noise-rotation-deg", o->noise_rotation_deg,
                  "measured data: tracker rotation noise, 1 sigma per axis [deg] (default: the description's, else estimated)")
      ->check(CLI::Range(sim::kMinNoiseRotationDeg, sim::kMaxNoiseRotationDeg));
  cmd->add_option_function<double>(
         "--holdout", [o](double h) { o->holdout = h; },
         "share of the configurations (an image dataset's: of its usable images) kept out for validation, whole "
         "configurations, seeded (default: " + sim::formatNumber("%g", calib::kDefaultHoldoutShare) + ", raised to hold out " +
             std::to_string(calib::kMinHeldoutConfigurations) + " where as many are left to fit). A model is accepted when at least " +
             std::to_string(calib::kMinHeldoutConfigurations) + " are held out and it predicts them better than the nominal arm, "
             "significantly at p < " + sim::formatNumber("%g", calib::kHeldoutGainAlpha) + " (one rule for images and measured data)")
      ->check(CLI::Range(0.0, 0.9));
  cmd->add_option("--seed", o->seed, "seed of the hold-out draw")->capture_default_str();
  cmd->add_flag("--accept-worse", o->measured.accept_worse,
                "write the calibrated files even if the fit is inconsistent with its noise, predicts the held-out configurations "
                "worse, or its held-out gain is not significant (the report and the terminal say so first)");
  cmd->add_option("-o,--out", o->out, "output folder (default: calibration/ beside the dataset or description, with an image dataset's "
                 "measurements.csv in the dataset folder); with -o, everything (measurements.csv too) goes to OUT and "
                 "the dataset folder is only read");
  cmd->add_flag("--quiet", o->images.quiet, "no progress output");
  cmd->add_flag("--no-plots", [o](std::int64_t) { o->images.plots = false; }, "do not draw the report's figures");
  cmd->add_option("--model", o->images.model,
                  "images: what of each camera pose is used: pose (absolute, through the scene's base_T_board; Wang et al. "
                  "2023), position, or between pairs of images, frame-free (no base_T_board needed; Jia et al. 2019): "
                  "distance, rotation, dr (both)")
      ->capture_default_str()
      ->check(CLI::IsMember({"pose", "position", "distance", "rotation", "dr"}));
  cmd->add_option("--pairs", o->images.pairs, "images, relative models: each image against the first, or consecutive")
      ->capture_default_str()
      ->check(CLI::IsMember({"reference", "consecutive"}));
  cmd->add_flag("--estimate-frames", o->images.estimate_frames,
                "images: also estimate base_T_board and flange_T_camera with the DH errors (report + frames.yaml)");
  cmd->callback([o] {
    if (std::filesystem::is_regular_file(o->images.dataset)) {
      if (o->images.model != "pose" || o->images.pairs != "reference") {
        throw sim::InputError("--model/--pairs: for image datasets; a measurement description says what it measures "
                              "(pose, or position only) in its pose: section");
      }
      workflow::MeasuredCalibrateOptions m = o->measured;
      m.description = o->images.dataset;
      m.method = workflow::parseFitMethod(o->method.empty() ? calib::kDefaultMethod : o->method, "--method");
      m.level = calib::parseLevel(o->level, "--level");
      m.holdout = o->holdout;
      m.seed = o->seed;
      m.out = o->out;
      m.plots = o->images.plots;
      m.callbacks = terminalCallbacks(m.plots);
      if (o->noise_position_mm > 0) m.noise_position_m = o->noise_position_mm * 1e-3;
      if (o->noise_rotation_deg > 0) m.noise_rotation_rad = o->noise_rotation_deg * sim::kDegToRad;
      const workflow::MeasuredCalibrateResult r = workflow::runMeasuredCalibrate(m);
      printMeasured(r, m.description);
      if (!r.refusals.empty() && !m.accept_worse) throw CLI::RuntimeError(1);
      return;
    }
    if (o->level != "auto") throw sim::InputError("--level: for measured data (a measurement description)");
    workflow::CalibrateOptions c = o->images;
    c.effects = o->measured.effects;  // with --estimate-frames (workflow::runCalibrate says so otherwise)
    c.method = o->method.empty() ? calib::kDefaultMethod : o->method;
    c.holdout = o->holdout;
    c.seed = o->seed;
    c.out = o->out;
    c.accept_worse = o->measured.accept_worse;
    c.callbacks = terminalCallbacks(c.plots);
    const workflow::CalibrateResult r = workflow::runCalibrate(c);
    printImages(r);
    if (!r.refusals.empty() && !c.accept_worse) throw CLI::RuntimeError(1);
  });
}

}  // namespace

ORBCAL_COMMAND(45, addCalibrateCommand);

}  // namespace orbcal::tools
