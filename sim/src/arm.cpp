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

const char* jointTypeName(JointType type) { return type == JointType::kPrismatic ? "prismatic" : "revolute"; }

namespace {
/// True for the URDF convention's prismatic zero offset: slot kTheta of a prismatic joint, a length.
/// (An arm without rows, as error tables make to name their keys, has revolute joints only.)
bool isUrdfSlide(const Arm& arm, int index) {
  const int joint = index / arm.paramsPerJoint();
  return arm.convention == DhConvention::kUrdf && paramKind(arm, index) == kTheta && joint < arm.numJoints() &&
         arm.isPrismatic(joint);
}

/// Name of parameter `index` without the joint number.
const char* paramStem(const Arm& arm, int index) {
  static const char* kDh[] = {"theta", "alpha", "a", "d", "beta"};
  static const char* kUrdfNames[] = {"theta", "x", "y", "z", "roll", "pitch", "yaw"};
  if (isUrdfSlide(arm, index)) return "d";
  const int k = paramKind(arm, index);
  return arm.convention == DhConvention::kUrdf ? kUrdfNames[k] : kDh[k];
}
}  // namespace

int jointParamIndex(const Arm& arm, int joint) {
  const bool dh_slide = arm.isPrismatic(joint) && arm.convention != DhConvention::kUrdf;
  return paramIndex(arm, joint, dh_slide ? kD : kTheta);
}

std::string paramName(const Arm& arm, int index) {
  return paramStem(arm, index) + std::to_string(index / arm.paramsPerJoint() + 1);
}

bool isAngleParam(const Arm& arm, int index) {
  const ParamKind kind = paramKind(arm, index);
  if (arm.convention == DhConvention::kUrdf) return (kind == kTheta && !isUrdfSlide(arm, index)) || kind >= kOroll;
  return kind == kTheta || kind == kAlpha || kind == kBeta;
}

std::string paramKey(const Arm& arm, int index) {
  return std::string(paramStem(arm, index)) + (isAngleParam(arm, index) ? "_deg" : "_mm");
}

const char* jointSiUnit(const Arm& arm, int joint) { return arm.isPrismatic(joint) ? "m" : "rad"; }

const char* jointEdgeUnit(const Arm& arm, int joint) { return arm.isPrismatic(joint) ? "mm" : "deg"; }

double jointEdgeScale(const Arm& arm, int joint) { return arm.isPrismatic(joint) ? 1e3 : kRadToDeg; }

std::string jointEdgeColumn(const Arm& arm, int joint) {
  return "q" + std::to_string(joint + 1) + "_" + jointEdgeUnit(arm, joint);
}

std::string jointValueName(const Arm& arm, int joint) {
  return "joint " + std::to_string(joint + 1) + (arm.isPrismatic(joint) ? " position" : " angle");
}

std::string jointEdgeLabel(const Arm& arm, int joint) {
  return jointValueName(arm, joint) + " (" + jointEdgeUnit(arm, joint) + ")";
}

std::string jointEffortColumn(const Arm& arm, int joint) {
  return "tau" + std::to_string(joint + 1) + (arm.isPrismatic(joint) ? "_N" : "_Nm");
}

std::string jointEffortName(const Arm& arm, int joint) {
  return "joint " + std::to_string(joint + 1) + (arm.isPrismatic(joint) ? " force" : " torque");
}

std::string jointEffortLabel(const Arm& arm, int joint) {
  return jointEffortName(arm, joint) + (arm.isPrismatic(joint) ? " (N)" : " (N m)");
}

std::string formatJointValue(const Arm& arm, int joint, double q) {
  return formatNumber("%.6g", q * jointEdgeScale(arm, joint)) + " " + jointEdgeUnit(arm, joint);
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
    if (arm.isPrismatic(static_cast<int>(j))) {
      if (q[j] >= arm.lower_rad[j] - kMaxLengthM && q[j] <= arm.upper_rad[j] + kMaxLengthM) continue;
      throw std::invalid_argument(std::string(context) + ": joint " + std::to_string(j + 1) + " of " + arm.source + ": " +
                                  formatJointValue(arm, static_cast<int>(j), q[j]) + " is more than 10 km outside its limits [" +
                                  formatJointValue(arm, static_cast<int>(j), arm.lower_rad[j]) + ", " +
                                  formatJointValue(arm, static_cast<int>(j), arm.upper_rad[j]) + "]: no pose of the arm");
    }
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

Eigen::VectorXd parseEdgeJointValues(const Arm& arm, const std::vector<std::string>& words) {
  if (static_cast<int>(words.size()) != arm.numJoints()) {
    throw InputError("joint values: expected " + std::to_string(arm.numJoints()) + " (" + arm.source + " has " +
                     std::to_string(arm.numJoints()) + " joints), got " + std::to_string(words.size()));
  }
  Eigen::VectorXd q(arm.numJoints());
  for (int j = 0; j < arm.numJoints(); ++j) {
    const std::string& w = words[static_cast<std::size_t>(j)];
    char* end = nullptr;
    const double v = std::strtod(w.c_str(), &end);
    if (w.empty() || end != w.c_str() + w.size() || !std::isfinite(v)) {
      throw InputError("joint values: q" + std::to_string(j + 1) + ": expected a finite " +
                       (arm.isPrismatic(j) ? "length in millimetres" : "angle in degrees") + ", got " + quoteInput(w));
    }
    q[j] = v / jointEdgeScale(arm, j);
  }
  return q;
}

Eigen::Isometry3d linkTransform(DhConvention convention, const DhRow& row, double q) {
  const bool prismatic = row.type == JointType::kPrismatic;
  if (convention == DhConvention::kUrdf) {
    Eigen::Isometry3d T = fromXyzRpy(row.xyz_m, row.rpy_rad);
    if (prismatic) {
      T.translate((row.d_m + q) * row.axis);
    } else {
      T.rotate(Eigen::AngleAxisd(row.theta_rad + q, row.axis));
    }
    return T;
  }
  if (prismatic) {
    DhRow fixed = row;  // the same matrix with the variable on d
    fixed.type = JointType::kRevolute;
    fixed.d_m += q;
    return linkTransform(convention, fixed, 0.0);
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
      (arm.isPrismatic(j) ? arm.joints[j].d_m : arm.joints[j].theta_rad) += y[b];
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
  std::vector<Eigen::Isometry3d> frames;
  chainFrames(arm, q, inserts, frames);
  return frames;
}

void chainFrames(const Arm& arm, const Eigen::VectorXd& q, const LinkInserts& inserts, std::vector<Eigen::Isometry3d>& frames) {
  checkJointVector(arm, q, "chainFrames");
  if (!inserts.empty() && static_cast<int>(inserts.size()) != arm.numJoints()) {
    throw std::invalid_argument("chainFrames: expected one insert per link");
  }
  frames.clear();
  frames.reserve(arm.joints.size() + 2);
  frames.push_back(arm.base_T_first);
  for (int j = 0; j < arm.numJoints(); ++j) {
    frames.push_back(frames.back() * linkTransform(arm.convention, arm.joints[j], q[j]));
    if (!inserts.empty()) frames.back() = frames.back() * inserts[static_cast<std::size_t>(j)];
  }
  frames.push_back(frames.back() * arm.last_T_flange);
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
