#include "orbcal/calib/marker_model.hpp"

#include <stdexcept>

namespace orbcal::calib {

MarkerPoseModel::MarkerPoseModel(sim::KinematicModel model, std::vector<MarkerObservation> observations,
                                 MarkerNoise noise, Eigen::VectorXd p0)
    : model_(std::move(model)), observations_(std::move(observations)), noise_(noise), p0_(std::move(p0)) {
  if (p0_.size() == 0) p0_ = Eigen::VectorXd::Zero(model_.layout.size());
  if (p0_.size() != model_.layout.size()) throw std::invalid_argument("MarkerPoseModel: p0 has the wrong size");
  for (const MarkerObservation& o : observations_) sim::checkJointVector(model_.arm, o.sample.q_rad, "MarkerPoseModel");
}

namespace {
Eigen::VectorXd residualOf(const MarkerObservation& o, const Eigen::Isometry3d& predicted) {
  if (o.has_rotation) return sim::poseMinus(o.world_T_marker, predicted);
  return o.world_T_marker.translation() - predicted.translation();
}

/// The joint Jacobian of the prediction error as the residual sees it: position-only residuals are
/// in the measuring system's frame, so the marker-frame translation rows are rotated into it.
Eigen::MatrixXd residualJointJacobian(const MarkerObservation& o, const Eigen::Isometry3d& predicted, const Eigen::MatrixXd& J_e_q) {
  return o.has_rotation ? J_e_q : Eigen::MatrixXd(predicted.linear() * J_e_q.topRows(3));
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
  return residualOf(o, sim::predictMarkerPose(model, p, o.sample));
}

Linearization MarkerPoseModel::linearize(int k, const Eigen::VectorXd& y) const { return linearized(k, y, true); }

Linearization MarkerPoseModel::innovationAndCovariance(int k, const Eigen::VectorXd& y) const { return linearized(k, y, false); }

Linearization MarkerPoseModel::linearized(int k, const Eigen::VectorXd& y, bool with_H) const {
  const MarkerObservation& o = observations_.at(static_cast<std::size_t>(k));
  Eigen::MatrixXd J_e_p, J_e_q;
  const Eigen::Isometry3d predicted = sim::predictMarkerPose(model_, p0_ + y, o.sample, with_H ? &J_e_p : nullptr,
                                                             noise_.joint_noise_sigma_rad > 0.0 ? &J_e_q : nullptr);
  Linearization lin;
  lin.innovation = residualOf(o, predicted);
  const int m = rows(k);
  // Position-only: the marker-frame translation rows rotated into the measuring system's frame.
  const Eigen::Matrix3d R = predicted.linear();
  if (with_H) lin.H = o.has_rotation ? J_e_p : Eigen::MatrixXd(R * J_e_p.topRows(3));
  if (o.covariance.size() > 0) {
    lin.R = o.has_rotation ? o.covariance : Eigen::MatrixXd(R * o.covariance.topLeftCorner(3, 3) * R.transpose());
  } else {
    Eigen::VectorXd d(m);
    d.head(3).setConstant(noise_.sigma_position_m * noise_.sigma_position_m);
    if (m == 6) d.tail(3).setConstant(noise_.sigma_rotation_rad * noise_.sigma_rotation_rad);
    lin.R = d.asDiagonal();
  }
  if (noise_.joint_noise_sigma_rad > 0.0) {
    const Eigen::MatrixXd Jq = residualJointJacobian(o, predicted, J_e_q);
    lin.R += noise_.joint_noise_sigma_rad * noise_.joint_noise_sigma_rad * Jq * Jq.transpose();
  }
  return lin;
}

Eigen::VectorXd MarkerPoseModel::innovation(int k, const Eigen::VectorXd& y) const {
  return markerResidual(model_, p0_ + y, observations_.at(static_cast<std::size_t>(k)));
}

Eigen::MatrixXd MarkerPoseModel::jointJacobian(int k, const Eigen::VectorXd& y, Eigen::VectorXd* residual) const {
  const MarkerObservation& o = observations_.at(static_cast<std::size_t>(k));
  Eigen::MatrixXd J_e_p, J_e_q;
  const Eigen::Isometry3d predicted = sim::predictMarkerPose(model_, p0_ + y, o.sample, &J_e_p, &J_e_q);
  if (residual) *residual = residualOf(o, predicted);
  return residualJointJacobian(o, predicted, J_e_q);
}

}  // namespace orbcal::calib
