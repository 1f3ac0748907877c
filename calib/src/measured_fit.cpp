#include "orbcal/calib/measured_fit.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <cmath>
#include <future>
#include <limits>
#include <map>

#include "reml.hpp"
#include "stacked_system.hpp"
#include "orbcal/calib/observability.hpp"
#include "orbcal/calib/registration.hpp"
#include "orbcal/calib/rigid_body.hpp"
#include "orbcal/sim/marker_points.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/gravity.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::calib {

bool needsTorque(const std::vector<sim::Effect>& effects) {
  for (const sim::Effect& e : effects) {
    if (e.kind().needs().torque) return true;
  }
  return false;
}

std::vector<MarkerObservation> observationsFrom(const sim::MeasuredData& data, bool needs_torque) {
  if (needs_torque && !data.has_torque && data.arm.masses.empty()) {
    std::string links;
    for (const std::string& l : data.arm.urdf.links_without_inertial) links += (links.empty() ? "" : ", ") + l;
    throw sim::InputError(data.description + ": covariates.torque: compliance needs joint torques: the data has no torque "
                          "column and the robot file (" + data.robot_file + ") " +
                          (links.empty() ? std::string("no masses section") : "no <inertial> on the links the chain moves (" + links + ")") +
                          " to compute them from");
  }
  std::vector<MarkerObservation> obs;
  obs.reserve(data.poses.size());
  for (const sim::MeasuredPose& m : data.poses) {
    MarkerObservation o{m.sample, m.world_T_marker, m.has_rotation, {}, m.point};
    if (needs_torque && !o.sample.hasTorque()) o.sample.tau_Nm = sim::gravityTorques(data.arm, data.arm.masses, o.sample.q_rad);
    obs.push_back(std::move(o));
  }
  return obs;
}

namespace {

bool allRotations(const std::vector<MarkerObservation>& obs) {
  for (const MarkerObservation& o : obs) {
    if (!o.has_rotation) return false;
  }
  return true;
}

/// The chordal mean of rotations, projected onto SO(3), and the mean translation.
Eigen::Isometry3d meanTransform(const std::vector<Eigen::Isometry3d>& Ts) {
  Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  for (const Eigen::Isometry3d& T : Ts) {
    S += T.linear();
    t += T.translation();
  }
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = sim::projectToSO3(S);
  out.translation() = t / static_cast<double>(Ts.size());
  return out;
}

/// world_T_base with the marker known: from full poses, the mean of T_k M^-1 F_k^-1; from positions,
/// the rigid registration of the predicted marker positions onto the measured ones.
Eigen::Isometry3d baseWithKnownMarker(const std::vector<Eigen::Isometry3d>& T, const std::vector<Eigen::Isometry3d>& F,
                                      const Eigen::Isometry3d& M, bool use_rotation) {
  if (use_rotation) {
    std::vector<Eigen::Isometry3d> W;
    for (std::size_t k = 0; k < T.size(); ++k) W.push_back(T[k] * M.inverse() * F[k].inverse());
    return meanTransform(W);
  }
  Eigen::Matrix3Xd src(3, static_cast<Eigen::Index>(T.size())), dst(3, static_cast<Eigen::Index>(T.size()));
  for (std::size_t k = 0; k < T.size(); ++k) {
    src.col(static_cast<Eigen::Index>(k)) = (F[k] * M).translation();
    dst.col(static_cast<Eigen::Index>(k)) = T[k].translation();
  }
  return Eigen::Isometry3d(Eigen::umeyama(src, dst, false));
}

struct SessionPoses {
  std::vector<Eigen::Isometry3d> T, F;
};

/// The unknown frames of `shape` (its sharing and known frames) from measured poses and the flange
/// poses of a model at the same samples; the frames of `shape` that are estimated are replaced.
void guessFrames(sim::KinematicModel& shape, const std::vector<MarkerObservation>& obs,
                 const std::vector<Eigen::Isometry3d>& F) {
  using sim::FrameSharing;
  const bool rot = allRotations(obs);
  const int S = shape.sessions;
  std::vector<SessionPoses> per(static_cast<std::size_t>(S));
  SessionPoses all;
  for (std::size_t k = 0; k < obs.size(); ++k) {
    per[static_cast<std::size_t>(obs[k].sample.session)].T.push_back(obs[k].world_T_marker);
    per[static_cast<std::size_t>(obs[k].sample.session)].F.push_back(F[k]);
    all.T.push_back(obs[k].world_T_marker);
    all.F.push_back(F[k]);
  }
  std::size_t largest = 0;
  for (std::size_t s = 0; s < per.size(); ++s) {
    if (per[s].T.size() > per[largest].T.size()) largest = s;
  }
  const auto markerGiven = [&](const SessionPoses& sp, const Eigen::Isometry3d& W) { return initialMarker(sp.T, sp.F, W, rot); };
  if (shape.base == FrameSharing::kPerSession) {
    for (int s = 0; s < S; ++s) {
      const SessionPoses& sp = per[static_cast<std::size_t>(s)];
      if (shape.marker == FrameSharing::kKnown) {
        shape.world_T_base[static_cast<std::size_t>(s)] = baseWithKnownMarker(sp.T, sp.F, shape.flange_T_marker[0], rot);
        continue;
      }
      const RegistrationGuess g = initialRegistration(sp.T, sp.F, rot);
      shape.world_T_base[static_cast<std::size_t>(s)] = g.world_T_base;
      if (shape.marker == FrameSharing::kPerSession) shape.flange_T_marker[static_cast<std::size_t>(s)] = g.flange_T_marker;
      if (shape.marker == FrameSharing::kShared && static_cast<std::size_t>(s) == largest) shape.flange_T_marker[0] = g.flange_T_marker;
    }
    return;
  }
  if (shape.base == FrameSharing::kShared) {
    if (shape.marker == FrameSharing::kKnown) {
      shape.world_T_base[0] = baseWithKnownMarker(all.T, all.F, shape.flange_T_marker[0], rot);
      return;
    }
    // With a marker per session, the largest session alone fixes the base.
    const RegistrationGuess g = initialRegistration(shape.marker == FrameSharing::kShared ? all.T : per[largest].T,
                                                    shape.marker == FrameSharing::kShared ? all.F : per[largest].F, rot);
    shape.world_T_base[0] = g.world_T_base;
    if (shape.marker == FrameSharing::kShared) shape.flange_T_marker[0] = g.flange_T_marker;
  }
  if (shape.marker == FrameSharing::kPerSession) {
    for (int s = 0; s < S; ++s) shape.flange_T_marker[static_cast<std::size_t>(s)] = markerGiven(per[static_cast<std::size_t>(s)], shape.world_T_base[0]);
  } else if (shape.marker == FrameSharing::kShared && shape.base == FrameSharing::kKnown) {
    shape.flange_T_marker[0] = markerGiven(all, shape.world_T_base[0]);
  }
}

std::vector<Eigen::Isometry3d> framesFor(sim::FrameSharing sharing, int sessions, const Eigen::Isometry3d& T) {
  return std::vector<Eigen::Isometry3d>(sharing == sim::FrameSharing::kPerSession ? static_cast<std::size_t>(sessions) : 1, T);
}

}  // namespace

double NoiseComponents::sigmaSd(int c) const {
  const double v = variance[c], sd = std::sqrt(std::max(0.0, covariance(c, c)));
  return v > sd ? sd / (2.0 * std::sqrt(v)) : std::sqrt(sd);
}

double NoiseComponents::sigmaUpper(int c) const {
  return std::sqrt(std::max(0.0, variance[c]) + 2.0 * std::sqrt(std::max(0.0, covariance(c, c))));
}

bool NoiseComponents::resolved(int c) const {
  return estimated[static_cast<std::size_t>(c)] && variance[c] > 2.0 * std::sqrt(std::max(0.0, covariance(c, c)));
}

double NoiseComponents::correlation(int a, int b) const {
  const double d = std::sqrt(std::max(0.0, covariance(a, a)) * std::max(0.0, covariance(b, b)));
  return d > 0.0 ? covariance(a, b) / d : 0.0;
}

namespace {

/// Each effect adapted to the samples it is fitted on (Effect kinds' adaptTo: a range, a default order).
void adaptEffects(const std::vector<MarkerObservation>& observations, std::vector<sim::Effect>& effects) {
  std::vector<sim::JointSample> samples;
  for (const MarkerObservation& o : observations) samples.push_back(o.sample);
  for (sim::Effect& e : effects) e = e.kind().adaptTo(e, samples);
}

}  // namespace

sim::KinematicModel startingModel(const sim::MeasuredData& data, const std::vector<MarkerObservation>& observations,
                                  std::vector<sim::Effect> effects) {
  const int S = data.numSessions();
  adaptEffects(observations, effects);
  sim::KinematicModel shape = sim::makeKinematicModel(data.arm, S, data.base, data.marker, framesFor(data.base, S, data.world_T_base),
                                                      framesFor(data.marker, S, data.flange_T_marker), std::move(effects));
  std::vector<Eigen::Isometry3d> F;
  for (const MarkerObservation& o : observations) F.push_back(sim::forwardKinematics(data.arm, o.sample.q_rad));
  if (data.points > 0) return rigidBodyStart(data, observations, F, shape);
  try {
    guessFrames(shape, observations, F);
  } catch (const std::invalid_argument& e) {
    throw sim::InputError(data.description + ": registration: the samples cannot fix the unknown frames (" + e.what() + ")");
  }
  return shape;
}

sim::KinematicModel startingModelFrom(const sim::KinematicModel& start, const std::vector<MarkerObservation>& observations,
                                      std::vector<sim::Effect> effects) {
  adaptEffects(observations, effects);
  return sim::makeKinematicModel(start.arm, start.sessions, start.base, start.marker, start.world_T_base, start.flange_T_marker,
                                 std::move(effects), start.geometry, start.marker_points);
}

ResidualStats residualStats(const std::vector<Eigen::VectorXd>& residuals) {
  ResidualStats s;
  s.samples = static_cast<int>(residuals.size());
  if (residuals.empty()) return s;
  double pos2 = 0.0, rot2 = 0.0;
  int nrot = 0;
  for (const Eigen::VectorXd& r : residuals) {
    const double e = r.head<3>().norm();
    s.position_mean_m += e / s.samples;
    pos2 += e * e;
    s.position_max_m = std::max(s.position_max_m, e);
    if (r.size() == 6) {
      const double a = r.tail<3>().norm();
      rot2 += a * a;
      ++nrot;
      s.rotation_max_rad = std::max(s.rotation_max_rad, a);
    }
  }
  s.position_rms_m = std::sqrt(pos2 / s.samples);
  s.rotation_rms_rad = nrot ? std::sqrt(rot2 / nrot) : 0.0;
  s.rotation_samples = nrot;
  return s;
}

ResidualStats residualStats(const sim::KinematicModel& model, const Eigen::VectorXd& p,
                            const std::vector<MarkerObservation>& observations) {
  return residualStats(markerResiduals(model, p, observations));
}

FitControls fitControls(const FitOptions& o, const sim::ParamLayout& layout, const Eigen::VectorXd& p0) {
  FitControls controls;
  controls.hold = o.hold;
  controls.fix_unidentifiable = o.fix_unidentifiable;
  controls.covariance = o.analyze;
  controls.normal_equations = o.normal_equations;
  controls.prior_sigma = fitPriorSigma(o, layout);
  if (controls.prior_sigma.size()) controls.prior_mean = -p0;  // centred on the starting model: p = p0 + y = 0
  if (o.map) {
    controls.scaled_prior = Eigen::VectorXd::Zero(layout.size());
    const int g = layout.find(sim::BlockKind::kGeometry);
    if (g >= 0) controls.scaled_prior.segment(layout.block(g).offset, layout.block(g).size()) = layout.typical().segment(layout.block(g).offset, layout.block(g).size());
  }
  return controls;
}

Eigen::VectorXd geometryPriorSigma(const sim::ParamLayout& layout) {
  const Eigen::VectorXd typical = layout.typical();
  Eigen::VectorXd sigma = Eigen::VectorXd::Zero(layout.size());
  for (const sim::ParamBlock& b : layout.blocks()) {
    using K = sim::BlockKind;
    if (b.kind != K::kGeometry && b.kind != K::kBase && b.kind != K::kMarker && !sim::isPointBlock(b)) continue;
    sigma.segment(b.offset, b.size()) = typical.segment(b.offset, b.size());
  }
  return sigma;
}

namespace {
/// FitOptions::effect_prior's 1-sigma in typical magnitudes: wide, so that a real effect of a few typical
/// sizes (a stiffening compliance an empirical cubic of torque takes) is not shrunk into the noise.
constexpr double kEffectPriorScale = 10.0;
}  // namespace

Eigen::VectorXd fitPriorSigma(const FitOptions& o, const sim::ParamLayout& layout) {
  if (!o.geometry_prior && !o.map && !o.effect_prior) return {};
  Eigen::VectorXd sigma = o.geometry_prior || o.map ? geometryPriorSigma(layout) : Eigen::VectorXd::Zero(layout.size());
  if (!o.effect_prior) return sigma;
  const Eigen::VectorXd typical = layout.typical();
  const Eigen::VectorXd guarded = geometryPriorSigma(layout);  // the blocks that are not effects
  for (int i = 0; i < layout.size(); ++i) {
    if (guarded[i] == 0.0) sigma[i] = kEffectPriorScale * typical[i];
  }
  return sigma;
}

namespace {

/// The free parameters an estimate effectively uses (its hat matrix's trace) under `options`' prior:
/// from the LM's own normal equations where it has them, else shrinkage()'s.
double effectiveParameters(const MeasurementModel& m, const Estimate& e, const FitOptions& o, const sim::ParamLayout& layout) {
  if (e.effective_parameters > 0.0) return e.effective_parameters;
  return shrinkage(m, e.y, e.held, fitPriorSigma(o, layout)).effective;
}

/// LmOptions::decrease_tolerance of a round whose fit only feeds the noise's next estimate: within about
/// 0.045 standard deviations of the round's minimum, which raises the weighted sum of squares the noise
/// is estimated from by at most about 2e-3 (in the noise's units; the sum is about one per row). The last
/// round, the fit itself, keeps the default.
constexpr double kNoiseRoundDecrease = 1e-3;

}  // namespace

Fit fitMarkerModel(const sim::KinematicModel& start, const std::vector<MarkerObservation>& obs, const FitOptions& o,
                   const Eigen::VectorXd& p0_in) {
  Fit fit;
  fit.model = start;
  fit.p0 = p0_in.size() ? p0_in : Eigen::VectorXd::Zero(start.layout.size());
  fit.noise.joint_noise_sigma_rad = o.joint_noise_sigma_rad;
  if (o.sigma_position_m) fit.noise.sigma_position_m = *o.sigma_position_m;
  if (o.sigma_rotation_rad) fit.noise.sigma_rotation_rad = *o.sigma_rotation_rad;
  fit.noise_estimated = !(o.sigma_position_m && o.sigma_rotation_rad) || o.estimate_joint_noise;
  const int rounds = fit.noise_estimated ? 3 : 1;
  int rows = 0;
  for (const MarkerObservation& x : obs) rows += x.has_rotation ? 6 : 3;
  Eigen::MatrixXd R_start;  // the whitened Jacobian's R factor at the start (y = 0) of the first round
  for (int round = 0; round < rounds; ++round) {
    const MarkerPoseModel m(start, obs, fit.noise, fit.p0);
    if (round == 0 && o.analyze) {
      std::vector<std::string> names;
      for (int i = 0; i < m.numParams(); ++i) names.push_back(m.paramName(i));
      // From the whitened Jacobian's R factor (its column norms, singular values and right vectors).
      R_start = whitenedRFactor(m, Eigen::VectorXd::Zero(m.numParams()));
      fit.identifiability = sim::analyzeJacobian(R_start, names, m.numSamples(), sim::kRankTolerance);
      fit.identifiability.num_rows = rows;
    }
    // Without analyses a round starts where the round before ended when that round converged (where
    // it did not, its end point depends on where LM stopped: docs/benchmarks.md), the last round always.
    const bool warm = !o.analyze && round > 0 && (round + 1 == rounds || fit.estimate.converged);
    FitControls controls = fitControls(o, start.layout, fit.p0);
    if (warm) {
      controls.start = fit.estimate.y;
      // The same start point, whitened with another noise: the data determine the same combinations of
      // the parameters. The round before's held ones, without another R factor of every sample.
      controls.hold = fit.estimate.held;
      controls.fix_unidentifiable = false;
    }
    if (round + 1 < rounds) controls.decrease_tolerance = kNoiseRoundDecrease;
    const Eigen::VectorXd round_start = fit.estimate.y;
    fit.estimate = runMethod(findMethod(comparisonMethods(o.joint_noise_sigma_rad), o.method, "method"), m, controls);
    fit.p = fit.p0 + fit.estimate.y;
    fit.chi2 = 2.0 * fit.estimate.cost;
    const int free = m.numParams() - static_cast<int>(fit.estimate.held.size());
    fit.effective_parameters = o.map ? fit.estimate.effective_parameters
                               : o.effect_prior ? effectiveParameters(m, fit.estimate, o, start.layout)
                                                : free;
    fit.prior_scale = fit.estimate.prior_scale;
    fit.dof = std::max(1, rows - static_cast<int>(std::lround(fit.effective_parameters)));
    if (round + 1 == rounds) {
      // The first round's model is whitened as at the start: its R factor there is the one already taken.
      if (o.analyze) {
        fit.observability = round == 0 ? observability(R_start, m, fit.estimate.held)
                                       : observability(m, Eigen::VectorXd::Zero(m.numParams()), fit.estimate.held);
      }
      break;
    }
    // A warm round whose LM took no step ends where the round before did: the noise estimated there, from
    // these residuals, stands (estimated again, it moves by less than its own stopping tolerance).
    if (warm && fit.estimate.y == round_start) continue;
    const double correction = static_cast<double>(rows) / fit.dof;
    if (o.estimate_joint_noise) {
      const bool rotations = std::any_of(obs.begin(), obs.end(), [](const MarkerObservation& x) { return x.has_rotation; });
      fit.noise = estimateNoiseComponents(m, fit.estimate.y, fit.noise, {!o.sigma_position_m, !o.sigma_rotation_rad && rotations, true},
                                          fit.estimate.held, o.geometry_prior || o.effect_prior ? fitPriorSigma(o, start.layout) : Eigen::VectorXd(),
                                          &fit.noise_components);
      continue;
    }
    // Variance components: position and rotation sigmas from their residuals, corrected for the
    // parameters fitted (rows / dof).
    double pos2 = 0.0, rot2 = 0.0;
    int npos = 0, nrot = 0;
    for (const Eigen::VectorXd& r : markerResiduals(start, fit.p, obs)) {
      pos2 += r.head<3>().squaredNorm();
      npos += 3;
      if (r.size() == 6) {
        rot2 += r.tail<3>().squaredNorm();
        nrot += 3;
      }
    }
    if (!o.sigma_position_m) fit.noise.sigma_position_m = std::max(1e-9, std::sqrt(pos2 / npos * correction));
    if (!o.sigma_rotation_rad && nrot) fit.noise.sigma_rotation_rad = std::max(1e-9, std::sqrt(rot2 / nrot * correction));
  }
  fit.residuals = residualStats(start, fit.p, obs);
  if (!o.analyze) return fit;
  const Eigen::VectorXd typical = start.layout.typical();
  for (int i = 0; i < start.layout.size(); ++i) {
    if (std::binary_search(fit.estimate.held.begin(), fit.estimate.held.end(), i)) continue;
    if (fit.estimate.covariance.rows() > i && std::sqrt(std::max(0.0, fit.estimate.covariance(i, i))) > typical[i]) {
      fit.weak.push_back(i);
    }
  }
  return fit;
}

CalibratedModel calibratedModel(const Fit& fit) {
  sim::FoldedModel f = sim::foldParameters(fit.model, fit.p);
  return {std::move(f.model), std::move(f.p)};
}

CalibratedModel calibratedModel(const Fit& fit, const std::vector<MarkerObservation>& fitted_on) {
  CalibratedModel c = calibratedModel(fit);
  std::vector<sim::JointSample> samples;
  for (const MarkerObservation& o : fitted_on) samples.push_back(o.sample);
  for (sim::Effect& e : c.model.effects) e = sim::recordFittedRanges(e, c.model.arm, samples);
  return c;
}

Fit predictWithModel(const CalibratedModel& c, const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs,
                     const FitOptions& options) {
  using sim::FrameSharing;
  const sim::KinematicModel& cm = c.model;
  const int S = data.numSessions();
  // The data's per-session frames are refitted; every other frame is the model's (its first where
  // the model had one per session).
  const auto sharing = [](FrameSharing in_data) {
    return in_data == FrameSharing::kPerSession ? FrameSharing::kPerSession : FrameSharing::kKnown;
  };
  const FrameSharing base = sharing(data.base), marker = sharing(data.marker);
  sim::KinematicModel m = sim::makeKinematicModel(cm.arm, S, base, marker, framesFor(base, S, cm.world_T_base.front()),
                                                  framesFor(marker, S, cm.flange_T_marker.front()), cm.effects, false,
                                                  cm.marker_points);
  // Effect values by name (mount changes are per session: refitted, not carried).
  std::map<std::string, double> value;
  for (const sim::ParamBlock& b : cm.layout.blocks()) {
    for (int i = 0; i < b.size(); ++i) value[b.params[static_cast<std::size_t>(i)].name] = c.p[b.offset + i];
  }
  Eigen::VectorXd p0 = Eigen::VectorXd::Zero(m.layout.size());
  FitOptions o = options;
  o.hold.clear();
  for (const sim::ParamBlock& b : m.layout.blocks()) {
    const bool refit = sim::isRegistrationFrame(b.kind);
    for (int i = 0; i < b.size(); ++i) {
      if (refit) continue;
      o.hold.push_back(b.offset + i);
      const auto it = value.find(b.params[static_cast<std::size_t>(i)].name);
      if (it != value.end()) p0[b.offset + i] = it->second;
    }
  }
  if (static_cast<int>(o.hold.size()) == m.layout.size()) {
    // Nothing to refit: the model predicts the data as it is.
    Fit fit;
    fit.model = m;
    fit.p0 = fit.p = p0;
    fit.estimate.held = o.hold;  // every parameter: none was fitted
    fit.residuals = residualStats(m, p0, obs);
    return fit;
  }
  // Per-session frames from the calibrated model's flange poses.
  std::vector<Eigen::Isometry3d> F;
  for (const MarkerObservation& x : obs) F.push_back(sim::flangePose(m, p0, x.sample));
  try {
    guessFrames(m, obs, F);
  } catch (const std::invalid_argument& e) {
    throw sim::InputError(data.description + ": registration: the samples cannot fix the per-session frames (" + e.what() + ")");
  }
  return fitMarkerModel(m, obs, o, p0);
}

std::vector<sim::RangeExcess> rangeExcesses(const sim::KinematicModel& model, const std::vector<MarkerObservation>& observations) {
  std::vector<sim::JointSample> samples;
  for (const MarkerObservation& o : observations) samples.push_back(o.sample);
  return sim::rangeExcesses(model.effects, model.arm, samples);
}

std::vector<std::string> outsideTrustedRange(const sim::KinematicModel& model, const std::vector<MarkerObservation>& observations) {
  std::vector<std::string> out;
  for (const sim::RangeExcess& r : rangeExcesses(model, observations)) {
    if (r.outside > 0) out.push_back(sim::rangeExcessText(r));
  }
  return out;
}

}  // namespace orbcal::calib
