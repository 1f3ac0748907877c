#include "calibrate.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "experiment.hpp"
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
#include "progress.hpp"

namespace orbcal::tools {

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
  const sim::ParamBlock& g = start.layout.block(start.layout.find("geometry"));
  for (int i = 0; i < g.size(); ++i) ref.hold.push_back(g.offset + i);
  const calib::Fit reference = calib::fitMarkerModel(start, obs, ref);
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
      if (b.effect == "geometry" || b.effect == "base" || b.effect == "marker" || b.effect == "distortion") continue;
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
  const sim::KinematicModel km = sim::makeKinematicModel(d.arm, 1, sim::FrameSharing::kKnown, sim::FrameSharing::kKnown,
                                                         {d.scene.base_T_board.inverse()}, {d.scene.flange_T_camera}, {});
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

std::string joinWords(const std::vector<std::string>& words) {
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
           "(its frames.yaml corrects the scene)";
  }
  return "even with base_T_board and flange_T_camera estimated the fit is inconsistent (chi-square " + formatNumber("%.1f", f.fit.chi2) +
         " for " + std::to_string(f.fit.dof) + "): the robot file or the camera intrinsics do not describe this arm, or it has "
         "effects the DH model lacks (`orbcal diagnose` names them)";
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

ParameterColumns parameterColumns(const sim::Arm& arm) {
  ParameterColumns c;
  c.header = "| joint |";
  std::string rule = "|---|";
  for (int k = 0; k < arm.paramsPerJoint(); ++k) {
    std::string key = sim::paramKey(arm, k);
    const std::string stem = key.substr(0, key.rfind('_'));
    std::string& list = sim::isAngleParam(arm, k) ? c.angles : c.lengths;
    list += (list.empty() ? "" : ", ") + stem;
    c.header += " " + stem + " |";
    rule += "---|";
  }
  c.header += "\n" + rule + "\n";
  return c;
}

namespace {
/// "theta1, x1, ..." for the parameters `which` (or "none").
std::string parameterList(const calib::ParameterClasses& classes, const std::vector<int>& which) {
  std::vector<std::string> names;
  for (int i : which) names.push_back(classes.names[static_cast<std::size_t>(i)]);
  return names.empty() ? std::string("none") : joinWords(names);
}
}  // namespace

std::string formatKeptAndHeld(const calib::ParameterClasses& classes) {
  const auto list = [&](const std::vector<int>& which) { return parameterList(classes, which); };
  return "identifiable set: " + std::to_string(classes.minimal.size()) + " of " + std::to_string(classes.names.size()) +
         " parameters kept (" + list(classes.minimal) + "); " + std::to_string(classes.held.size()) + " held as unidentifiable (" +
         list(classes.held) + ")";
}

CalibrateResult runCalibrate(const CalibrateOptions& o) {
  CalibrateResult r;
  if (!(o.holdout >= 0.0 && o.holdout < 1.0)) throw sim::InputError("--holdout: must be within [0, 1)");
  if (!o.effects.empty() && !o.estimate_frames) {
    throw sim::InputError("--effects: an image dataset's effects are fitted with its frames: add --estimate-frames");
  }
  for (const std::string& e : o.effects) {  // before any work: names and joints
    if (!sim::isCameraEffect(e, "--effects")) sim::parseEffect(e, 64, "--effects");
  }
  const sim::Dataset d = sim::loadDataset(o.dataset);
  // With -o nothing is written into the dataset folder (it may be read-only, or hold a measurements.csv
  // of `orbcal measure` with other settings): measurements.csv goes to OUT too. Without -o it goes into
  // the dataset folder, locked meanwhile, so that two runs never mix their files.
  std::optional<sim::FolderLock> dataset_lock;
  if (o.out.empty()) dataset_lock.emplace(o.dataset, "orbcal calibrate");
  for (const std::string& e : o.effects) {
    if (!sim::isCameraEffect(e, "--effects")) sim::parseEffect(e, d.arm.numJoints(), "--effects");
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
  // The inputs are read: the output folder now holds this run's outcome only (sim::OutputFolder).
  sim::OutputFolder folder(o.out.empty() ? o.dataset + "/calibration" : o.out, "orbcal calibrate");
  const std::string& out = folder.path();
  const std::string measurements_path = (o.out.empty() ? o.dataset : folder.finalPath()) + "/measurements.csv";

  std::vector<vision::Measurement> meas;
  {
    Progress bar(o.quiet ? "" : "measure", o.quiet ? 0 : static_cast<int>(d.samples.size()));
    meas = vision::measureDataset(d, {}, [&](int done, int) { bar.update(done); });
  }
  sim::writeFileAtomic(o.out.empty() ? measurements_path : out + "/measurements.csv", vision::formatMeasurementsCsv(meas));
  r.images = static_cast<int>(meas.size());

  // Usable samples, then a seeded hold-out draw.
  std::vector<std::size_t> usable;
  for (std::size_t k = 0; k < meas.size(); ++k) {
    if (meas[k].found()) usable.push_back(k);
  }
  r.usable = static_cast<int>(usable.size());
  std::mt19937_64 rng = sim::makeRng(o.seed, 0x686f6c646f7574ULL);
  std::shuffle(usable.begin(), usable.end(), rng);
  const int n_hold = static_cast<int>(std::floor(o.holdout * r.usable));
  std::vector<std::size_t> hold(usable.begin(), usable.begin() + n_hold), ident(usable.begin() + n_hold, usable.end());
  std::sort(hold.begin(), hold.end());
  std::sort(ident.begin(), ident.end());
  r.identification = static_cast<int>(ident.size());
  r.held_out = n_hold;
  if (static_cast<int>(ident.size()) * 6 < d.arm.numParams()) {
    throw sim::InputError(o.dataset + ": only " + std::to_string(ident.size()) +
                          " usable identification images: at least " + std::to_string((d.arm.numParams() + 5) / 6) +
                          " are needed for " + std::to_string(d.arm.numParams()) + " parameters (" +
                          vision::summaryLine(vision::summarize(meas)) + ")");
  }

  // R: the vision covariance plus the joint noise (unless the method says otherwise).
  r.joint_noise_sigma_rad = o.joint_noise_sigma_rad >= 0.0 ? o.joint_noise_sigma_rad
                            : d.manifest.joint_noise_sigma_rad > 0.0 ? d.manifest.joint_noise_sigma_rad
                                                                       : 0.01 * sim::kDegToRad;
  const calib::MethodSpec method = calib::findMethod(calib::comparisonMethods(r.joint_noise_sigma_rad), o.method);
  std::unique_ptr<calib::MeasurementModel> model;
  if (kind == calib::MeasurementKind::kPose) {
    std::vector<calib::PoseObservation> obs;
    for (std::size_t k : ident) obs.push_back({d.samples[k].q_rad, meas[k].base_T_flange, meas[k].covariance});
    model = std::make_unique<calib::PoseMeasurementModel>(d.arm, std::move(obs), method.noise);
  } else {
    model = imageKindModel(d, meas, ident, kind, o.pairs, r.joint_noise_sigma_rad);
  }
  r.model = calib::measurementKindName(kind);
  r.estimate = calib::runMethod(method, *model);
  r.estimate.method = method.name;
  r.consistency = calib::consistencyTest(*model, r.estimate.y,
                                         r.estimate.rank > 0 ? r.estimate.rank : model->numParams() - static_cast<int>(r.estimate.held.size()));
  for (int k : r.consistency.outliers) {
    const calib::SampleConsistency& sc = r.consistency.samples[static_cast<std::size_t>(k)];
    r.outlier_images.push_back((calib::isRelativeKind(kind) ? "pair " + std::to_string(k + 1) : d.samples[ident[static_cast<std::size_t>(k)]].image) +
                               " (chi-square " + formatNumber("%.1f", sc.chi2) + " for " + std::to_string(sc.rows) + ")");
  }
  // A pose model's parameters are the DH errors; the others' layout starts with them too (known frames).
  r.estimate.y = Eigen::VectorXd(r.estimate.y.head(d.arm.numParams()));
  r.estimate.covariance = Eigen::MatrixXd(r.estimate.covariance.topLeftCorner(d.arm.numParams(), d.arm.numParams()));
  {
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model->numParams());
    r.classes = calib::classifyParameters(*model, zero);
    r.observability = calib::observability(*model, zero, r.classes.held);
    if (n_hold > 0 && calib::isRelativeKind(kind)) {
      std::vector<std::size_t> which{ident.front()};
      which.insert(which.end(), hold.begin(), hold.end());
      const auto held_model = imageKindModel(d, meas, which, kind, "reference", r.joint_noise_sigma_rad);
      const auto& relative = dynamic_cast<const calib::RelativePoseModel&>(*held_model);
      r.relative_before = calib::relativeErrors(relative, zero);
      r.relative_after = calib::relativeErrors(relative, r.estimate.y);
    }
  }

  // Hold-out validation against the measured poses (and the true ones where the dataset has them: the
  // plant of its true_errors and, where it has one, its errors.yaml with the effects; sample k as the
  // renderer numbered it, approach direction from sample k - 1).
  calib::PlantSamples measured, truth;
  const std::optional<sim::TrueArm> true_arm = sim::datasetTrueArm(d);
  for (std::size_t k : hold) {
    measured.q_commanded.push_back(d.samples[k].q_rad);
    measured.base_T_flange_true.push_back(meas[k].base_T_flange);
    const std::optional<Eigen::VectorXd>& q_true = d.samples[k].q_true_rad;
    if (true_arm && q_true) {
      const std::optional<Eigen::VectorXd>* previous = k > 0 ? &d.samples[k - 1].q_true_rad : nullptr;
      truth.q_commanded.push_back(d.samples[k].q_rad);
      truth.base_T_flange_true.push_back(
          true_arm->flangePose(static_cast<int>(k), *q_true, previous && *previous ? &**previous : nullptr));
    }
  }
  const sim::Arm calibrated = sim::withErrors(d.arm, r.estimate.y);
  if (n_hold > 0) {
    r.before = calib::summarize(calib::poseErrors(d.arm, measured));
    r.after = calib::summarize(calib::poseErrors(calibrated, measured));
  }
  r.has_truth = !truth.q_commanded.empty();
  if (r.has_truth) {
    r.truth_before = calib::summarize(calib::poseErrors(d.arm, truth));
    r.truth_after = calib::summarize(calib::poseErrors(calibrated, truth));
  }

  if (o.estimate_frames) r.frames = estimateFrames(d, meas, ident, hold, r.joint_noise_sigma_rad, o.effects);

  // A calibration never silently makes an arm worse: an inconsistent fit, or a held-out error that grew,
  // is said first and leaves no calibrated files unless --accept-worse.
  r.worse = n_hold > 0 && r.after.position_avg_m > r.before.position_avg_m;
  if (!r.consistency.consistent()) r.likely_cause = likelyCause(d, meas, ident, hold, kind, r);
  if (!r.consistency.consistent()) {
    r.refusals.push_back("the fit is inconsistent with its noise model: " + calib::formatConsistency(r.consistency) + "; " +
                         r.likely_cause);
  }
  if (r.worse) {
    r.refusals.push_back("the calibrated arm predicts the " + std::to_string(n_hold) + " held-out images worse than the nominal one ("
                         + formatNumber("%.3f", r.before.position_avg_m * 1e3) + " -> " +
                         formatNumber("%.3f", r.after.position_avg_m * 1e3) + " mm average position error)");
  }
  r.written = r.refusals.empty() || o.accept_worse;

  // Outputs.
  std::ostringstream header;
  header << "Calibrated by orbcal " << ORBCAL_VERSION << " (orbcal calibrate) from " << o.dataset << "\n"
         << "method " << method.name << "; " << r.identification << " identification images of " << r.images << "; nominal: "
         << d.manifest.robot_file << " (" << d.arm.name << ")\n"
         << "Identified parameter errors are added to the nominal DH rows; base and tool are the nominal ones.";
  calib::Comparison single;
  single.methods.push_back({method, r.estimate, {}, {}});
  const Eigen::VectorXd* y_true = d.manifest.true_errors ? &*d.manifest.true_errors : nullptr;
  if (r.written) {
    r.robot_path = out + "/robot_calibrated.yaml";
    sim::Arm named = calibrated;
    named.name = d.arm.name + " (calibrated)";
    if (calibrated.convention == sim::DhConvention::kUrdf && !calibrated.urdf.empty()) {
      // A URDF robot: the URDF it came from with the chain joints' origins replaced by the calibrated
      // ones (zero offsets folded in), beside the YAML, which names it.
      r.urdf_path = out + "/robot_calibrated.urdf";
      named.urdf.file = "robot_calibrated.urdf";
      sim::writeFileAtomic(r.urdf_path, sim::replaceUrdfOrigins(sim::readTextSource(calibrated.urdf.file), calibrated,
                                                                "Joint origins of the chain " + calibrated.urdf.base_link + " -> " +
                                                                    calibrated.urdf.tip_link + " calibrated by orbcal " + ORBCAL_VERSION +
                                                                    " (orbcal calibrate, method " + method.name + ") from " + o.dataset));
    }
    sim::writeFileAtomic(r.robot_path, sim::formatArm(named, header.str()));
    sim::writeFileAtomic(out + "/estimates.csv", calib::formatEstimatesCsv(d.arm, single, y_true));
    r.robot_path = folder.published(r.robot_path);
    r.urdf_path = folder.published(r.urdf_path);
  }

  // Per-image errors against the measured poses, nominal and calibrated, with the inconsistent images marked.
  {
    std::ostringstream rows;
    rows << "image,set,before_mm,after_mm,outlier\n";
    std::vector<bool> outlier(d.samples.size(), false);
    if (calib::isPoseKind(kind) && !calib::isRelativeKind(kind)) {
      for (int k : r.consistency.outliers) outlier[ident[static_cast<std::size_t>(k)]] = true;
    }
    std::vector<std::pair<std::size_t, const char*>> all;
    for (std::size_t k : ident) all.emplace_back(k, "identification");
    for (std::size_t k : hold) all.emplace_back(k, "held-out");
    std::sort(all.begin(), all.end());
    for (const auto& [k, set] : all) {
      const Eigen::Vector3d p = meas[k].base_T_flange.translation();
      rows << d.samples[k].image << "," << set << ","
           << formatNumber("%.6f", (p - sim::forwardKinematics(d.arm, d.samples[k].q_rad).translation()).norm() * 1e3) << ","
           << formatNumber("%.6f", (p - sim::forwardKinematics(calibrated, d.samples[k].q_rad).translation()).norm() * 1e3) << ","
           << (outlier[k] ? 1 : 0) << "\n";
    }
    sim::writeFileAtomic(out + "/samples.csv", rows.str());
  }
  ExperimentOptions figures;
  figures.plots = o.plots;
  std::string figure_lines = drawFigure(figures, out, "samples '" + out + "/samples.csv'", "samples.png",
                                        "per-image errors before and after");
  if (r.written) {
    figure_lines += drawFigure(figures, out, "parameters '" + out + "/estimates.csv'", "parameters.png",
                               "identified parameters with their 1-sigma");
  }

  std::ostringstream md;
  const ParameterColumns columns = parameterColumns(d.arm);
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
     << (method.kind == calib::MethodSpec::Kind::kEkf ? " (the EKF estimates every parameter under its prior; LSE and LM hold these)" : "")
     << ".\n"
     << "\nObservability indices (Borm & Menq 1991 O1 to Sun & Hollerbach 2008 O5; whitened rows, columns in typical "
        "magnitudes, held parameters left out; larger is better): " << calib::formatIndices(r.observability) << ".\n\n"
     << "## Estimate\n\n"
     << r.estimate.iterations << " iterations, rank " << r.estimate.rank << ", " << formatNumber("%.2f", r.estimate.seconds * 1e3)
     << " ms" << (r.estimate.converged ? "" : ", NOT converged") << ". Per joint, " << columns.angles << " in deg, " << columns.lengths
     << " in mm, +- 1 sigma" << (y_true ? "; truth in brackets" : "") << ":\n\n"
     << columns.header;
  for (int j = 0; j < d.arm.numJoints(); ++j) {
    md << "| " << j + 1 << " |";
    for (int k = 0; k < d.arm.paramsPerJoint(); ++k) {
      const int i = sim::paramIndex(d.arm, j, static_cast<sim::ParamKind>(k));
      const double s = sim::isAngleParam(d.arm, i) ? sim::kRadToDeg : 1e3;
      const bool held = std::find(r.estimate.held.begin(), r.estimate.held.end(), i) != r.estimate.held.end();
      md << " " << formatNumber("%+.4f", r.estimate.y[i] * s);
      if (held) {
        md << " (held)";
      } else {
        md << " +- " << formatNumber("%.4f", std::sqrt(std::max(0.0, r.estimate.covariance(i, i))) * s);
      }
      if (y_true) md << " [" << formatNumber("%+.4f", (*y_true)[i] * s) << "]";
      md << " |";
    }
    md << "\n";
  }
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
  if (n_hold > 0) {
    md << "\n## Hold-out validation against the measured poses\n\n"
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
  if (r.frames) {
    sim::writeFileAtomic(out + "/frames.yaml", "# base_T_board and flange_T_camera estimated by orbcal calibrate --estimate-frames "
                                               "(paste into the scene)\nbase_T_board: " + sim::transformYaml(r.frames->base_T_board) +
                                               "\nflange_T_camera: " + sim::transformYaml(r.frames->flange_T_camera) + "\n");
  }
  md << "## Figures\n\n" << figure_lines << "\n";
  md << (r.written ? "Files: `robot_calibrated.yaml` (load it with `--robot`), `estimates.csv`, `samples.csv` (per-image errors); measurements in `"
                   : "No calibrated files were written (see the top). `samples.csv` (per-image errors); measurements in `")
     << measurements_path << "`.\n";
  sim::writeFileAtomic(out + "/report.md", md.str());
  folder.commit();
  r.report_path = folder.finalPath() + "/report.md";
  return r;
}

}  // namespace orbcal::tools
