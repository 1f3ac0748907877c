#include "orbcal/calib/marker_model.hpp"

#include <stdexcept>

#include "halves.hpp"
#include "orbcal/sim/marker_points.hpp"

namespace orbcal::calib {

MarkerPoseModel::MarkerPoseModel(sim::KinematicModel model, std::vector<MarkerObservation> observations,
                                 MarkerNoise noise, Eigen::VectorXd p0)
    : model_(std::move(model)), observations_(std::move(observations)), noise_(noise), p0_(std::move(p0)) {
  if (p0_.size() == 0) p0_ = Eigen::VectorXd::Zero(model_.layout.size());
  if (p0_.size() != model_.layout.size()) throw std::invalid_argument("MarkerPoseModel: p0 has the wrong size");
  for (const MarkerObservation& o : observations_) sim::checkJointVector(model_.arm, o.sample.q_rad, "MarkerPoseModel");
}

namespace {

/// The residual of an observation and, where asked, its derivatives over the parameters (H) and the
/// joint readings (Jq), both in the residual's coordinates; R: the rotation that carries a marker-frame
/// covariance into them (position-only residuals are in the measuring system's frame).
struct Predicted {
  Eigen::VectorXd residual;
  Eigen::MatrixXd H, Jq;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
};

Predicted predictObservation(const sim::KinematicModel& model, const Eigen::VectorXd& p, const MarkerObservation& o,
                             bool with_H, bool with_q) {
  Predicted out;
  Eigen::MatrixXd J_p, J_q;
  if (o.point >= 0) {  // a marker point of a rigid body: its position, in the measuring system's frame
    const Eigen::Vector3d x = sim::predictMarkerPoint(model, p, o.sample, o.point, with_H ? &J_p : nullptr, with_q ? &J_q : nullptr);
    out.residual = o.world_T_marker.translation() - x;
    out.H = std::move(J_p);
    out.Jq = std::move(J_q);
    return out;
  }
  const Eigen::Isometry3d predicted = sim::predictMarkerPose(model, p, o.sample, with_H ? &J_p : nullptr, with_q ? &J_q : nullptr);
  out.R = predicted.linear();
  if (o.has_rotation) {
    out.residual = sim::poseMinus(o.world_T_marker, predicted);
    out.H = std::move(J_p);
    out.Jq = std::move(J_q);
    return out;
  }
  // Position-only: the marker-frame translation rows rotated into the measuring system's frame.
  out.residual = o.world_T_marker.translation() - predicted.translation();
  if (with_H) out.H = out.R * J_p.topRows(3);
  if (with_q) out.Jq = out.R * J_q.topRows(3);
  return out;
}

}  // namespace

MarkerPoseModel poseModel(const sim::Arm& nominal, const std::vector<PoseObservation>& observations, const PoseNoiseModel& noise) {
  std::vector<MarkerObservation> obs;
  obs.reserve(observations.size());
  for (const PoseObservation& o : observations) {
    MarkerObservation m;
    m.sample.q_rad = o.q_rad;
    m.world_T_marker = o.base_T_flange;
    if (noise.source == PoseNoiseModel::Source::kObservation) m.covariance = o.covariance;
    obs.push_back(std::move(m));
  }
  MarkerNoise n;
  n.sigma_position_m = noise.sigma_position_m;
  n.sigma_rotation_rad = noise.sigma_orientation_rad;
  n.joint_noise_sigma_rad = noise.joint_noise_sigma_rad;
  return MarkerPoseModel(sim::flangeModel(nominal), std::move(obs), n);
}

Eigen::VectorXd markerResidual(const sim::KinematicModel& model, const Eigen::VectorXd& p, const MarkerObservation& o) {
  return predictObservation(model, p, o, false, false).residual;
}

std::vector<Eigen::VectorXd> markerResiduals(const sim::KinematicModel& model, const Eigen::VectorXd& p,
                                             const std::vector<MarkerObservation>& obs) {
  std::vector<Eigen::VectorXd> r(obs.size());
  onHalves(static_cast<int>(obs.size()), [&](int k0, int k1) {
    for (int k = k0; k < k1; ++k) r[static_cast<std::size_t>(k)] = markerResidual(model, p, obs[static_cast<std::size_t>(k)]);
    return 0;
  });
  return r;
}

Linearization MarkerPoseModel::linearize(int k, const Eigen::VectorXd& y) const { return linearized(k, y, true); }

Linearization MarkerPoseModel::innovationAndCovariance(int k, const Eigen::VectorXd& y) const { return linearized(k, y, false); }

Linearization MarkerPoseModel::linearized(int k, const Eigen::VectorXd& y, bool with_H) const {
  const MarkerObservation& o = observations_.at(static_cast<std::size_t>(k));
  const bool joint_noise = noise_.joint_noise_sigma_rad > 0.0;
  Predicted pr = predictObservation(model_, p0_ + y, o, with_H, joint_noise);
  Linearization lin;
  lin.innovation = std::move(pr.residual);
  const int m = rows(k);
  if (with_H) lin.H = std::move(pr.H);
  if (o.covariance.size() > 0) {
    lin.R = m == 6 ? o.covariance : Eigen::MatrixXd(pr.R * o.covariance.topLeftCorner(3, 3) * pr.R.transpose());
  } else {
    Eigen::VectorXd d(m);
    d.head(3).setConstant(noise_.sigma_position_m * noise_.sigma_position_m);
    if (m == 6) d.tail(3).setConstant(noise_.sigma_rotation_rad * noise_.sigma_rotation_rad);
    lin.R = d.asDiagonal();
  }
  if (joint_noise) lin.R += noise_.joint_noise_sigma_rad * noise_.joint_noise_sigma_rad * pr.Jq * pr.Jq.transpose();
  return lin;
}

Eigen::VectorXd MarkerPoseModel::innovation(int k, const Eigen::VectorXd& y) const {
  return markerResidual(model_, p0_ + y, observations_.at(static_cast<std::size_t>(k)));
}

Eigen::MatrixXd MarkerPoseModel::jointJacobian(int k, const Eigen::VectorXd& y, Eigen::VectorXd* residual, Eigen::MatrixXd* H) const {
  Predicted pr = predictObservation(model_, p0_ + y, observations_.at(static_cast<std::size_t>(k)), H != nullptr, true);
  if (residual) *residual = std::move(pr.residual);
  if (H) *H = std::move(pr.H);
  return pr.Jq;
}

}  // namespace orbcal::calib
