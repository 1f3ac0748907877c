#pragma once
// The identification model of Wang et al. 2023 (eqs. 5-9): the first-order map from the parameter errors y
// (arm.hpp's layout) to the end-effector pose error e = [d; δ] = poseMinus(FK(p + y), FK(p)).
//
// Each parameter perturbs one DH row by an exact rigid motion (a screw) along or about an axis of
// frame i-1 or i; its twist in the base frame is [o x w + v; w] for an axis w through point o, or a
// pure translation v. Mapped to the flange it gives the column of J: J_tool = Ad(flange_T_base) xi,
// the paper's F^E G_i. Hayati's beta_i turns frame i about its own y axis through its origin; there
// alpha_i and a_i act along the x axis before Ry(beta_i). In the URDF convention every origin parameter
// moves frame i about or along an axis through the origin's position (jacobian.cpp). Checked against central differences in
// tests/sim/test_jacobian.cpp.
#include <Eigen/Core>
#include <vector>

#include "orbcal/sim/arm.hpp"

namespace orbcal::sim {

using Matrix6Xd = Eigen::Matrix<double, 6, Eigen::Dynamic>;

/// Frame in which the pose error e is expressed.
enum class ErrorFrame {
  kTool,  ///< the flange (tool) frame, Wang et al. 2023's Σ_E: e = poseMinus(measured, nominal)
  kBase   ///< the base frame: [p_meas - p_nom; log(R_meas R_nom^T)]
};

/// J_e_y (6 x arm.numParams()) at joint angles q, for the arm's current parameters.
Matrix6Xd identificationJacobian(const Arm& arm, const Eigen::VectorXd& q,
                                 ErrorFrame frame = ErrorFrame::kTool);
/// Same, written into caller-owned storage of size 6 x arm.numParams() (no allocation for the result).
void identificationJacobian(const Arm& arm, const Eigen::VectorXd& q, ErrorFrame frame,
                            Eigen::Ref<Matrix6Xd> J_e_y);
/// Same, for the chain with link inserts (arm.hpp's LinkInserts; empty: none): every parameter of
/// link j acts on the chain before X_j, and X_j moves with it.
void identificationJacobian(const Arm& arm, const Eigen::VectorXd& q, ErrorFrame frame,
                            Eigen::Ref<Matrix6Xd> J_e_y, const LinkInserts& inserts);
/// Same, from the chain's frames at q the caller already has (chainFrames(arm, q, inserts)).
void identificationJacobian(const Arm& arm, const Eigen::VectorXd& q, ErrorFrame frame, Eigen::Ref<Matrix6Xd> J_e_y,
                            const LinkInserts& inserts, const std::vector<Eigen::Isometry3d>& frames);

/// Geometric manipulator Jacobian J_twist_q (6 x n) in the base frame: [v of the flange origin; w].
Matrix6Xd manipulatorJacobian(const Arm& arm, const Eigen::VectorXd& q);
/// The same with comparable columns for length L (characteristicLength): [v / L; w] of a revolute joint
/// (per rad), [v; w L] of a prismatic one (per L of travel: v is a unit vector, w zero), so that the
/// singular values and Newton steps of IK weigh both kinds alike.
Matrix6Xd scaledManipulatorJacobian(const Arm& arm, const Eigen::VectorXd& q, double L);

/// J_e_y by central differences of poseMinus (the oracle the analytic Jacobian is tested against).
Matrix6Xd numericIdentificationJacobian(const Arm& arm, const Eigen::VectorXd& q, ErrorFrame frame,
                                        double step);

}  // namespace orbcal::sim
