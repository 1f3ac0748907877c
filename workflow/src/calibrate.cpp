#include "orbcal/workflow/calibrate.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "orbcal/workflow/experiment.hpp"
#include "orbcal/workflow/report_html.hpp"
#include "orbcal/calib/diagnose.hpp"
#include "orbcal/calib/planning.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/identifiability.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/sim/truth.hpp"
#include "orbcal/sim/urdf.hpp"
#include "orbcal/vision/measurement.hpp"
#include "calibrate_detail.hpp"

namespace orbcal::workflow {

using namespace calibrate_detail;

std::vector<calib::CornerObservation> cornerObservations(const std::vector<calib::MarkerObservation>& obs,
                                                         const std::vector<vision::Measurement>& meas,
                                                         const std::vector<std::size_t>& which) {
  std::vector<calib::CornerObservation> out;
  for (std::size_t i = 0; i < which.size(); ++i) out.push_back({obs[i].sample, meas[which[i]].corners_px, meas[which[i]].corner_ids});
  return out;
}

namespace {

/// Geometry + both frames + chain effects (+ distortion) on the corner model, from the closed-form
/// frame start; the pixel sigma from the residuals. Joint noise is not in R (see corner_model.hpp).
CornerEstimate estimateOnCorners(const sim::Dataset& d, const std::vector<vision::Measurement>& meas,
                                 const std::vector<std::size_t>& ident, const std::vector<std::size_t>& hold,
                                 const std::vector<sim::Effect>& effects, bool distortion) {
  CornerEstimate c;
  c.effects = effects;
  c.distortion = distortion;
  const ImageMeasuredData fitted = imageMeasuredData(d, meas, ident);
  if (calib::needsTorque(effects) && d.arm.masses.empty()) {
    throw sim::InputError("--effects: compliance deflects the joints under gravity torques, and " + d.manifest.robot_file +
                          " has no masses: section");
  }
  const sim::KinematicModel start = calib::startingModel(fitted.data, fitted.observations, effects);
  const std::vector<calib::CornerObservation> obs = cornerObservations(fitted.observations, meas, ident);
  const ImageMeasuredData held_data = imageMeasuredData(d, meas, hold);
  const std::vector<calib::CornerObservation> held = cornerObservations(held_data.observations, meas, hold);
  const int off = start.layout.size();
  std::vector<int> distortion_params;
  for (int i = 0; i < 4; ++i) distortion_params.push_back(off + i);
  calib::CornerNoise noise;  // the starting sigma; re-estimated from the residuals
  c.model = start;
  c.fit = calib::fitCornerModel(start, d.scene.camera, d.scene.board, obs, noise, true, {},
                                distortion ? std::vector<int>{} : distortion_params);
  noise.sigma_px = c.fit.sigma_px;
  const calib::CornerMeasurementModel held_model(start, d.scene.camera, d.scene.board, held, noise);
  c.layout = held_model.layout();
  c.heldout_rms_px = held.empty() ? 0.0 : calib::cornerResidualRms(held_model, c.fit.p);
  if (distortion) {
    c.without = calib::fitCornerModel(start, d.scene.camera, d.scene.board, obs, noise, true, {}, distortion_params);
    c.heldout_rms_px_without = held.empty() ? 0.0 : calib::cornerResidualRms(held_model, c.without.p);
    for (int i = 0; i < 4; ++i) {
      c.dk[i] = c.fit.p[off + i];
      c.dk_sigma[i] = std::sqrt(std::max(0.0, c.fit.estimate.covariance(off + i, off + i)));
    }
  }
  if (const std::optional<sim::TrueArm> t = sim::datasetTrueArm(d)) c.dk_true = t->camera_distortion_delta;
  return c;
}

FrameEstimate estimateFrames(const sim::Dataset& d, const std::vector<vision::Measurement>& meas,
                             const std::vector<std::size_t>& ident, const std::vector<std::size_t>& hold,
                             double joint_noise_sigma_rad, const std::vector<std::string>& effect_specs) {
  const ImageMeasuredData fitted = imageMeasuredData(d, meas, ident);
  const std::vector<calib::MarkerObservation>& obs = fitted.observations;
  const std::vector<calib::MarkerObservation> held = imageMeasuredData(d, meas, hold).observations;
  const sim::KinematicModel start = calib::startingModel(fitted.data, obs, {});
  calib::FitOptions fo;
  fo.joint_noise_sigma_rad = joint_noise_sigma_rad;
  fo.sigma_position_m = fo.sigma_rotation_rad = 1.0;  // unused: every observation has its covariance
  FrameEstimate f;
  f.fit = calib::fitMarkerModel(start, obs, fo);
  calib::FitOptions ref = fo;
  const sim::ParamBlock& g = start.layout.block(start.layout.find(sim::BlockKind::kGeometry));
  for (int i = 0; i < g.size(); ++i) ref.hold.push_back(g.offset + i);
  const calib::Fit reference = calib::fitMarkerModel(start, obs, ref);
  f.reference_p = reference.p;
  f.heldout_before = calib::residualStats(start, reference.p, held);
  f.heldout_after = calib::residualStats(start, f.fit.p, held);
  const calib::CalibratedModel cm = calib::calibratedModel(f.fit);
  f.base_T_board = cm.model.world_T_base.front().inverse();
  f.flange_T_camera = cm.model.flange_T_marker.front();
  if (!effect_specs.empty()) {
    std::vector<sim::Effect> effects;
    bool distortion = false;
    for (const std::string& e : effect_specs) {
      if (sim::isCameraEffect(e, "--effects")) {
        distortion = true;
      } else {
        effects.push_back(sim::parseEffect(e, d.arm.numJoints(), "--effects"));
      }
    }
    f.corners = estimateOnCorners(d, meas, ident, hold, effects, distortion);
  }
  return f;
}

}  // namespace

ImageMeasuredData imageMeasuredData(const sim::Dataset& d, const std::vector<vision::Measurement>& meas,
                                    const std::vector<std::size_t>& which) {
  ImageMeasuredData out;
  sim::MeasuredData& md = out.data;
  md.description = d.folder;
  md.robot_file = d.manifest.robot_file;
  md.arm = d.arm;
  md.files = {d.folder};
  const sim::Matrix6d Ad = sim::adjoint(d.scene.flange_T_camera.inverse());  // camera <- flange
  for (std::size_t k : which) {
    sim::MeasuredPose p;
    p.sample.q_rad = d.samples[k].q_rad;
    p.world_T_marker = meas[k].camera_T_board.inverse();
    p.where = d.folder + ": " + d.samples[k].image;
    md.poses.push_back(std::move(p));
  }
  sim::fillApproachDirections(md.poses);
  out.observations = calib::observationsFrom(md, !md.arm.masses.empty());
  for (std::size_t i = 0; i < which.size(); ++i) out.observations[i].covariance = Ad * meas[which[i]].covariance * Ad.transpose();
  return out;
}

sim::KinematicModel calibrate_detail::sceneModel(const sim::Dataset& d) {
  return sim::makeKinematicModel(d.arm, 1, sim::FrameSharing::kKnown, sim::FrameSharing::kKnown, {d.scene.base_T_board.inverse()},
                                 {d.scene.flange_T_camera}, {});
}

calib::Fit calibrate_detail::cornerModelFit(const CornerEstimate& c) {
  calib::Fit fit;
  fit.model = c.model;
  const int n = c.model.layout.size();
  fit.p0 = Eigen::VectorXd::Zero(n);
  fit.p = c.fit.p.head(n);
  fit.estimate = c.fit.estimate;
  fit.estimate.y = Eigen::VectorXd(c.fit.estimate.y.head(n));
  fit.estimate.covariance = Eigen::MatrixXd(c.fit.estimate.covariance.topLeftCorner(n, n));
  fit.estimate.held.erase(std::remove_if(fit.estimate.held.begin(), fit.estimate.held.end(), [n](int i) { return i >= n; }),
                          fit.estimate.held.end());
  fit.noise_estimated = true;
  fit.dof = c.fit.dof;
  return fit;
}

calib::Fit calibrate_detail::imageFit(const CalibrationRun& run, const CalibrateResult& r) {
  if (r.frames && r.frames->corners) {
    calib::Fit fit = cornerModelFit(*r.frames->corners);
    // Geometry and both frames come first in both layouts: what the frames fit found unidentifiable
    // together (d7 with the camera mount, ...) is so on the corners too: effects can add redundancies, not remove them.
    const sim::ParamLayout& frames = r.frames->fit.model.layout;
    bool same_prefix = frames.size() <= fit.model.layout.size();
    for (int i = 0; same_prefix && i < frames.size(); ++i) same_prefix = frames.param(i).name == fit.model.layout.param(i).name;
    if (same_prefix) fit.identifiability = r.frames->fit.identifiability;
    return fit;
  }
  if (r.frames) return r.frames->fit;
  calib::Fit fit;
  fit.model = sceneModel(run.d);
  fit.p0 = Eigen::VectorXd::Zero(fit.model.layout.size());
  fit.p = r.estimate.y;
  fit.estimate = r.estimate;
  return fit;
}

namespace {

/// The model of a measurement kind other than the absolute pose from an image dataset's camera poses
/// (world = the board, marker = the camera, both frames the scene's and known: the relative kinds do not
/// see base_T_board at all). Position rows carry each image's vision covariance; the relative models take
/// one pose sigma per axis (calib::relativePairs), the RMS over the images of the vision covariance's
/// diagonal. The joint noise is carried into R by every kind (at 0.01 deg on a long arm it dominates).
std::unique_ptr<calib::MeasurementModel> imageKindModel(const sim::Dataset& d, const std::vector<vision::Measurement>& meas,
                                                        const std::vector<std::size_t>& ident, calib::MeasurementKind kind,
                                                        const std::string& pairs, double joint_sigma_rad) {
  ImageMeasuredData data = imageMeasuredData(d, meas, ident);
  const sim::KinematicModel km = sceneModel(d);
  calib::MeasurementSetup setup;
  setup.kind = kind;
  setup.pairing = pairs == "reference" ? calib::Pairing::kReference : calib::Pairing::kConsecutive;
  setup.noise.joint_noise_sigma_rad = joint_sigma_rad;
  double pos2 = 0.0, rot2 = 0.0;
  for (const calib::MarkerObservation& o : data.observations) {
    pos2 += o.covariance.topLeftCorner(3, 3).trace() / 3.0;
    rot2 += o.covariance.bottomRightCorner(3, 3).trace() / 3.0;
  }
  const double n = std::max<double>(1.0, static_cast<double>(data.observations.size()));
  setup.noise.sigma_position_m = std::sqrt(pos2 / n);
  setup.noise.sigma_rotation_rad = std::sqrt(rot2 / n);
  return calib::modelFromPoses(setup, km, std::move(data.observations));
}

}  // namespace

std::string calibrate_detail::joinWords(const std::vector<std::string>& words) {
  std::string out;
  for (const std::string& w : words) out += (out.empty() ? "" : ", ") + w;
  return out;
}

/// What most likely makes a fit inconsistent: a few images (a misdetected board, a wrong joint reading:
/// without them the rest is consistent), the scene's frames (the board or camera mount: a fit with both
/// frames estimated is consistent), or the arm model itself (the robot file, the camera, or effects the
/// DH model lacks: even that fit is not).
std::string likelyCause(const sim::Dataset& d, const std::vector<vision::Measurement>& meas, const std::vector<std::size_t>& ident,
                        const std::vector<std::size_t>& hold, calib::MeasurementKind kind, const CalibrateResult& r) {
  const calib::Consistency& c = r.consistency;
  int rows = 0;
  for (const calib::SampleConsistency& s : c.samples) rows += s.rows;
  const int free = rows - c.dof;
  double rest_chi2 = c.chi2;
  int rest_rows = rows;
  for (int k : c.outliers) {
    rest_chi2 -= c.samples[static_cast<std::size_t>(k)].chi2;
    rest_rows -= c.samples[static_cast<std::size_t>(k)].rows;
  }
  const bool few = !c.outliers.empty() && 5 * c.outliers.size() <= c.samples.size();
  if (few && calib::chiSquareSurvival(rest_chi2, std::max(1, rest_rows - free)) >= c.alpha) {
    return "without " + std::to_string(c.outliers.size()) + " image(s) the rest is consistent: " + joinWords(r.outlier_images) +
           " disagree with the others (a misdetected board, or a wrong joint reading there): check or remove them";
  }
  if (kind != calib::MeasurementKind::kPose) {
    return "the robot file, the camera or the scene's flange_T_camera do not describe this arm (or it has effects the DH model "
           "lacks: `orbcal diagnose` names them)";
  }
  const FrameEstimate f = r.frames ? *r.frames : estimateFrames(d, meas, ident, hold, r.joint_noise_sigma_rad, {});
  const double p_frames = calib::chiSquareSurvival(f.fit.chi2, f.fit.dof);
  if (p_frames >= c.alpha || f.fit.chi2 < 0.5 * c.chi2) {
    return "with base_T_board and flange_T_camera estimated the fit is " + std::string(p_frames >= c.alpha ? "consistent" : "far better") +
           " (chi-square " + formatNumber("%.1f", f.fit.chi2) + " for " + std::to_string(f.fit.dof) +
           "): the scene's board or camera mount (base_T_board, flange_T_camera) is off; calibrate with --estimate-frames "
           "(its scene_frames.yaml corrects the scene)";
  }
  return "even with base_T_board and flange_T_camera estimated the fit is inconsistent (chi-square " + formatNumber("%.1f", f.fit.chi2) +
         " for " + std::to_string(f.fit.dof) + "): the robot file or the camera intrinsics do not describe this arm, or it has "
         "effects the DH model lacks (`orbcal diagnose` names them)";
}

namespace {

/// The options' checks that need no file: a bad value fails before any work.
void checkCalibrateOptions(const CalibrateOptions& o) {
  calib::checkHoldout(o.holdout);
  if (!o.effects.empty() && !o.estimate_frames) {
    throw sim::InputError("--effects: an image dataset's effects are fitted with its frames: add --estimate-frames");
  }
  for (const std::string& e : o.effects) {  // before any work: names and joints
    if (!sim::isCameraEffect(e, "--effects")) sim::parseEffect(e, 64, "--effects");
  }
}

/// The measurement kind, checked against the dataset's arm and the other options.
calib::MeasurementKind checkedKind(const CalibrateOptions& o, const sim::Arm& arm) {
  for (const std::string& e : o.effects) {
    if (!sim::isCameraEffect(e, "--effects")) sim::parseEffect(e, arm.numJoints(), "--effects");
  }
  calib::findMethod(calib::comparisonMethods(0.0), o.method);  // an unknown name fails before any work
  const calib::MeasurementKind kind = calib::parseMeasurementKind(o.model, "--model");
  if (kind == calib::MeasurementKind::kRange) {
    throw sim::InputError("--model: range: an image dataset measures camera poses, not laser ranges");
  }
  if (kind != calib::MeasurementKind::kPose && o.estimate_frames) {
    throw sim::InputError("--model: " + o.model + ": --estimate-frames fits the absolute pose (--model pose)");
  }
  if (o.pairs != "reference" && o.pairs != "consecutive") {
    throw sim::InputError("--pairs: '" + o.pairs + "' is not reference or consecutive");
  }
  return kind;
}

/// Detects the boards of every image and writes measurements.csv.
void measureImages(CalibrationRun& run, CalibrateResult& r) {
  const CalibrateOptions& o = run.o;
  {
    Progress bar(o.callbacks.progress, o.quiet ? "" : "measure", o.quiet ? 0 : static_cast<int>(run.d.samples.size()));
    run.meas = vision::measureDataset(run.d, {}, [&](int done, int) { bar.update(done); });
  }
  sim::writeFileAtomic(o.out.empty() ? run.measurements_path : run.out + "/measurements.csv", vision::formatMeasurementsCsv(run.meas));
  r.images = static_cast<int>(run.meas.size());
}

/// The usable samples, split by the one hold-out rule of every calibration (calib::holdoutSplit: whole
/// configurations, seeded; an image is a configuration unless its joint readings repeat another's).
void splitHoldout(CalibrationRun& run, CalibrateResult& r) {
  std::vector<std::size_t> usable;
  for (std::size_t k = 0; k < run.meas.size(); ++k) {
    if (run.meas[k].found()) usable.push_back(k);
  }
  r.usable = static_cast<int>(usable.size());
  const std::vector<calib::MarkerObservation> obs = imageMeasuredData(run.d, run.meas, usable).observations;
  run.configurations = calib::countConfigurations(obs);
  const std::vector<int> part = calib::holdoutSplit(obs, run.o.holdout, run.o.seed);
  for (std::size_t i = 0; i < usable.size(); ++i) (part[i] == 1 ? run.hold : run.ident).push_back(usable[i]);
  r.identification = static_cast<int>(run.ident.size());
  r.held_out = static_cast<int>(run.hold.size());
  const sim::Arm& arm = run.d.arm;
  if (static_cast<int>(run.ident.size()) * 6 < arm.numParams()) {
    throw sim::InputError(run.o.dataset + ": only " + std::to_string(run.ident.size()) +
                          " usable identification images: at least " + std::to_string((arm.numParams() + 5) / 6) +
                          " are needed for " + std::to_string(arm.numParams()) + " parameters (" +
                          vision::summaryLine(vision::summarize(run.meas)) + ")");
  }
}

/// The estimate, its consistency with the noise model, the identifiability of the identification set and,
/// for relative models, the held-out pairs.
void fitImages(CalibrationRun& run, CalibrateResult& r) {
  const CalibrateOptions& o = run.o;
  const sim::Dataset& d = run.d;
  // R: the vision covariance plus the joint noise (unless the method says otherwise).
  r.joint_noise_sigma_rad = o.joint_noise_sigma_rad >= 0.0 ? o.joint_noise_sigma_rad
                            : d.manifest.joint_noise_sigma_rad > 0.0 ? d.manifest.joint_noise_sigma_rad
                                                                       : 0.01 * sim::kDegToRad;
  run.method = calib::findMethod(calib::comparisonMethods(r.joint_noise_sigma_rad), o.method);
  if (run.kind == calib::MeasurementKind::kPose) {
    std::vector<calib::PoseObservation> obs;
    for (std::size_t k : run.ident) obs.push_back({d.samples[k].q_rad, run.meas[k].base_T_flange, run.meas[k].covariance});
    run.model = std::make_unique<calib::MarkerPoseModel>(calib::poseModel(d.arm, obs, run.method.noise));
  } else {
    run.model = imageKindModel(d, run.meas, run.ident, run.kind, o.pairs, r.joint_noise_sigma_rad);
  }
  const calib::MeasurementModel& model = *run.model;
  r.model = calib::measurementKindName(run.kind);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model.numParams());
  // One decision of what this data cannot identify: the report's classes, and what every estimator holds.
  r.classes = calib::classifyParameters(model, zero);
  calib::FitControls controls;
  controls.hold = r.classes.held;
  r.estimate = calib::runMethod(run.method, model, controls);
  r.consistency = calib::consistencyTest(model, r.estimate.y,
                                         r.estimate.rank > 0 ? r.estimate.rank : model.numParams() - static_cast<int>(r.estimate.held.size()));
  for (int k : r.consistency.outliers) {
    const calib::SampleConsistency& sc = r.consistency.samples[static_cast<std::size_t>(k)];
    r.outlier_images.push_back((calib::isRelativeKind(run.kind) ? "pair " + std::to_string(k + 1) : d.samples[run.ident[static_cast<std::size_t>(k)]].image) +
                               " (chi-square " + formatNumber("%.1f", sc.chi2) + " for " + std::to_string(sc.rows) + ")");
  }
  // A pose model's parameters are the DH errors; the others' layout starts with them too (known frames).
  r.estimate.y = Eigen::VectorXd(r.estimate.y.head(d.arm.numParams()));
  r.estimate.covariance = Eigen::MatrixXd(r.estimate.covariance.topLeftCorner(d.arm.numParams(), d.arm.numParams()));
  r.observability = calib::observability(model, zero, r.classes.held);
  if (!run.hold.empty() && calib::isRelativeKind(run.kind)) {
    std::vector<std::size_t> which{run.ident.front()};
    which.insert(which.end(), run.hold.begin(), run.hold.end());
    const auto held_model = imageKindModel(d, run.meas, which, run.kind, "reference", r.joint_noise_sigma_rad);
    const auto& relative = dynamic_cast<const calib::RelativePoseModel&>(*held_model);
    r.relative_before = calib::relativeErrors(relative, zero);
    r.relative_after = calib::relativeErrors(relative, r.estimate.y);
  }
}

/// Hold-out validation against the measured poses (and the true ones where the dataset has them: the
/// plant of its true_errors and, where it has one, its errors.yaml with the effects; sample k as the
/// renderer numbered it, approach direction from sample k - 1).
void validateHeldOut(CalibrationRun& run, CalibrateResult& r) {
  const sim::Dataset& d = run.d;
  calib::PlantSamples measured, truth;
  run.true_arm = sim::datasetTrueArm(d);
  for (std::size_t k : run.hold) {
    measured.q_commanded.push_back(d.samples[k].q_rad);
    measured.base_T_flange_true.push_back(run.meas[k].base_T_flange);
    const std::optional<Eigen::VectorXd>& q_true = d.samples[k].q_true_rad;
    if (run.true_arm && q_true) {
      const std::optional<Eigen::VectorXd>* previous = k > 0 ? &d.samples[k - 1].q_true_rad : nullptr;
      truth.q_commanded.push_back(d.samples[k].q_rad);
      truth.base_T_flange_true.push_back(
          run.true_arm->flangePose(static_cast<int>(k), *q_true, previous && *previous ? &**previous : nullptr));
    }
  }
  run.calibrated = calib::calibratedModel(imageFit(run, r)).model.arm;  // before the frames' fit: the estimate's
  if (!run.hold.empty()) {
    r.before = calib::summarize(calib::poseErrors(d.arm, measured));
    r.after = calib::summarize(calib::poseErrors(run.calibrated, measured));
  }
  r.has_truth = !truth.q_commanded.empty();
  if (r.has_truth) {
    r.truth_before = calib::summarize(calib::poseErrors(d.arm, truth));
    r.truth_after = calib::summarize(calib::poseErrors(run.calibrated, truth));
  }
}

/// The written model's fit against its noise, where the noise is given: the scene-frame estimate's
/// per-image test, or with --estimate-frames the frames fit's chi-square (the corner fit estimates its
/// pixel noise, so it has none). Empty: consistent.
std::string inconsistency(const CalibrationRun& run, CalibrateResult& r) {
  if (!r.frames) {
    if (r.consistency.consistent()) return "";
    r.likely_cause = likelyCause(run.d, run.meas, run.ident, run.hold, run.kind, r);
    return "the fit is inconsistent with its noise model: " + calib::formatConsistency(r.consistency) + "; " + r.likely_cause;
  }
  if (r.frames->corners) return "";
  const calib::Fit& f = r.frames->fit;
  if (f.dof <= 0 || calib::chiSquareSurvival(f.chi2, f.dof) >= r.consistency.alpha) return "";
  return "the fit with base_T_board and flange_T_camera estimated is inconsistent with its noise model (chi-square " +
         formatNumber("%.1f", f.chi2) + " for " + std::to_string(f.dof) + "): the robot file or the camera intrinsics do not "
         "describe this arm, or it has effects the DH model lacks (`orbcal diagnose` names them)";
}

/// A calibration never silently makes an arm worse: the model to be written is judged by the one
/// held-out rule of every calibration (calib::heldoutVerdict) on the held-out camera poses, and by its
/// consistency with its noise; a refusal is said first and leaves no calibrated files unless --accept-worse.
void judge(const CalibrationRun& run, CalibrateResult& r) {
  if (const std::string why = inconsistency(run, r); !why.empty()) r.refusals.push_back(why);
  if (!run.hold.empty()) {
    const calib::Fit fit = imageFit(run, r);
    const std::vector<calib::MarkerObservation> held = imageMeasuredData(run.d, run.meas, run.hold).observations;
    std::vector<Eigen::VectorXd> before, after;
    for (const calib::MarkerObservation& x : held) {
      before.push_back(r.frames ? calib::markerResidual(r.frames->fit.model, r.frames->reference_p, x)
                                : calib::markerResidual(fit.model, Eigen::VectorXd::Zero(fit.model.layout.size()), x));
      after.push_back(calib::markerResidual(fit.model, fit.p, x));
    }
    r.verdict = calib::heldoutVerdict(held, before, after, run.o.holdout, run.configurations);
    if (!r.verdict.refusal.empty()) r.refusals.push_back(r.verdict.refusal);
  }
  r.written = r.refusals.empty() || run.o.accept_worse;
}

}  // namespace

CalibrateResult runCalibrate(const CalibrateOptions& o) {
  checkCalibrateOptions(o);
  CalibrationRun run(o);
  run.d = sim::loadDataset(o.dataset);
  sim::requireJointReadings(run.d, "calibrate");
  // With -o nothing is written into the dataset folder (it may be read-only, or hold a measurements.csv
  // of `orbcal measure` with other settings): measurements.csv goes to OUT too. Without -o it goes into
  // the dataset folder, locked meanwhile, so that two runs never mix their files.
  std::optional<sim::FolderLock> dataset_lock;
  if (o.out.empty()) dataset_lock.emplace(o.dataset, "orbcal calibrate");
  run.kind = checkedKind(o, run.d.arm);
  // The inputs are read: the output folder now holds this run's outcome only (sim::OutputFolder).
  sim::OutputFolder folder(o.out.empty() ? o.dataset + "/calibration" : o.out, "orbcal calibrate");
  run.out = folder.path();
  run.measurements_path = (o.out.empty() ? o.dataset : folder.finalPath()) + "/measurements.csv";

  CalibrateResult r;
  measureImages(run, r);
  splitHoldout(run, r);
  fitImages(run, r);
  validateHeldOut(run, r);
  if (o.estimate_frames) r.frames = estimateFrames(run.d, run.meas, run.ident, run.hold, r.joint_noise_sigma_rad, o.effects);
  judge(run, r);
  if (r.written) {
    writeCalibratedFiles(run, r);
    r.robot_path = folder.published(r.robot_path);
    r.urdf_path = folder.published(r.urdf_path);
    r.model_path = folder.published(r.model_path);
  }
  writeSampleErrors(run, r);
  std::string figure_lines = drawFigure(o.callbacks, o.plots, run.out, "samples " + shellQuote(run.out + "/samples.csv"), "samples.png",
                                        "per-image errors before and after");
  if (r.written) {
    figure_lines += drawFigure(o.callbacks, o.plots, run.out, "parameters " + shellQuote(run.out + "/estimates.csv"), "parameters.png",
                               "identified parameters with their 1-sigma");
  }
  const std::string report = calibrationReport(run, r, figure_lines);
  writeReport(run.out, report);
  folder.commit();
  r.report_path = folder.finalPath() + "/report.md";
  return r;
}

}  // namespace orbcal::workflow
