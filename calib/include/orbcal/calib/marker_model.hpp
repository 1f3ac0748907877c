#pragma once
// The measurement model of measured data: the pose (or the position) of a marker on the flange in the
// measuring system's frame, predicted by a sim::KinematicModel (geometry + registration + effects).
//
//   nu_k(y) = z_k ⊖ h_k(p0 + y):  full poses: poseMinus(measured, predicted), in the marker frame
//                                 positions:  p_measured - p_predicted, in the measuring system's frame
//   H_k = d h_k / d y, so that nu_k(y + dy) ≈ nu_k(y) - H_k dy (model.hpp's convention).
//
// y is the change from p0 (the starting parameters; zero for a fresh model), so every estimator starts
// from y = 0 as it does for Wang et al. 2023's model.
#include <vector>

#include "orbcal/calib/model.hpp"
#include "orbcal/sim/model.hpp"

namespace orbcal::calib {

struct MarkerObservation {
  sim::JointSample sample;
  Eigen::Isometry3d world_T_marker = Eigen::Isometry3d::Identity();
  bool has_rotation = true;
  /// Covariance of the right perturbation of world_T_marker in the marker frame [m; rad] (e.g. from
  /// vision); empty: MarkerNoise's sigmas.
  Eigen::MatrixXd covariance;
  int point = -1;  ///< rigid-body data: the marker point (from 0) whose position this is (sim/marker_points.hpp); -1: the marker
};

/// True when some observation carries its own covariance (image datasets): the noise is then not one
/// set of sigmas to estimate.
inline bool anyOwnCovariance(const std::vector<MarkerObservation>& obs) {
  for (const MarkerObservation& o : obs) {
    if (o.covariance.size() > 0) return true;
  }
  return false;
}

struct MarkerNoise {
  double sigma_position_m = 0.1e-3;                     ///< per axis
  double sigma_rotation_rad = 0.01 * sim::kDegToRad;   ///< per axis
  double joint_noise_sigma_rad = 0.0;                   ///< carried into R through the joint Jacobian
};

class MarkerPoseModel : public MeasurementModel {
 public:
  MarkerPoseModel(sim::KinematicModel model, std::vector<MarkerObservation> observations, MarkerNoise noise,
                  Eigen::VectorXd p0 = {});
  int numSamples() const override { return static_cast<int>(observations_.size()); }
  int rows(int k) const override { return observations_[static_cast<std::size_t>(k)].has_rotation ? 6 : 3; }
  const sim::ParamLayout& layout() const override { return model_.layout; }
  Linearization linearize(int k, const Eigen::VectorXd& y) const override;
  Eigen::VectorXd innovation(int k, const Eigen::VectorXd& y) const override;
  Linearization innovationAndCovariance(int k, const Eigen::VectorXd& y) const override;
  /// d(residual k)/d(joint readings) at y (rows(k) x joints): how joint noise enters the residual,
  /// R_k's term joint_noise_sigma^2 Jq Jq^T. `residual` and `H` (if given) get the residual at y and
  /// linearize()'s H, from the same pose prediction.
  Eigen::MatrixXd jointJacobian(int k, const Eigen::VectorXd& y, Eigen::VectorXd* residual = nullptr,
                                Eigen::MatrixXd* H = nullptr) const;

  const sim::KinematicModel& model() const { return model_; }
  const std::vector<MarkerObservation>& observations() const { return observations_; }
  const Eigen::VectorXd& p0() const { return p0_; }
  const MarkerNoise& noise() const { return noise_; }

 private:
  /// linearize (with H) or innovationAndCovariance (without): one prediction per sample.
  Linearization linearized(int k, const Eigen::VectorXd& y, bool with_H) const;

  sim::KinematicModel model_;
  std::vector<MarkerObservation> observations_;
  MarkerNoise noise_;
  Eigen::VectorXd p0_;
};

/// The flange-pose measurement of Wang et al. (2023, eq. 13) as a marker model whose frames are known: the
/// flange pose in the base frame (sim::flangeModel: world = base, marker = flange), geometry only, so
/// nu_k = poseMinus(measured base_T_flange, FK(nominal + y, q_k)) in the flange frame. R_k: each
/// observation's covariance (noise.source kObservation) or noise's fixed sigmas, plus the joint noise
/// through the joint Jacobian.
MarkerPoseModel poseModel(const sim::Arm& nominal, const std::vector<PoseObservation>& observations, const PoseNoiseModel& noise);

/// Residual of one observation at parameters p (not y): [position (m); rotation (rad)] as the model
/// defines nu (the rotation part empty for position-only observations).
Eigen::VectorXd markerResidual(const sim::KinematicModel& model, const Eigen::VectorXd& p, const MarkerObservation& o);
/// markerResidual of each observation, in their order (the two halves side by side).
std::vector<Eigen::VectorXd> markerResiduals(const sim::KinematicModel& model, const Eigen::VectorXd& p,
                                             const std::vector<MarkerObservation>& obs);

}  // namespace orbcal::calib
