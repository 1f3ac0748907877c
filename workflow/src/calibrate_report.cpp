// The report and the files of an image calibration (calibrate.hpp).
#include <algorithm>
#include <cmath>
#include <sstream>

#include "calibrate_detail.hpp"
#include "orbcal/calib/diagnose.hpp"
#include "orbcal/sim/camera_io.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/model_io.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/sim/urdf.hpp"
#include "orbcal/workflow/experiment.hpp"
#include "orbcal/workflow/measured.hpp"

namespace orbcal::workflow {

using namespace calibrate_detail;

/// "theta1, x1, ..." for the parameters `which` (or "none").
std::string calibrate_detail::parameterList(const calib::ParameterClasses& classes, const std::vector<int>& which) {
  std::vector<std::string> names;
  for (int i : which) names.push_back(classes.names[static_cast<std::size_t>(i)]);
  return names.empty() ? std::string("none") : joinWords(names);
}

std::string formatKeptAndHeld(const calib::ParameterClasses& classes) {
  const auto list = [&](const std::vector<int>& which) { return parameterList(classes, which); };
  return "identifiable set: " + std::to_string(classes.minimal.size()) + " of " + std::to_string(classes.names.size()) +
         " parameters kept (" + list(classes.minimal) + "); " + std::to_string(classes.held.size()) + " held as unidentifiable (" +
         list(classes.held) + ")";
}

namespace {

std::string frameDifference(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  const Eigen::Isometry3d d = a.inverse() * b;
  return formatNumber("%.3f", d.translation().norm() * 1e3) + " mm, " +
         formatNumber("%.4f", sim::rotationAngle(d.linear()) * sim::kRadToDeg) + " deg";
}

std::string cornerSection(const CornerEstimate& c) {
  std::ostringstream md;
  md << "## Effects fitted on the detected corners\n\n"
     << "Geometry, both frames";
  for (const sim::Effect& e : c.effects) md << ", `" << sim::formatEffect(e) << "`";
  if (c.distortion) md << " and the lens distortion the scene's camera does not model (`distortion`)";
  md << ", by LM on the corner model (every detected corner against its projection; closed-form frame start). Pixel "
     << "noise estimated from the residuals: " << formatNumber("%.4f", c.fit.sigma_px) << " px (joint noise is not in R: "
     << "it counts as pixel noise); " << c.fit.estimate.held.size() << " parameters held as unidentifiable.\n\n"
     << "Corner residual RMS: " << formatNumber("%.4f", c.fit.rms_px) << " px fitted, "
     << formatNumber("%.4f", c.heldout_rms_px) << " px held out";
  if (c.distortion) {
    md << " (without the distortion block: " << formatNumber("%.4f", c.without.rms_px) << " px fitted, "
       << formatNumber("%.4f", c.heldout_rms_px_without) << " px held out)";
  }
  md << ".\n\n";
  const int off = c.layout.size() - 4;
  if (c.distortion) {
    md << "| distortion | estimate +- 1 sigma |" << (c.dk_true ? " injected |" : "") << "\n|---|---|" << (c.dk_true ? "---|" : "")
       << "\n";
    for (int i = 0; i < 4; ++i) {
      md << "| " << c.layout.param(off + i).name << " | " << formatNumber("%+.5f", c.dk[i]) << " +- "
         << formatNumber("%.5f", c.dk_sigma[i]) << " |";
      if (c.dk_true) md << " " << formatNumber("%+.5f", (*c.dk_true)[i]) << " |";
      md << "\n";
    }
    md << "\n(added to the scene camera's k1, k2, p1, p2; dimensionless)\n\n";
  }
  if (!c.effects.empty()) {
    md << "| effect parameter | estimate +- 1 sigma |\n|---|---|\n";
    for (const sim::ParamBlock& b : c.layout.blocks()) {
      using K = sim::BlockKind;
      if (b.kind == K::kGeometry || b.kind == K::kBase || b.kind == K::kMarker || b.kind == K::kCamera) continue;
      for (int i = 0; i < b.size(); ++i) {
        const int k = b.offset + i;
        const sim::ParamInfo& info = c.layout.param(k);
        const bool held = std::binary_search(c.fit.estimate.held.begin(), c.fit.estimate.held.end(), k);
        md << "| " << info.name << " | " << formatNumber("%+.5g", c.fit.p[k] * info.display_scale) << " "
           << info.display_unit
           << (held ? " (held)"
                    : " +- " + formatNumber("%.3g", std::sqrt(std::max(0.0, c.fit.estimate.covariance(k, k))) *
                                                         info.display_scale))
           << " |\n";
      }
    }
    md << "\n" << sim::signConventions(c.effects);
  }
  return md.str();
}


/// The problems first, in the report: what failed and what was (not) written.
std::string refusalSection(const CalibrateResult& r, bool accept_worse) {
  if (r.refusals.empty()) return "";
  std::string out = "**This calibration is not to be trusted as it is:**\n\n";
  for (const std::string& line : r.refusals) out += "- " + line + "\n";
  out += accept_worse ? "\nThe calibrated files were written all the same because --accept-worse was given.\n\n"
                      : "\nNo calibrated robot file was written (--accept-worse writes it).\n\n";
  return out;
}

/// The identification set, its identifiability and the table of the model's parameters (+- 1 sigma, truth where known).
std::string estimateSection(const CalibrationRun& run, const CalibrateResult& r) {
  const CalibrateOptions& o = run.o;
  const sim::Dataset& d = run.d;
  const calib::MethodSpec& method = run.method;
  const calib::MeasurementKind kind = run.kind;
  const calib::MeasurementModel* model = run.model.get();
  const std::vector<vision::Measurement>& meas = run.meas;
  const Eigen::VectorXd* y_true = d.manifest.true_errors ? &*d.manifest.true_errors : nullptr;
  std::ostringstream md;
  md << "# Calibration of " << d.arm.name << (kind == calib::MeasurementKind::kPose ? "" : " (" + r.model + " model)") << "\n\n"
     << refusalSection(r, o.accept_worse)
     << "Dataset `" << o.dataset << "`; method **" << method.name << "** (" << method.description
     << "); joint noise in R: " << formatNumber("%.4g", r.joint_noise_sigma_rad * sim::kRadToDeg) << " deg.\n\n"
     << "## Images\n\n" << vision::formatSummary(vision::summarize(meas)) << "\n\n"
     << r.identification << " used for identification, " << r.held_out << " held out for validation (seed " << o.seed << ").\n\n"
     << "## Identifiability of the identification set\n\n"
     << "Measurement: " << calib::measurementKindDescription(kind)
     << (kind == calib::MeasurementKind::kPose ? "" : (o.pairs == "reference" ? "; every image against the first" : "; consecutive images"))
     << ". " << model->numSamples() << " samples.\n\n" << r.classes.table() << "\nHeld as unidentifiable (" << r.classes.held.size()
     << "): " << parameterList(r.classes, r.classes.held)
     << " (every estimator holds these at their nominal values)"
     << ".\n"
     << "\nObservability indices (Borm & Menq 1991 O1 to Sun & Hollerbach 2008 O5; whitened rows, columns in typical "
        "magnitudes, held parameters left out; larger is better): " << calib::formatIndices(r.observability) << ".\n\n"
     << "## Estimate\n\n" << (r.frames ? "With the scene's frames the estimate took " : "")
     << r.estimate.iterations << " iterations, rank " << r.estimate.rank << ", " << formatNumber("%.2f", r.estimate.seconds * 1e3)
     << " ms" << (r.estimate.converged ? "" : ", NOT converged") << ". ";
  if (r.frames) {
    md << "The model " << (r.written ? "written to model.yaml" : "fitted (not written)") << ": geometry and both frames"
       << (r.frames->corners ? ", with the effects, fitted on the detected corners" : "") << " (sections below), +- 1 sigma"
       << (y_true ? "; the injected geometry errors as truth" : "") << ":\n\n";
  } else {
    md << "Every parameter of the model " << (r.written ? "written to model.yaml" : "fitted (not written)")
       << ", in its unit, +- 1 sigma" << (y_true ? "; the injected errors as truth" : "") << ":\n\n";
  }
  const calib::Fit fit = imageFit(run, r);
  md << parameterTable(fit, r.frames ? nullptr : &r.classes, y_true);
  return md.str();
}

/// The fit against its noise model, and the held-out pairs of a relative model.
std::string consistencySection(const CalibrationRun& run, const CalibrateResult& r) {
  const calib::MethodSpec& method = run.method;
  std::ostringstream md;
  md << "\n## Consistency of the fit with its noise model\n\n" << calib::formatConsistency(r.consistency)
     << " (each image's normalized squared residual against chi-square, Bonferroni over the images at "
     << formatNumber("%.3g", r.consistency.alpha) << "; R = the vision covariance plus the joint noise)."
     << (r.outlier_images.empty() ? std::string() : " Inconsistent: " + joinWords(r.outlier_images) + ".") << "\n";
  if (r.relative_before) {
    const auto row = [](const char* what, const calib::RelativeErrors& e) {
      return std::string("| ") + what + " | " + formatNumber("%.4f", e.distance_rms_m * 1e3) + " | " +
             formatNumber("%.4f", e.distance_max_m * 1e3) + " | " + formatNumber("%.5f", e.angle_rms_rad * sim::kRadToDeg) +
             " | " + formatNumber("%.5f", e.angle_max_rad * sim::kRadToDeg) + " |\n";
    };
    md << "\n## Hold-out validation of the frame-free quantities\n\n"
       << "Each held-out image paired with the first identification image: the distance between the two camera positions "
          "and the rotation angle between the two orientations, measured minus predicted (no base_T_board involved; "
       << r.relative_before->distance_pairs << " distance and " << r.relative_before->angle_pairs << " angle pairs).\n\n"
       << "| model | distance RMS (mm) | max (mm) | angle RMS (deg) | max (deg) |\n|---|---|---|---|---|\n"
       << row("nominal", *r.relative_before) << row(method.name.c_str(), *r.relative_after) << "\n"
       << "The parameters this model cannot see (ineffective above: e.g. theta1 and d1, a rigid motion of the whole arm) "
          "stay nominal, so the absolute errors below keep whatever errors they have.\n";
  }
  return md.str();
}

/// Hold-out validation against the measured (and true) poses, and the estimated frames.
std::string validationSection(const CalibrationRun& run, const CalibrateResult& r) {
  const sim::Dataset& d = run.d;
  const calib::MethodSpec& method = run.method;
  const std::optional<sim::TrueArm>& true_arm = run.true_arm;
  const int n_hold = static_cast<int>(run.hold.size());
  std::ostringstream md;
  if (n_hold > 0) {
    const calib::HeldoutGain& g = r.verdict.gain;
    md << "\n## Held-out test of the model written\n\n"
       << "The held-out camera poses (board_T_camera) predicted by the nominal arm "
       << (r.frames ? "(base_T_board and flange_T_camera fitted)" : "(the scene's frames)") << " and by the model "
       << (r.written ? "written to model.yaml" : "not written") << ": camera position RMS " << formatNumber("%.4f", g.before_rms_m * 1e3)
       << " -> " << formatNumber("%.4f", g.after_rms_m * 1e3) << " mm. " << calib::formatHeldoutGain(g) << ".\n"
       << "\n## Hold-out validation against the measured poses\n\n"
       << (r.frames ? "The DH estimate with the scene's frames (flange errors; Wang et al. 2023 Table 4's layout):\n\n" : "")
       << calib::formatTable4(r.before, {{method.name, r.after}}) << "\n";
  }
  if (r.has_truth) {
    md << "## Hold-out validation against the true poses (simulated dataset)\n\n"
       << calib::formatTable4(r.truth_before, {{method.name, r.truth_after}}) << "\n";
    if (true_arm->hasEffects()) {
      md << "The true poses include the effects of `" << d.manifest.error_set_file
         << "`, which a geometric calibration cannot represent:\n\n```\n" << sim::formatEffects(*true_arm) << "```\n\n";
    }
  }
  if (r.frames) {
    const FrameEstimate& f = *r.frames;
    md << "## Geometry with base_T_board and flange_T_camera estimated\n\n"
       << "Closed-form start from the camera poses, then LM over the DH errors and both frames ("
       << f.fit.estimate.held.size() << " parameters held as unidentifiable). Estimated frames against the scene's: base_T_board "
       << frameDifference(d.scene.base_T_board, f.base_T_board) << "; flange_T_camera "
       << frameDifference(d.scene.flange_T_camera, f.flange_T_camera) << ".\n\n"
       << "base_T_board: " << sim::transformYaml(f.base_T_board) << "\n\nflange_T_camera: " << sim::transformYaml(f.flange_T_camera)
       << "\n\nHeld-out camera poses (board_T_camera), position RMS: nominal arm with the frames refitted "
       << formatNumber("%.4f", f.heldout_before.position_rms_m * 1e3) << " mm, calibrated "
       << formatNumber("%.4f", f.heldout_after.position_rms_m * 1e3) << " mm.\n\n";
    if (f.corners) md << cornerSection(*f.corners);
  }
  return md.str();
}

}  // namespace

std::string calibrate_detail::calibrationReport(const CalibrationRun& run, const CalibrateResult& r, const std::string& figure_lines) {
  std::ostringstream md;
  md << estimateSection(run, r) << consistencySection(run, r) << validationSection(run, r);
  md << "## Figures\n\n" << figure_lines << "\n";
  md << (r.written ? "Files: `model.yaml` with `robot_calibrated.yaml` (orbcal's model, as measured data's: `orbcal evaluate`, "
                     "`--robot robot_calibrated.yaml`), `estimates.csv` (every parameter of model.yaml); for other programs "
                     "`robot_calibrated.urdf`, `frames.yaml` and `effects.yaml` (docs/export.md); `samples.csv` (per-image errors)"
                     + std::string(r.frames ? "; `scene_frames.yaml` (the estimated frames, to paste into the scene)" : "") +
                     (r.frames && r.frames->corners && r.frames->corners->distortion
                          ? "; `camera_calibrated.yaml` (the camera with the fitted distortion, ROS camera_info)"
                          : "") +
                     "; measurements in `"
                   : "No calibrated files were written (see the top). `samples.csv` (per-image errors); measurements in `")
     << run.measurements_path << "`.\n";
  return md.str();
}

void calibrate_detail::writeCalibratedFiles(const CalibrationRun& run, CalibrateResult& r) {
  const sim::Dataset& d = run.d;
  const calib::Fit fit = imageFit(run, r);
  calib::CalibratedModel cm = calib::calibratedModel(fit);
  cm.model.arm.name = d.arm.name + " (calibrated)";
  std::ostringstream header;
  header << "Calibrated by orbcal " << ORBCAL_VERSION << " (orbcal calibrate, method " << run.method.name << ") from " << run.o.dataset
         << "\n" << r.identification << " identification images of " << r.images << "; nominal: " << d.manifest.robot_file << " ("
         << d.arm.name << ")\n";
  if (r.frames && r.frames->corners) {
    header << "Fitted on the detected corners with base_T_board, flange_T_camera (world = the board, marker = the camera)";
    for (const sim::Effect& e : r.frames->corners->effects) header << ", " << sim::formatEffect(e);
    header << (r.frames->corners->distortion ? "; the lens distortion fitted with them is in camera_calibrated.yaml." : ".");
  } else if (r.frames) {
    header << "Fitted with base_T_board and flange_T_camera (world = the board, marker = the camera).";
  } else {
    header << "Identified parameter errors with the scene's base_T_board and flange_T_camera known (world = the board, marker = the "
              "camera).";
  }
  r.model_path = writeModelAndExports(cm, parameterRows(fit), run.out, header.str(), "robot_calibrated.yaml");
  r.robot_path = run.out + "/robot_calibrated.yaml";
  r.urdf_path = run.out + "/robot_calibrated.urdf";
  const Eigen::VectorXd* y_true = d.manifest.true_errors ? &*d.manifest.true_errors : nullptr;
  sim::writeFileAtomic(run.out + "/estimates.csv", estimatesCsv(fit, &r.classes, y_true));
  if (r.frames) {  // model.yaml's frames (world = the board, marker = the camera) as the scene writes them
    sim::writeFileAtomic(run.out + "/scene_frames.yaml",
                         "# base_T_board and flange_T_camera of model.yaml, estimated by orbcal calibrate --estimate-frames (paste "
                         "into the scene)\nbase_T_board: " + sim::transformYaml(cm.model.world_T_base.front().inverse()) +
                             "\nflange_T_camera: " + sim::transformYaml(cm.model.flange_T_marker.front()) + "\n");
  }
  if (r.frames && r.frames->corners && r.frames->corners->distortion) {
    // The camera with the fitted distortion added, as a ROS camera_info file a scene's camera: {file: ...} reads.
    sim::Camera camera = d.scene.camera;
    for (int i = 0; i < 4; ++i) camera.distortion[static_cast<std::size_t>(i)] += r.frames->corners->dk[i];
    sim::writeFileAtomic(run.out + "/camera_calibrated.yaml", sim::formatCameraInfoYaml(camera, "orbcal calibrated"));
  }
}

void calibrate_detail::writeSampleErrors(const CalibrationRun& run, const CalibrateResult& r) {
  const sim::Dataset& d = run.d;
  std::ostringstream rows;
  rows << "image,set,before_mm,after_mm,outlier\n";
  std::vector<bool> outlier(d.samples.size(), false);
  if (calib::isPoseKind(run.kind) && !calib::isRelativeKind(run.kind)) {
    for (int k : r.consistency.outliers) outlier[run.ident[static_cast<std::size_t>(k)]] = true;
  }
  std::vector<std::pair<std::size_t, const char*>> all;
  for (std::size_t k : run.ident) all.emplace_back(k, "identification");
  for (std::size_t k : run.hold) all.emplace_back(k, "held-out");
  std::sort(all.begin(), all.end());
  for (const auto& [k, set] : all) {
    const Eigen::Vector3d p = run.meas[k].base_T_flange.translation();
    rows << d.samples[k].image << "," << set << ","
         << formatNumber("%.6f", (p - sim::forwardKinematics(d.arm, d.samples[k].q_rad).translation()).norm() * 1e3) << ","
         << formatNumber("%.6f", (p - sim::forwardKinematics(run.calibrated, d.samples[k].q_rad).translation()).norm() * 1e3) << ","
         << (outlier[k] ? 1 : 0) << "\n";
  }
  sim::writeFileAtomic(run.out + "/samples.csv", rows.str());
}

}  // namespace orbcal::workflow
