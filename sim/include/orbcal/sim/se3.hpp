#pragma once
// Small rigid-motion helpers shared by every library. Twists and pose errors are 6-vectors
// ordered [translation; rotation] = [dx dy dz; δx δy δz], as in Wang et al. 2023 eq. (8).
#include <Eigen/Geometry>

namespace orbcal::sim {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

/// Skew-symmetric matrix S(w) with S(w) v = w x v.
Eigen::Matrix3d skew(const Eigen::Vector3d& w);

/// Rotation vector (axis * angle, rad) of R; exact for angles up to and near pi.
Eigen::Vector3d logSO3(const Eigen::Matrix3d& R);
/// Rotation matrix of the rotation vector w (rad).
Eigen::Matrix3d expSO3(const Eigen::Vector3d& w);

/// Pose error of `measured` against `nominal`, expressed in the nominal frame (Wang et al. 2023 eq. 13):
/// [R_nom^T (p_meas - p_nom); log(R_nom^T R_meas)]. To first order it equals the
/// differential motion [d; δ] with measured = nominal * (I + [[S(δ), d], [0, 0]]).
Vector6d poseMinus(const Eigen::Isometry3d& measured, const Eigen::Isometry3d& nominal);
/// Inverse of poseMinus: nominal * (exp(S(e.tail)), e.head).
Eigen::Isometry3d posePlus(const Eigen::Isometry3d& nominal, const Vector6d& e);

/// T as the 6-vector the tables store: [translation (m); rotation vector logSO3(R) (rad)].
Vector6d poseToVector(const Eigen::Isometry3d& T);
/// Inverse of poseToVector: translation v.head, rotation expSO3(v.tail).
Eigen::Isometry3d poseFromVector(const Vector6d& v);

/// Adjoint of a_T_b: maps a twist [v; w] expressed in frame b to the same twist expressed in a.
Matrix6d adjoint(const Eigen::Isometry3d& a_T_b);

/// Rigid transform from a translation (m) and roll-pitch-yaw angles (rad), R = Rz(yaw) Ry(pitch) Rx(roll).
Eigen::Isometry3d fromXyzRpy(const Eigen::Vector3d& xyz_m, const Eigen::Vector3d& rpy_rad);

/// The rotation nearest to M in the Frobenius norm (SVD; reflections excluded).
Eigen::Matrix3d projectToSO3(const Eigen::Matrix3d& M);

/// Rotation angle (rad, in [0, pi]) of R.
double rotationAngle(const Eigen::Matrix3d& R);

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;
constexpr double kRadToDeg = 180.0 / kPi;

}  // namespace orbcal::sim
