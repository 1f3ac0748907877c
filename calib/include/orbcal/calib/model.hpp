#pragma once
// What the estimators see: a measurement model. Every estimator (EKF, LSE, LM) works through this
// interface only, so a new measurement type (distance-and-rotation, laser range) or a model extension
// (joint compliance, encoder scale, ...) plugs in as a new MeasurementModel without touching them.
//
// Convention: for sample k at parameter errors y, linearize() gives the innovation
//   nu_k(y) = z_k ⊖ h_k(y)   (measurement minus prediction),
// its Jacobian H_k = d h_k / d y, so that nu_k(y + dy) ≈ nu_k(y) - H_k dy, and the covariance R_k of nu_k.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "orbcal/sim/arm.hpp"
#include "orbcal/sim/model.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::calib {

struct Linearization {
  Eigen::VectorXd innovation;  ///< nu_k(y)
  Eigen::MatrixXd H;           ///< d h_k / d y  (rows(k) x numParams())
  Eigen::MatrixXd R;           ///< covariance of nu_k (rows(k) x rows(k))
};

class MeasurementModel {
 public:
  virtual ~MeasurementModel() = default;
  virtual int numSamples() const = 0;
  virtual int rows(int k) const = 0;
  /// What every parameter means: name, unit, typical magnitude (sim/model.hpp).
  virtual const sim::ParamLayout& layout() const = 0;
  virtual Linearization linearize(int k, const Eigen::VectorXd& y) const = 0;
  /// The innovation alone (what linearize gives as `innovation`): models override it where the
  /// Jacobian costs more than the prediction (the LM's trial steps need only the residual).
  virtual Eigen::VectorXd innovation(int k, const Eigen::VectorXd& y) const { return linearize(k, y).innovation; }
  /// The innovation and its covariance R (what linearize gives), H possibly left empty: what a cost
  /// needs. Models override it where H costs more than the prediction.
  virtual Linearization innovationAndCovariance(int k, const Eigen::VectorXd& y) const { return linearize(k, y); }

  int numParams() const { return layout().size(); }
  const std::string& paramName(int i) const { return layout().param(i).name; }
};

/// One measured end-effector pose.
struct PoseObservation {
  Eigen::VectorXd q_rad;                 ///< joint readings the model is driven with (commanded or encoder)
  Eigen::Isometry3d base_T_flange;       ///< measured flange pose
  sim::Matrix6d covariance = sim::Matrix6d::Identity();  ///< of the right perturbation [m; rad] in the flange frame
};

/// Where the measurement covariance R_k comes from.
struct PoseNoiseModel {
  enum class Source {
    kObservation,  ///< each observation's own covariance (e.g. the vision covariance)
    kFixed         ///< diag(sigma_position^2 x3, sigma_orientation^2 x3) (Wang et al. 2023: 0.3 mm, 0.5 deg)
  };
  Source source = Source::kObservation;
  double sigma_position_m = 0.3e-3;
  double sigma_orientation_rad = 0.5 * sim::kDegToRad;
  /// Joint control noise (rad) carried into R through the joint Jacobian: R += J_q sigma^2 J_q^T.
  /// Wang et al. 2023's R leaves it out (0); the plant's joints differ from the readings by this much.
  double joint_noise_sigma_rad = 0.0;
};

/// The arm `nominal` with the geometry parameters y of its layout (sim::geometryBlock, its order) folded
/// in (sim::foldParameters of sim::flangeModel): what a geometric calibration's estimate makes of it.
sim::Arm calibratedArm(const sim::Arm& nominal, const Eigen::VectorXd& y);

/// Stacked innovations and Jacobians over all samples at y (for the batch estimators and identifiability).
struct StackedLinearization {
  Eigen::VectorXd innovation;
  Eigen::MatrixXd H;
  std::vector<Eigen::MatrixXd> R;  ///< per sample
};
/// Every sample's linearization at y; std::runtime_error (requireFinite) when one is not finite, so no
/// estimator, SVD or identifiability analysis ever runs on an infinity or a NaN.
StackedLinearization linearizeAll(const MeasurementModel& model, const Eigen::VectorXd& y);
/// Throws std::runtime_error naming sample k (from 0; said from 1) unless its innovation, Jacobian and
/// covariance are finite.
void requireFinite(const Linearization& lin, int k);

}  // namespace orbcal::calib
