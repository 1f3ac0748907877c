#include "orbcal/calib/model.hpp"

#include <stdexcept>

#include "orbcal/sim/jacobian.hpp"

namespace orbcal::calib {

PoseMeasurementModel::PoseMeasurementModel(sim::Arm nominal, std::vector<PoseObservation> observations,
                                           PoseNoiseModel noise)
    : nominal_(std::move(nominal)), observations_(std::move(observations)), noise_(noise) {
  for (const PoseObservation& o : observations_) sim::checkJointVector(nominal_, o.q_rad, "PoseMeasurementModel");
  layout_.add(sim::geometryBlock(nominal_));
}

Linearization PoseMeasurementModel::linearize(int k, const Eigen::VectorXd& y) const {
  const PoseObservation& o = observations_.at(static_cast<std::size_t>(k));
  const sim::Arm arm = sim::withErrors(nominal_, y);
  Linearization lin;
  lin.innovation = sim::poseMinus(o.base_T_flange, sim::forwardKinematics(arm, o.q_rad));
  const sim::Matrix6Xd J = sim::identificationJacobian(arm, o.q_rad, sim::ErrorFrame::kTool);
  lin.H = J;
  if (noise_.source == PoseNoiseModel::Source::kObservation) {
    lin.R = o.covariance;
  } else {
    sim::Vector6d d;
    d << Eigen::Vector3d::Constant(noise_.sigma_position_m * noise_.sigma_position_m),
        Eigen::Vector3d::Constant(noise_.sigma_orientation_rad * noise_.sigma_orientation_rad);
    lin.R = d.asDiagonal();
  }
  if (noise_.joint_noise_sigma_rad > 0.0) {
    // A joint angle and its theta offset are the same motion: J_q = the theta columns of J.
    sim::Matrix6Xd J_e_q(6, nominal_.numJoints());
    for (int j = 0; j < nominal_.numJoints(); ++j) J_e_q.col(j) = J.col(sim::jointParamIndex(nominal_, j));
    lin.R += noise_.joint_noise_sigma_rad * noise_.joint_noise_sigma_rad * J_e_q * J_e_q.transpose();
  }
  return lin;
}

void requireFinite(const Linearization& lin, int k) {
  if (lin.innovation.allFinite() && lin.H.allFinite() && lin.R.allFinite()) return;
  throw std::runtime_error("fit: sample " + std::to_string(k + 1) + " of the fitted samples: its residual, Jacobian or "
                           "covariance is not finite (a measured value far outside what the arm reaches?); nothing was fitted");
}

StackedLinearization linearizeAll(const MeasurementModel& model, const Eigen::VectorXd& y) {
  int total = 0;
  for (int k = 0; k < model.numSamples(); ++k) total += model.rows(k);
  StackedLinearization s;
  s.innovation.resize(total);
  s.H.resize(total, model.numParams());
  s.R.reserve(static_cast<std::size_t>(model.numSamples()));
  for (int k = 0, row = 0; k < model.numSamples(); ++k) {
    Linearization lin = model.linearize(k, y);
    requireFinite(lin, k);
    const int m = model.rows(k);
    s.innovation.segment(row, m) = lin.innovation;
    s.H.middleRows(row, m) = lin.H;
    s.R.push_back(std::move(lin.R));
    row += m;
  }
  return s;
}

}  // namespace orbcal::calib
