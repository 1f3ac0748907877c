// frames.yaml, views.csv and report.md of a calibration from a description of images.
#include <filesystem>
#include <sstream>

#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/se3.hpp"
#include "measured_images_detail.hpp"

namespace orbcal::workflow::measured_images_detail {

using sim::formatNumber;

namespace {

std::string list(const std::vector<double>& v, const char* format) {
  std::string s = "[";
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + formatNumber(format, v[i]);
  return s + "]";
}

std::string frameYaml(const std::string& key, const Eigen::Isometry3d& T, const sim::Vector6d& sigma) {
  const Eigen::Matrix4d M = T.matrix();
  std::vector<double> m;
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) m.push_back(M(i, j));
  }
  const Eigen::Quaterniond q(T.linear());
  const Eigen::Vector3d t = T.translation();
  return key + ":\n  matrix: " + list(m, "%.17g") + "\n  xyz_m: " + list({t.x(), t.y(), t.z()}, "%.17g") +
         "\n  quaternion_xyzw: " + list({q.x(), q.y(), q.z(), q.w()}, "%.17g") + "\n  sigma_xyz_mm: " +
         list({sigma[0] * 1e3, sigma[1] * 1e3, sigma[2] * 1e3}, "%.4g") + "\n  sigma_rotation_deg: " +
         list({sigma[3] * sim::kRadToDeg, sigma[4] * sim::kRadToDeg, sigma[5] * sim::kRadToDeg}, "%.4g") + "\n";
}

std::string joinIds(const std::vector<int>& ids) {
  std::string s;
  for (int id : ids) s += (s.empty() ? "" : " ") + std::to_string(id);
  return s;
}

std::string mm(double m) { return formatNumber("%.3f", m * 1e3); }
std::string deg(double rad) { return formatNumber("%.3f", rad * sim::kRadToDeg); }

std::string frameLine(const std::string& name, const Eigen::Isometry3d& T, const sim::Vector6d& s) {
  const Eigen::Vector3d t = T.translation(), w = sim::logSO3(T.linear());
  return "| " + name + " | " + mm(t.x()) + ", " + mm(t.y()) + ", " + mm(t.z()) + " | " + mm(s[0]) + ", " + mm(s[1]) + ", " + mm(s[2]) +
         " | " + deg(w.x()) + ", " + deg(w.y()) + ", " + deg(w.z()) + " | " + deg(s[3]) + ", " + deg(s[4]) + ", " + deg(s[5]) + " |\n";
}

std::string verdict(const ImageCalibrateResult& r, bool written) {
  std::ostringstream md;
  const std::string files = written ? "frames.yaml was written" + std::string(r.refusals.empty() ? "" : " because --accept-worse was given") + "."
                                    : "frames.yaml was not written.";
  for (const std::string& why : r.refusals) md << "**The calibration is not accepted: " << why << ".** " << files << "\n\n";
  if (r.refusals.empty()) {
    md << "**Accepted: frames.yaml was written (leave-one-configuration-out cross-validation over " << r.configurations
       << " configurations: held-out residual RMS " << formatNumber("%.3f", r.heldout_rms_px) << " px, "
       << formatNumber("%.3f", r.heldout_rms_mm) << " mm).**\n\n";
  }
  return md.str();
}

/// The corner fit against the closed form on the held-out views: reported, not required (measured_images.cpp).
std::string gainSentence(const calib::HeldoutGain& g) {
  return "The corner fit against the closed form, each predicting the views of every configuration from the others: one-sided "
         "paired test of their squared mm residuals t = " + formatNumber("%.2f", g.t) + ", p = " + formatNumber("%.2g", g.p_value) +
         " over " + std::to_string(g.configurations) + " configurations (both estimate the same frames: the calibration is refused "
         "when the corner fit predicts worse, not for want of a significant gain).\n\n";
}

}  // namespace

std::pair<std::string, std::string> frameNames(sim::HandEyeSetup setup) {
  return setup == sim::HandEyeSetup::kEyeInHand ? std::make_pair(std::string("flange_T_camera"), std::string("base_T_board"))
                                                : std::make_pair(std::string("flange_T_board"), std::string("base_T_camera"));
}

std::string framesYaml(const sim::ImageViews& data, const ImageCalibrateResult& r, const std::string& header) {
  const auto [hand, base] = frameNames(data.setup);
  std::ostringstream s;
  s << "# " << header << "\n"
    << "# a_T_b maps coordinates in frame b to frame a: p_a = R p_b + t. matrix: the 4x4 homogeneous transform, row by row,\n"
    << "# translation in metres; xyz_m: t; quaternion_xyzw: R as a unit quaternion [x, y, z, w] (Hamilton).\n"
    << "# sigma_*: 1-sigma per axis of the parent frame a, the jackknife over the views' configurations (leave one out).\n"
    << (r.robot ? "# Calibrated at the robot level " + calib::levelName(r.level) +
                      ": the frames of the calibrated arm's flange (report.md lists the arm's parameters).\n"
                : std::string())
    << "# The board frame is OpenCV's " << (data.board_frame == sim::BoardFrameConvention::kOpenCv ? ">= 4.6" : "legacy (<= 4.5)")
    << " CharucoBoard frame (origin at the outer corner of square (0, 0)).\n"
    << "format: orbcal-hand-eye-1\n"
    << "setup: " << sim::handEyeSetupName(data.setup) << "\n"
    << "board_frame: " << (data.board_frame == sim::BoardFrameConvention::kOpenCv ? "opencv" : "legacy") << "\n"
    << frameYaml(hand, r.hand_T_eye, r.hand_sigma) << frameYaml(base, r.base_T_other, r.base_sigma);
  if (r.lens_taken) {
    s << "# The frames hold with this radial distortion added to the camera file's k1, k2 (normalised coordinates; the lens check\n"
      << "# of report.md): project through it, or the frames misplace the outer corners.\n"
      << "camera_distortion_added:\n  k1_k2: " << list({r.lens_k[0], r.lens_k[1]}, "%.17g") << "\n  sigma_k1_k2: "
      << list({r.lens_sigma[0], r.lens_sigma[1]}, "%.4g") << "\n";
  }
  return s.str();
}

std::string viewsCsv(const ImageCalibrateResult& r) {
  std::ostringstream csv;
  csv << "row,image,used,reason,corners,lost_markers,ignored_px,pnp_rms_px,fitted_rms_px,fitted_rms_mm,heldout_rms_px,heldout_rms_mm,half_turned\n";
  const auto num = [](bool used, double v) { return used ? formatNumber("%.4f", v) : std::string(); };
  for (std::size_t k = 0; k < r.views.size(); ++k) {
    const ImageViewOutcome& v = r.views[k];
    const bool fitted = v.used && r.fit.corners > 0;
    std::string reason = v.reason;
    for (char& c : reason) c = c == ',' ? ';' : c;
    csv << k << "," << v.image << "," << (v.used ? 1 : 0) << "," << reason << "," << v.corners << "," << joinIds(v.lost_markers) << ","
        << v.ignored_px << "," << num(v.used, v.pnp_rms_px) << "," << num(fitted, v.fitted.rms_px) << "," << num(fitted, v.fitted.rms_m * 1e3)
        << "," << num(fitted && r.cross_validated, v.heldout.rms_px) << "," << num(fitted && r.cross_validated, v.heldout.rms_m * 1e3) << ","
        << (v.half_turned ? 1 : 0) << "\n";
  }
  return csv.str();
}

/// The lens check's paragraph of report.md ("" when it did not run).
std::string lensSection(const ImageCalibrateResult& r) {
  if (!r.lens_checked) return "";
  std::ostringstream md;
  md << "## Lens check\n\nThe camera's radial distortion fitted with the frames on the corners, added to the camera file's: k1 = "
     << formatNumber("%.4f", r.lens_k[0]) << " +- " << formatNumber("%.4f", r.lens_sigma[0]) << ", k2 = " << formatNumber("%.4f", r.lens_k[1])
     << " +- " << formatNumber("%.4f", r.lens_sigma[1]) << " (normalised coordinates, jackknife 1-sigma), "
     << formatNumber("%.2f", r.lens_shift_px) << " px at the image corner farthest from the principal point. Cross-validated against the "
     << "stated lens, the views held out: " << formatNumber("%.3f", r.lens_verdict.gain.after_rms_m * 1e3) << " mm with it, "
     << formatNumber("%.3f", r.lens_stated_heldout_rms_mm) << " mm (" << formatNumber("%.3f", r.lens_stated_heldout_rms_px)
     << " px) without; one-sided paired test of their squared mm residuals t = " << formatNumber("%.2f", r.lens_verdict.gain.t)
     << ", p = " << formatNumber("%.2g", r.lens_verdict.gain.p_value) << " over " << r.lens_verdict.gain.configurations
     << " configurations. "
     << (r.lens_taken ? "**Taken**: the camera file misses this distortion; the frames, residuals and figures above are with it, and "
                        "frames.yaml gives it (`camera_distortion_added`).\n\n"
                      : "Not taken (" + r.lens_verdict.refusal + "): the stated lens stands.\n\n");
  return md.str();
}

std::string imageReport(const sim::ImageViews& data, const ImageCalibrateResult& r, const MeasuredCalibrateOptions& o, bool written) {
  const auto [hand, base] = frameNames(data.setup);
  const bool fitted = r.fit.corners > 0;
  std::ostringstream md;
  md << "# Hand-eye calibration from images\n\n" << verdict(r, written);
  md << "Description `" << o.description << "`: " << r.views.size() << " images, " << sim::handEyeSetupName(data.setup)
     << "; the board found in " << r.used << " (" << r.configurations << " configurations). Flange poses "
     << (data.arm ? "of the nominal arm " + data.robot_file + " at the joint readings" : std::string("from the controller"))
     << ". "
     << (r.robot ? "Calibrated at the robot level " + calib::levelName(r.level) + ": " + hand + " and " + base +
                       " with the robot's parameters (below).\n\n"
                 : "Calibrated at the frames level: " + hand + " and " + base + " (12 parameters), no robot parameter.\n\n");
  for (const std::string& w : r.warnings) md << "Warning: " << w << ".\n\n";
  if (fitted) {
    md << "Start: closed form (Shah 2013's robot-world / hand-eye rotations, least-squares translations) on each view's own board "
          "pose; then the corner reprojection fit over " << r.fit.corners << " corners (" << r.fit.iterations << " iterations, RMS "
       << formatNumber("%.3f", r.fit.rms_px) << " px).\n\n"
       << "## Frames\n\n1-sigma: the jackknife over the " << r.configurations
       << " configurations (each left out in turn), per axis of the parent frame.\n\n"
       << "| frame | translation (mm) | 1-sigma (mm) | rotation vector (deg) | 1-sigma (deg) |\n|---|---|---|---|---|\n"
       << frameLine(hand, r.hand_T_eye, r.hand_sigma) << frameLine(base, r.base_T_other, r.base_sigma)
       << "\n## Cross-validated residuals\n\nEach view predicted by the frames fitted without its configuration (leave one "
          "configuration out; a row repeated in the file is left out with its copies): by the corner fit, and by the closed form "
          "it starts from. px: RMS of the corner reprojection residuals per coordinate; mm: RMS over the view's corners of the "
          "residual carried to the corner's distance (|residual| times depth over focal length: how far across the line of sight "
          "the chain, flange pose and frames, misplaces the corner).\n\n"
       << "| residual RMS over the views | px | mm |\n|---|---|---|\n";
    if (r.cross_validated) {
      md << "| held out (cross-validated), corner fit | " << formatNumber("%.3f", r.heldout_rms_px) << " | "
         << formatNumber("%.3f", r.heldout_rms_mm) << " |\n"
         << "| held out (cross-validated), closed form | " << formatNumber("%.3f", r.heldout_start_rms_px) << " | "
         << formatNumber("%.3f", r.heldout_start_rms_mm) << " |\n";
    }
    md << "| fitted | " << formatNumber("%.3f", r.fitted_rms_px) << " | " << formatNumber("%.3f", r.fitted_rms_mm) << " |\n\n"
       << (r.cross_validated ? gainSentence(r.cv.verdict.gain) : std::string())
       << "The detection noise, known independently of the chain (the median over the views of each view's own PnP residual, per "
          "coordinate): " << formatNumber("%.3f", r.detection_sigma_px) << " px. "
       << (!r.cross_validated ? "\n\n"
           : r.heldout_rms_px > 2.0 * r.detection_sigma_px
               ? std::string(r.robot ? "The held-out residuals exceed it: the rest is what the level's model lacks, or the "
                                       "camera's intrinsics, which it does not fit.\n\n"
                                     : "The held-out residuals exceed it: the rest is the flange poses' error (a controller reports "
                                       "its nominal model's poses) or the camera's intrinsics beyond the lens check's k1, k2.\n\n")
               : "The held-out residuals are at that noise.\n\n");
  }
  md << lensSection(r) << robotLevelSection(data, r) << "## Views\n\n| row | image | corners | lost markers | PnP RMS (px) | fitted (px) | fitted (mm) | held out (px) | held out (mm) |\n"
        "|---|---|---|---|---|---|---|---|---|\n";
  for (std::size_t k = 0; k < r.views.size(); ++k) {
    const ImageViewOutcome& v = r.views[k];
    const std::string name = std::filesystem::path(v.image).filename().string();
    if (!v.used) {
      md << "| " << k << " | " << name << " | not used: " << v.reason << " | " << joinIds(v.lost_markers) << " | | | | | |\n";
      continue;
    }
    md << "| " << k << " | " << name << " | " << v.corners << " | " << joinIds(v.lost_markers) << " | " << formatNumber("%.3f", v.pnp_rms_px)
       << " | " << (fitted ? formatNumber("%.3f", v.fitted.rms_px) + " | " + formatNumber("%.3f", v.fitted.rms_m * 1e3) + " | " +
                                 (r.cross_validated ? formatNumber("%.3f", v.heldout.rms_px) + " | " + formatNumber("%.3f", v.heldout.rms_m * 1e3)
                                                    : std::string(" | "))
                           : std::string(" | | | "))
       << " |\n";
  }
  md << "\nDetection, fit and cross-validation took " << formatNumber("%.1f", r.seconds) << " s.\n\n## Files\n\n"
     << (written ? "`frames.yaml` (" + hand + " and " + base + " with their 1-sigma), " : std::string())
     << "`views.csv` (per view: detection, lost markers, residuals in px and mm).\n";
  return md.str();
}

}  // namespace orbcal::workflow::measured_images_detail
