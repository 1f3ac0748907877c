// The robot levels of a description of images with joint readings (calib/corner_levels.hpp): which level,
// its fit on every view, and its section of the report.
#include <sstream>

#include <algorithm>
#include <cmath>

#include "orbcal/sim/csv.hpp"
#include "measured_images_detail.hpp"

namespace orbcal::workflow::measured_images_detail {

using sim::formatNumber;

namespace {

/// The level's free parameters in the chain (the frames' 12 and the free geometric ones), or map's effective number.
std::string freeText(const calib::CornerLevelCrossValidation& t, const sim::Arm& arm) {
  const sim::KinematicModel m = calib::handEyeChainModel(arm, {});
  const int free = m.layout.size() - static_cast<int>(calib::levelHold(m, t.level, "--level").size());
  return std::to_string(free) + (t.level.kind == calib::LevelKind::kMap ? " (shrunk by the prior)" : "");
}

std::string judgement(const calib::HeldoutVerdict& v) {
  const std::string test = "t = " + formatNumber("%.2f", v.gain.t) + ", p = " + formatNumber("%.2g", v.gain.p_value);
  return v.refusal.empty() ? "better, " + test : (v.worse ? "worse, " : "not significantly better, ") + test;
}

}  // namespace

void robotLevel(const sim::ImageViews& data, const std::vector<calib::HandEyeView>& views, const std::vector<std::size_t>& used,
                const calib::Level& level, ImageCalibrateResult& r) {
  using calib::LevelKind;
  std::vector<sim::JointSample> samples;
  for (std::size_t k : used) samples.push_back(data.views[k].sample);
  const std::vector<calib::CornerObservation> obs = calib::cornerObservations(views, samples);
  const std::vector<calib::Level> candidates =
      level.kind == LevelKind::kAuto ? std::vector<calib::Level>{{LevelKind::kOffsets, {}}, {LevelKind::kMap, {}}, {LevelKind::kFull, {}}}
                                     : std::vector<calib::Level>{level};
  const calib::FitOptions options;  // measured data's: LM, the geometry prior
  for (const calib::Level& l : candidates) {
    r.tried.push_back(calib::crossValidateCornerLevel(views, obs, *data.arm, data.camera, data.board, data.setup, l, options, r.cv));
  }
  // Asked: that level. Auto: the smallest held-out residual among the levels that predict significantly better than frames.
  const calib::CornerLevelCrossValidation* chosen = level.kind == LevelKind::kAuto ? nullptr : &r.tried.front();
  for (const calib::CornerLevelCrossValidation& t : r.tried) {
    if (level.kind == LevelKind::kAuto && t.verdict.refusal.empty() && (!chosen || t.heldout_rms_m < chosen->heldout_rms_m)) chosen = &t;
  }
  if (!chosen) return;  // auto: the frames level stands
  r.level = chosen->level;
  r.refusals.clear();  // the frames level's: it is the reference now, not the result
  if (!chosen->verdict.refusal.empty()) r.refusals.push_back(chosen->verdict.refusal);
  const sim::KinematicModel start = calib::handEyeChainModel(*data.arm, r.fit.frames);
  r.robot = calib::fitCornerLevel(start, data.camera, data.board, data.setup, obs, calib::levelOptions(options, start, chosen->level, "--level"));
  std::vector<calib::ViewResidual> fitted;
  for (const calib::CornerObservation& o : obs) fitted.push_back(calib::cornerViewResidual(*r.robot, data.camera, data.board, data.setup, o));
  setResiduals(fitted, chosen->heldout, used, r);
  r.robot_sigma = calib::jackknifeSigma(chosen->refit_p);
  setFrames(data, r.robot->frames, chosen->refits, r);
}

std::string levelSentence(const ImageCalibrateResult& r) {
  if (r.tried.empty()) return "level frames";
  std::string s = "level " + calib::levelName(r.level) + (r.tried.size() == 1 ? " (as asked)" : " (chosen by cross-validation");
  if (r.tried.size() > 1) {
    s += ": held-out mm residual frames " + formatNumber("%.3f", r.frames_heldout_rms_mm);
    for (const calib::CornerLevelCrossValidation& t : r.tried) s += ", " + calib::levelName(t.level) + " " + formatNumber("%.3f", t.heldout_rms_m * 1e3);
    s += ")";
  }
  return s;
}

std::string robotLevelSection(const sim::ImageViews& data, const ImageCalibrateResult& r) {
  if (r.tried.empty()) return "";
  std::ostringstream md;
  md << "## Robot level\n\nThe joint readings let the robot's kinematic parameters be fitted to the corners too (the corner "
        "measurement model through the arm's parameter layout; the lens is the camera file's). Each level is judged as the "
        "frames level is, by leave-one-configuration-out cross-validation, against the frames level fitted to the same other "
        "configurations: one-sided paired test of the views' squared mm residuals, accepted at p < 0.01 over at least 10 "
        "configurations"
     << (r.tried.size() > 1 ? "; auto takes the smallest held-out residual among the accepted levels, frames when none is" : "")
     << ". Level: **" << levelSentence(r) << "**.\n\n"
     << "| level | free parameters | held out, RMS over the views (mm) | against the frames level |\n|---|---|---|---|\n"
     << "| frames | 12 | " << formatNumber("%.3f", r.frames_heldout_rms_mm) << " | the reference |\n";
  for (const calib::CornerLevelCrossValidation& t : r.tried) {
    md << "| " << calib::levelName(t.level) << " | " << freeText(t, *data.arm) << " | " << formatNumber("%.3f", t.heldout_rms_m * 1e3)
       << " | " << judgement(t.verdict) << " |\n";
  }
  if (!r.robot) return md.str() + "\n";
  const calib::CornerLevelFit& f = *r.robot;
  md << "\nThe frames above are those of the fitted arm's flange. Its geometric parameters (DH errors from the nominal "
        "arm; 1-sigma of the fit, its pixel sigma " << formatNumber("%.4f", f.sigma_px)
     << " px from the residuals, and the jackknife over the configurations; held: not free at this level or not identifiable "
        "from these views):\n\n| parameter | value | 1-sigma (fit) | 1-sigma (jackknife) | unit |\n|---|---|---|---|---|\n";
  const sim::ParamLayout& L = f.start.layout;
  const sim::ParamBlock& g = L.block(L.find(sim::BlockKind::kGeometry));
  for (int i = g.offset; i < g.offset + g.size(); ++i) {
    const sim::ParamInfo& info = L.param(i);
    const bool held = std::binary_search(f.estimate.held.begin(), f.estimate.held.end(), i);
    const double s = f.estimate.covariance.rows() > i ? std::sqrt(std::max(0.0, f.estimate.covariance(i, i))) : 0.0;
    const double jk = r.robot_sigma.size() > i ? r.robot_sigma[i] : 0.0;
    md << "| " << info.name << " | " << formatNumber("%.4f", f.p[i] * info.display_scale) << " | "
       << (held ? std::string("held") : formatNumber("%.4f", s * info.display_scale)) << " | "
       << (held ? std::string("held") : formatNumber("%.4f", jk * info.display_scale)) << " | " << info.display_unit << " |\n";
  }
  return md.str() + "\n";
}

}  // namespace orbcal::workflow::measured_images_detail
