#include "orbcal/sim/arm.hpp"

#include <cmath>
#include <stdexcept>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::sim {

const char* conventionName(DhConvention convention) {
  switch (convention) {
    case DhConvention::kModified: return "modified";
    case DhConvention::kStandard: return "standard";
    case DhConvention::kHayati: return "hayati";
    case DhConvention::kUrdf: return "urdf";
  }
  return "?";
}

namespace {
/// Name of per-joint parameter k without the joint number.
const char* paramStem(const Arm& arm, int k) {
  static const char* kDh[] = {"theta", "alpha", "a", "d", "beta"};
  static const char* kUrdfNames[] = {"theta", "x", "y", "z", "roll", "pitch", "yaw"};
  return arm.convention == DhConvention::kUrdf ? kUrdfNames[k] : kDh[k];
}
}  // namespace

std::string paramName(const Arm& arm, int index) {
  return paramStem(arm, paramKind(arm, index)) + std::to_string(index / arm.paramsPerJoint() + 1);
}

bool isAngleParam(const Arm& arm, int index) {
  const ParamKind kind = paramKind(arm, index);
  if (arm.convention == DhConvention::kUrdf) return kind == kTheta || kind >= kOroll;
  return kind == kTheta || kind == kAlpha || kind == kBeta;
}

std::string paramKey(const Arm& arm, int k) {
  return std::string(paramStem(arm, k)) + (isAngleParam(arm, k) ? "_deg" : "_mm");
}

namespace {
void checkVector(const Eigen::VectorXd& v, int expected, const char* what, const char* context) {
  if (v.size() != expected) {
    throw std::invalid_argument(std::string(context) + ": expected " + std::to_string(expected) + " " +
                                what + ", got " + std::to_string(v.size()));
  }
  for (Eigen::Index i = 0; i < v.size(); ++i) {
    if (!std::isfinite(v[i])) {
      throw std::invalid_argument(std::string(context) + ": " + what + "[" + std::to_string(i) +
                                  "] is not a finite number");
    }
  }
}
}  // namespace

void checkJointVector(const Arm& arm, const Eigen::VectorXd& q, const char* context) {
  checkVector(q, arm.numJoints(), "joint angles", context);
  if (arm.lower_rad.size() != q.size() || arm.upper_rad.size() != q.size()) return;  // an arm without limits
  for (Eigen::Index j = 0; j < q.size(); ++j) {
    if (q[j] >= arm.lower_rad[j] - kMaxJointAngleRad && q[j] <= arm.upper_rad[j] + kMaxJointAngleRad) continue;
    throw std::invalid_argument(std::string(context) + ": joint " + std::to_string(j + 1) + " of " + arm.source + ": " +
                                formatNumber("%.9g", q[j]) + " rad (" + formatNumber("%.6g", q[j] * kRadToDeg) +
                                " deg) is more than ten turns outside its limits [" +
                                formatNumber("%.6g", arm.lower_rad[j] * kRadToDeg) + ", " +
                                formatNumber("%.6g", arm.upper_rad[j] * kRadToDeg) + "] deg: no pose of the arm");
  }
}

void checkParamVector(const Arm& arm, const Eigen::VectorXd& y, const char* context) {
  checkVector(y, arm.numParams(), "parameter errors", context);
}

Eigen::Isometry3d linkTransform(DhConvention convention, const DhRow& row, double q) {
  if (convention == DhConvention::kUrdf) {
    Eigen::Isometry3d T = fromXyzRpy(row.xyz_m, row.rpy_rad);
    T.rotate(Eigen::AngleAxisd(row.theta_rad + q, row.axis));
    return T;
  }
  const double th = row.theta_rad + q;
  const double ct = std::cos(th), st = std::sin(th);
  const double ca = std::cos(row.alpha_rad), sa = std::sin(row.alpha_rad);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  Eigen::Matrix4d& M = T.matrix();
  if (convention == DhConvention::kModified) {
    M << ct, -st, 0.0, row.a_m,            //
        st * ca, ct * ca, -sa, -sa * row.d_m,  //
        st * sa, ct * sa, ca, ca * row.d_m,    //
        0.0, 0.0, 0.0, 1.0;
  } else if (convention == DhConvention::kStandard) {
    M << ct, -st * ca, st * sa, row.a_m * ct,  //
        st, ct * ca, -ct * sa, row.a_m * st,   //
        0.0, sa, ca, row.d_m,                  //
        0.0, 0.0, 0.0, 1.0;
  } else {
    // Standard DH times Ry(beta): Liu et al. 2012 eq. 2.
    const double cb = std::cos(row.beta_rad), sb = std::sin(row.beta_rad);
    M << ct * cb - st * sa * sb, -st * ca, ct * sb + st * sa * cb, row.a_m * ct,  //
        st * cb + ct * sa * sb, ct * ca, st * sb - ct * sa * cb, row.a_m * st,    //
        -ca * sb, sa, ca * cb, row.d_m,                                           //
        0.0, 0.0, 0.0, 1.0;
  }
  return T;
}

Arm withErrors(const Arm& nominal, const Eigen::VectorXd& y) {
  Arm out = nominal;
  addErrors(out, y);
  return out;
}

void addErrors(Arm& arm, const Eigen::VectorXd& y) {
  checkParamVector(arm, y, "withErrors");
  for (int j = 0; j < arm.numJoints(); ++j) {
    if (arm.convention == DhConvention::kUrdf) {
      const int b = paramIndex(arm, j, kTheta);
      arm.joints[j].theta_rad += y[b];
      arm.joints[j].xyz_m += y.segment<3>(b + kOx);
      arm.joints[j].rpy_rad += y.segment<3>(b + kOroll);
      continue;
    }
    arm.joints[j].theta_rad += y[paramIndex(arm, j, kTheta)];
    arm.joints[j].alpha_rad += y[paramIndex(arm, j, kAlpha)];
    arm.joints[j].a_m += y[paramIndex(arm, j, kA)];
    arm.joints[j].d_m += y[paramIndex(arm, j, kD)];
    if (arm.convention == DhConvention::kHayati) arm.joints[j].beta_rad += y[paramIndex(arm, j, kBeta)];
  }
}

Eigen::Isometry3d forwardKinematics(const Arm& arm, const Eigen::VectorXd& q) {
  checkJointVector(arm, q, "forwardKinematics");
  Eigen::Isometry3d T = arm.base_T_first;
  for (int j = 0; j < arm.numJoints(); ++j) T = T * linkTransform(arm.convention, arm.joints[j], q[j]);
  return T * arm.last_T_flange;
}

std::vector<Eigen::Isometry3d> chainFrames(const Arm& arm, const Eigen::VectorXd& q) { return chainFrames(arm, q, {}); }

std::vector<Eigen::Isometry3d> chainFrames(const Arm& arm, const Eigen::VectorXd& q, const LinkInserts& inserts) {
  checkJointVector(arm, q, "chainFrames");
  if (!inserts.empty() && static_cast<int>(inserts.size()) != arm.numJoints()) {
    throw std::invalid_argument("chainFrames: expected one insert per link");
  }
  std::vector<Eigen::Isometry3d> frames;
  frames.reserve(arm.joints.size() + 2);
  frames.push_back(arm.base_T_first);
  for (int j = 0; j < arm.numJoints(); ++j) {
    frames.push_back(frames.back() * linkTransform(arm.convention, arm.joints[j], q[j]));
    if (!inserts.empty()) frames.back() = frames.back() * inserts[static_cast<std::size_t>(j)];
  }
  frames.push_back(frames.back() * arm.last_T_flange);
  return frames;
}

Eigen::Isometry3d forwardKinematics(const Arm& arm, const Eigen::VectorXd& q, const LinkInserts& inserts) {
  if (inserts.empty()) return forwardKinematics(arm, q);
  return chainFrames(arm, q, inserts).back();
}

bool withinLimits(const Arm& arm, const Eigen::VectorXd& q) {
  return (q.array() >= arm.lower_rad.array()).all() && (q.array() <= arm.upper_rad.array()).all();
}

double characteristicLength(const Arm& arm) {
  double L = arm.base_T_first.translation().norm() + arm.last_T_flange.translation().norm();
  for (const DhRow& r : arm.joints) L += std::abs(r.a_m) + std::abs(r.d_m) + r.xyz_m.norm();
  return L;
}

}  // namespace orbcal::sim
