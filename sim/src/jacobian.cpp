#include "orbcal/sim/jacobian.hpp"

#include <cmath>
#include <stdexcept>

#include "orbcal/sim/se3.hpp"

namespace orbcal::sim {

namespace {
/// Twist [v; w] in the base frame of a rotation about unit axis w through point o.
Vector6d rotationTwist(const Eigen::Vector3d& w, const Eigen::Vector3d& o) {
  Vector6d xi;
  xi << o.cross(w), w;
  return xi;
}
Vector6d translationTwist(const Eigen::Vector3d& v) {
  Vector6d xi;
  xi << v, Eigen::Vector3d::Zero();
  return xi;
}
}  // namespace

void identificationJacobian(const Arm& arm, const Eigen::VectorXd& q, ErrorFrame frame,
                            Eigen::Ref<Matrix6Xd> J_e_y) {
  identificationJacobian(arm, q, frame, J_e_y, {});
}

void identificationJacobian(const Arm& arm, const Eigen::VectorXd& q, ErrorFrame frame,
                            Eigen::Ref<Matrix6Xd> J_e_y, const LinkInserts& inserts) {
  identificationJacobian(arm, q, frame, J_e_y, inserts, chainFrames(arm, q, inserts));
}

void identificationJacobian(const Arm& arm, const Eigen::VectorXd& q, ErrorFrame frame, Eigen::Ref<Matrix6Xd> J_e_y,
                            const LinkInserts& inserts, const std::vector<Eigen::Isometry3d>& frames) {
  if (J_e_y.cols() != arm.numParams()) {
    throw std::invalid_argument("identificationJacobian: expected " + std::to_string(arm.numParams()) +
                                " columns, got " + std::to_string(J_e_y.cols()));
  }
  if (frames.size() != arm.joints.size() + 2) {
    throw std::invalid_argument("identificationJacobian: expected " + std::to_string(arm.joints.size() + 2) + " frames, got " +
                                std::to_string(frames.size()));
  }
  const Eigen::Isometry3d& base_T_flange = frames.back();
  const Eigen::Vector3d p_f = base_T_flange.translation();
  const Eigen::Matrix3d Rt = base_T_flange.linear().transpose();
  const bool modified = arm.convention == DhConvention::kModified;
  const bool hayati = arm.convention == DhConvention::kHayati;
  const int per_joint = arm.paramsPerJoint();

  for (int j = 0; j < arm.numJoints(); ++j) {
    const Eigen::Isometry3d& prev = frames[j];      // base_T_{j-1} (its link's insert included)
    // base_T_{j} before link j's insert: the frame its parameters act in.
    const Eigen::Isometry3d cur = inserts.empty() ? frames[j + 1] : frames[j + 1] * inserts[static_cast<std::size_t>(j)].inverse();
    const Eigen::Isometry3d& z_frame = modified ? cur : prev;  // frame whose z carries theta and d
    const Eigen::Isometry3d& x_frame = modified ? prev : cur;  // frame whose x carries alpha and a
    Vector6d xi[7];
    if (arm.convention == DhConvention::kUrdf) {
      // {j-1}_T_{j} = T(xyz) Rz(yaw) Ry(pitch) Rx(roll) Rot(axis, theta + q). Every origin parameter
      // moves frame j about or along an axis through o, the origin's position: x, y, z along frame
      // j-1's axes; yaw about z_{j-1}; pitch about Rz(yaw) y; roll about the x axis of the origin
      // frame; theta about the joint axis (the same in the origin frame and in frame j).
      const DhRow& r = arm.joints[j];
      const Eigen::Matrix3d& Rp = prev.linear();
      const Eigen::Vector3d o = prev * r.xyz_m;
      const Eigen::Matrix3d R_yaw = Rp * Eigen::AngleAxisd(r.rpy_rad.z(), Eigen::Vector3d::UnitZ()).toRotationMatrix();
      // A prismatic joint slides frame j along the axis instead ({j-1}_T_{j} ends in Trans(axis (d + q))):
      // its offset column is that translation, and the origin frame keeps frame j's orientation.
      const bool slide = r.type == JointType::kPrismatic;
      const Eigen::Matrix3d R_origin =
          slide ? cur.linear() : Eigen::Matrix3d(cur.linear() * Eigen::AngleAxisd(-(r.theta_rad + q[j]), r.axis).toRotationMatrix());
      xi[kTheta] = slide ? translationTwist(cur.linear() * r.axis) : rotationTwist(cur.linear() * r.axis, o);
      for (int a = 0; a < 3; ++a) xi[kOx + a] = translationTwist(Rp.col(a));
      xi[kOyaw] = rotationTwist(Rp.col(2), o);
      xi[kOpitch] = rotationTwist(R_yaw.col(1), o);
      xi[kOroll] = rotationTwist(R_origin.col(0), o);
    } else {
      xi[kTheta] = rotationTwist(z_frame.linear().col(2), z_frame.translation());
      xi[kD] = translationTwist(z_frame.linear().col(2));
      if (!hayati) {
        xi[kAlpha] = rotationTwist(x_frame.linear().col(0), x_frame.translation());
        xi[kA] = translationTwist(x_frame.linear().col(0));
      } else {
        // Frame j = (frame after Rx(alpha)) Ry(beta): alpha and a act along the x axis before Ry(beta),
        // x = Ry(-beta) x_j = cos(beta) x_j + sin(beta) z_j. Perturbing beta turns everything downstream
        // about y_j (Ry leaves y unchanged) through the origin of frame j.
        const double beta = arm.joints[j].beta_rad;
        const Eigen::Vector3d x = std::cos(beta) * cur.linear().col(0) + std::sin(beta) * cur.linear().col(2);
        xi[kAlpha] = rotationTwist(x, cur.translation());
        xi[kA] = translationTwist(x);
        xi[kBeta] = rotationTwist(cur.linear().col(1), cur.translation());
      }
    }
    for (int k = 0; k < per_joint; ++k) {
      // Motion of the flange origin and rotation, both in the base frame.
      const Eigen::Vector3d w = xi[k].tail<3>();
      const Eigen::Vector3d dp = xi[k].head<3>() + w.cross(p_f);
      auto col = J_e_y.col(paramIndex(arm, j, static_cast<ParamKind>(k)));
      if (frame == ErrorFrame::kTool) {
        col.head<3>() = Rt * dp;
        col.tail<3>() = Rt * w;
      } else {
        col.head<3>() = dp;
        col.tail<3>() = w;
      }
    }
  }
}

Matrix6Xd identificationJacobian(const Arm& arm, const Eigen::VectorXd& q, ErrorFrame frame) {
  Matrix6Xd J(6, arm.numParams());
  identificationJacobian(arm, q, frame, J);
  return J;
}

Matrix6Xd manipulatorJacobian(const Arm& arm, const Eigen::VectorXd& q) {
  // A joint's motion is the motion of its zero offset (theta, or d for a prismatic joint).
  const Matrix6Xd J = identificationJacobian(arm, q, ErrorFrame::kBase);
  Matrix6Xd J_twist_q(6, arm.numJoints());
  for (int j = 0; j < arm.numJoints(); ++j) J_twist_q.col(j) = J.col(jointParamIndex(arm, j));
  return J_twist_q;
}

Matrix6Xd scaledManipulatorJacobian(const Arm& arm, const Eigen::VectorXd& q, double L) {
  Matrix6Xd J = manipulatorJacobian(arm, q);
  for (int j = 0; j < arm.numJoints(); ++j) {
    const double unit = arm.isPrismatic(j) ? L : 1.0;  // the variable's step that compares with a radian
    J.col(j).head<3>() *= unit / L;
    J.col(j).tail<3>() *= unit;
  }
  return J;
}

Matrix6Xd numericIdentificationJacobian(const Arm& arm, const Eigen::VectorXd& q, ErrorFrame frame,
                                        double step) {
  const Eigen::Isometry3d nominal = forwardKinematics(arm, q);
  Matrix6Xd J(6, arm.numParams());
  for (int c = 0; c < arm.numParams(); ++c) {
    Eigen::VectorXd dy = Eigen::VectorXd::Zero(arm.numParams());
    dy[c] = step;
    const Eigen::Isometry3d plus = forwardKinematics(withErrors(arm, dy), q);
    const Eigen::Isometry3d minus = forwardKinematics(withErrors(arm, -dy), q);
    Vector6d e_plus, e_minus;
    if (frame == ErrorFrame::kTool) {
      e_plus = poseMinus(plus, nominal);
      e_minus = poseMinus(minus, nominal);
    } else {
      e_plus << plus.translation() - nominal.translation(), logSO3(plus.linear() * nominal.linear().transpose());
      e_minus << minus.translation() - nominal.translation(), logSO3(minus.linear() * nominal.linear().transpose());
    }
    J.col(c) = (e_plus - e_minus) / (2.0 * step);
  }
  return J;
}

}  // namespace orbcal::sim
