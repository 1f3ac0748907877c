#include "orbcal/sim/se3.hpp"

#include <Eigen/SVD>

#include <algorithm>
#include <cmath>

namespace orbcal::sim {

Eigen::Matrix3d skew(const Eigen::Vector3d& w) {
  Eigen::Matrix3d S;
  S << 0.0, -w.z(), w.y(), w.z(), 0.0, -w.x(), -w.y(), w.x(), 0.0;
  return S;
}

Eigen::Vector3d logSO3(const Eigen::Matrix3d& R) {
  // Eigen's AngleAxis goes through a quaternion, which is accurate at 0 and at pi alike.
  const Eigen::AngleAxisd aa(Eigen::Quaterniond(R).normalized());
  double angle = aa.angle();
  Eigen::Vector3d axis = aa.axis();
  if (angle > kPi) {  // keep the angle in [0, pi]
    angle = 2.0 * kPi - angle;
    axis = -axis;
  }
  return axis * angle;
}

Eigen::Matrix3d expSO3(const Eigen::Vector3d& w) {
  const double angle = w.norm();
  if (angle < 1e-300) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
}

Vector6d poseMinus(const Eigen::Isometry3d& measured, const Eigen::Isometry3d& nominal) {
  const Eigen::Matrix3d Rt = nominal.linear().transpose();
  Vector6d e;
  e.head<3>() = Rt * (measured.translation() - nominal.translation());
  e.tail<3>() = logSO3(Rt * measured.linear());
  return e;
}

Eigen::Isometry3d posePlus(const Eigen::Isometry3d& nominal, const Vector6d& e) {
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = nominal.linear() * expSO3(e.tail<3>());
  out.translation() = nominal.translation() + nominal.linear() * e.head<3>();
  return out;
}

Vector6d poseToVector(const Eigen::Isometry3d& T) {
  Vector6d v;
  v << T.translation(), logSO3(T.linear());
  return v;
}

Eigen::Isometry3d poseFromVector(const Vector6d& v) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = v.head<3>();
  T.linear() = expSO3(v.tail<3>());
  return T;
}

Matrix6d adjoint(const Eigen::Isometry3d& a_T_b) {
  const Eigen::Matrix3d& R = a_T_b.linear();
  Matrix6d Ad = Matrix6d::Zero();
  Ad.topLeftCorner<3, 3>() = R;
  Ad.topRightCorner<3, 3>() = skew(a_T_b.translation()) * R;
  Ad.bottomRightCorner<3, 3>() = R;
  return Ad;
}

Eigen::Isometry3d fromXyzRpy(const Eigen::Vector3d& xyz_m, const Eigen::Vector3d& rpy_rad) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(rpy_rad.z(), Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(rpy_rad.y(), Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(rpy_rad.x(), Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = xyz_m;
  return T;
}

double rotationAngle(const Eigen::Matrix3d& R) { return logSO3(R).norm(); }

Eigen::Matrix3d projectToSO3(const Eigen::Matrix3d& M) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

}  // namespace orbcal::sim
