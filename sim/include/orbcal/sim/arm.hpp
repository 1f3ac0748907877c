#pragma once
// A serial arm of revolute and prismatic joints described by a DH table (Craig's modified, standard, or Hayati's
// parallel-axis DH), with fixed base and tool transforms, and the additive parameter errors that
// calibration identifies.
//
// Modified DH (Craig; Wang et al. 2023 eq. 1): row i holds (a_{i-1}, alpha_{i-1}, d_i, theta_i) and
//   {i-1}_T_{i} = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i + q_i) Tz(d_i).
// Standard DH: row i holds (a_i, alpha_i, d_i, theta_i) and
//   {i-1}_T_{i} = Rz(theta_i + q_i) Tz(d_i) Tx(a_i) Rx(alpha_i).
// Hayati (Jia et al. 2019; Liu et al. 2012 eq. 2): standard DH post-multiplied by Ry(beta_i), row i holds
// (a_i, alpha_i, d_i, theta_i, beta_i) and
//   {i-1}_T_{i} = Rz(theta_i + q_i) Tz(d_i) Tx(a_i) Rx(alpha_i) Ry(beta_i),   nominal beta_i = 0.
// URDF (a chain read from a URDF file, sim/urdf.hpp): joint i has a fixed origin (xyz, rpy) in its
// parent link and a unit axis, and
//   {i-1}_T_{i} = T(xyz_i) Rz(yaw_i) Ry(pitch_i) Rx(roll_i) Rot(axis_i, theta_i + q_i),
// with the URDF's R = Rz(yaw) Ry(pitch) Rx(roll); theta_i is a zero offset (nominal 0) that calibration
// adds. Row i holds (xyz_m, rpy_rad, axis, theta_rad); a, alpha, d and beta are unused.
// A prismatic joint's variable q_i is a length (m): in the DH conventions it adds to d_i instead of theta_i
// (theta_i is then a fixed angle and d_i the joint's zero offset); in the URDF convention
// Rot(axis_i, theta_i + q_i) becomes Trans(axis_i (d_i + q_i)), with d_i the zero offset (nominal 0).
// base_T_flange = base_T_first * prod_i {i-1}_T_{i} * last_T_flange (Wang et al. 2023: row 0, rows 1..7, row E).
#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace orbcal::sim {

enum class DhConvention { kModified, kStandard, kHayati, kUrdf };

/// What a joint's variable moves: a rotation (rad) or a translation (m) along the joint axis.
enum class JointType { kRevolute, kPrismatic };

/// "modified", "standard", "hayati" or "urdf": the robot file's `convention:` value.
const char* conventionName(DhConvention convention);

/// One DH row. Lengths in m, angles in rad; for a revolute joint theta_rad is the home offset, for a
/// prismatic one d_m (in the URDF convention too, where d_m is otherwise unused). beta_rad is used by
/// the Hayati convention only (and is 0 in the others).
struct DhRow {
  double a_m = 0.0;
  double alpha_rad = 0.0;
  double d_m = 0.0;
  double theta_rad = 0.0;
  double beta_rad = 0.0;
  JointType type = JointType::kRevolute;
  // The URDF convention only: the joint's origin in its parent link, and its unit axis.
  Eigen::Vector3d xyz_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d rpy_rad = Eigen::Vector3d::Zero();  ///< roll, pitch, yaw: R = Rz(yaw) Ry(pitch) Rx(roll)
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
};

/// Where a URDF-convention arm came from, to write the calibrated origins back (sim/urdf.hpp).
struct UrdfSource {
  std::string file;       ///< the URDF file (for a robot YAML: as written in it, relative to the YAML's folder)
  std::string base_link;  ///< the chain runs from this link ...
  std::string tip_link;   ///< ... to this one (the flange)
  std::vector<std::string> joint_names;  ///< the chain's movable joints, one per DhRow
  /// Per movable joint: the fixed joints just before it folded into its origin (parent side), so
  /// that the joint's own URDF origin is fixed_before^-1 * T(xyz) R(rpy).
  std::vector<Eigen::Isometry3d> fixed_before;
  /// The links the chain's joints move that have no <inertial> (gravity torques need their masses).
  std::vector<std::string> links_without_inertial;
  bool empty() const { return file.empty(); }
};

/// One link's mass properties: the body that moves with joint j (frame j of the DH chain).
struct LinkMass {
  double mass_kg = 0.0;
  Eigen::Vector3d com_m = Eigen::Vector3d::Zero();  ///< centre of mass in the link's own DH frame
};

/// Masses for static gravity torques (sim/gravity.hpp); optional in the robot file.
struct MassModel {
  std::vector<LinkMass> links;  ///< one per joint; empty: no mass model
  Eigen::Vector3d gravity_base = Eigen::Vector3d(0.0, 0.0, -9.80665);  ///< m/s^2, base frame
  double payload_kg = 0.0;                                           ///< at the flange
  Eigen::Vector3d payload_com_flange_m = Eigen::Vector3d::Zero();     ///< in the flange frame
  bool empty() const { return links.empty() && payload_kg == 0.0; }
};

struct Arm {
  std::string name;
  std::string source;  ///< file the arm was loaded from (for messages)
  DhConvention convention = DhConvention::kModified;
  Eigen::Isometry3d base_T_first = Eigen::Isometry3d::Identity();  ///< fixed, not identified
  std::vector<DhRow> joints;                                        ///< one row per joint
  Eigen::Isometry3d last_T_flange = Eigen::Isometry3d::Identity();  ///< fixed, not identified
  /// Joint limits, one per joint, in SI units: rad for a revolute joint, m for a prismatic one (as
  /// every joint vector q: the names say rad for the common case).
  Eigen::VectorXd lower_rad;
  Eigen::VectorXd upper_rad;
  MassModel masses;           ///< optional; empty when the robot file has no `masses:` section
  UrdfSource urdf;            ///< the URDF convention: the file and links the chain was read from

  int numJoints() const { return static_cast<int>(joints.size()); }
  bool isPrismatic(int j) const { return joints[static_cast<std::size_t>(j)].type == JointType::kPrismatic; }
  bool hasPrismatic() const {
    for (const DhRow& r : joints) {
      if (r.type == JointType::kPrismatic) return true;
    }
    return false;
  }
  /// Identified parameters per joint: 7 for the URDF convention (origin xyz and rpy, zero offset), 5
  /// for Hayati (with beta), 4 for the others.
  int paramsPerJoint() const {
    return convention == DhConvention::kUrdf ? 7 : convention == DhConvention::kHayati ? 5 : 4;
  }
  int numParams() const { return paramsPerJoint() * numJoints(); }
};

/// Parameter-error layout, joint by joint, in Wang et al. 2023's y_i order: y_i = [dtheta_i, dalpha_i, da_i, dd_i]
/// (for modified DH, alpha and a are those of row i, i.e. alpha_{i-1} and a_{i-1}), followed by
/// dbeta_i for the Hayati convention: arm.paramsPerJoint() entries per joint. SI units.
/// The URDF convention's 7 per joint: y_i = [dtheta_i, dx_i, dy_i, dz_i, droll_i, dpitch_i, dyaw_i]
/// (the zero offset, then the origin's xyz and rpy): kOx.. share values with the DH kinds, so a DH
/// kind is meaningful only for a DH arm and a kO* kind only for a URDF arm.
enum ParamKind {
  kTheta = 0, kAlpha = 1, kA = 2, kD = 3, kBeta = 4,
  kOx = 1, kOy = 2, kOz = 3, kOroll = 4, kOpitch = 5, kOyaw = 6
};
inline int paramIndex(const Arm& arm, int joint, ParamKind kind) { return arm.paramsPerJoint() * joint + kind; }
inline ParamKind paramKind(const Arm& arm, int index) { return static_cast<ParamKind>(index % arm.paramsPerJoint()); }
/// Index of the parameter joint j's variable moves along (its zero offset): theta_j for a revolute
/// joint and for the URDF convention (where a prismatic joint's slot kTheta holds its offset along the
/// axis, in m), d_j for a prismatic joint of a DH convention. Its Jacobian column is the joint's.
int jointParamIndex(const Arm& arm, int joint);
/// "theta1", "alpha1", "a1", "d1", ("beta1",) ... (joints numbered from 1, as in the DH table);
/// for the URDF convention "theta1", "x1", "y1", "z1", "roll1", "pitch1", "yaw1" (a prismatic joint's
/// zero offset "d1" in place of "theta1").
std::string paramName(const Arm& arm, int index);
/// Unit of parameter `index` as printed at the edges: true for angles (deg), false for lengths (mm).
bool isAngleParam(const Arm& arm, int index);

/// Throws std::invalid_argument("<context>: expected N joint angles, got M"), on a NaN/inf angle, and
/// on an angle more than ten turns (kMaxJointAngleRad) outside its joint's limits, a prismatic joint's
/// value more than kMaxLengthM: no pose of any arm (a reading beyond the limits by joint noise, or an
/// IK step past them, stays far inside that margin).
void checkJointVector(const Arm& arm, const Eigen::VectorXd& q, const char* context);
/// Same for a parameter-error vector of arm.numParams() entries.
void checkParamVector(const Arm& arm, const Eigen::VectorXd& y, const char* context);

/// The key of parameter `index` in error tables (true_errors, error-set files): its name without
/// the joint number and its edge unit, e.g. "theta_deg", "a_mm", "x_mm" (index < paramsPerJoint():
/// the first joint's, which is every revolute joint's).
std::string paramKey(const Arm& arm, int index);

/// "revolute" or "prismatic": the robot file's `type:` value.
const char* jointTypeName(JointType type);
/// A joint value q (SI) as people read it: "12.5 deg" for a revolute joint, "120 mm" for a prismatic one.
std::string formatJointValue(const Arm& arm, int joint, double q);
/// SI unit of joint j's value, as the code holds it: "rad" (revolute) or "m" (prismatic).
const char* jointSiUnit(const Arm& arm, int joint);
/// Edge unit of joint j's value: "deg" (revolute) or "mm" (prismatic), and its scale from SI.
const char* jointEdgeUnit(const Arm& arm, int joint);
double jointEdgeScale(const Arm& arm, int joint);
/// Joint j's value as a column of the tables people read (residuals.csv): "q2_deg" for a revolute
/// joint, "q1_mm" for a prismatic one (joints from 1 in the name), holding q * jointEdgeScale.
std::string jointEdgeColumn(const Arm& arm, int joint);
/// Its name, "joint 2 angle" or "joint 1 position", and axis label, "joint 2 angle (deg)" or "joint 1 position (mm)".
std::string jointValueName(const Arm& arm, int joint);
std::string jointEdgeLabel(const Arm& arm, int joint);
/// Joint j's actuator effort (a sample's tau_Nm entry, SI): a torque for a revolute joint, a force for a
/// prismatic one. Column "tau2_Nm" or "tau1_N", name "joint 2 torque" or "joint 1 force", label
/// "joint 2 torque (N m)" or "joint 1 force (N)".
std::string jointEffortColumn(const Arm& arm, int joint);
std::string jointEffortName(const Arm& arm, int joint);
std::string jointEffortLabel(const Arm& arm, int joint);
/// Joint values as people type them (deg for a revolute joint, mm for a prismatic one), in SI. Throws
/// InputError "joint values: ..." for a wrong count or a word that is not a finite number.
Eigen::VectorXd parseEdgeJointValues(const Arm& arm, const std::vector<std::string>& words);

/// Rigid transform of one DH row at joint value q (rad for a revolute joint, m for a prismatic one).
Eigen::Isometry3d linkTransform(DhConvention convention, const DhRow& row, double q);

/// The arm with parameter errors y added to its DH rows (theta, alpha, a, d, and beta for Hayati; theta,
/// xyz and rpy for the URDF convention).
Arm withErrors(const Arm& nominal, const Eigen::VectorXd& y);
/// The same in place: y added to `arm`'s rows (what withErrors does to its copy).
void addErrors(Arm& arm, const Eigen::VectorXd& y);

/// base_T_flange at joint values q (rad, or m for a prismatic joint).
Eigen::Isometry3d forwardKinematics(const Arm& arm, const Eigen::VectorXd& q);

/// Every frame along the chain: frames[0] = base_T_first, frames[i] = base_T_{joint i}, and
/// frames[n + 1] = base_T_flange.
std::vector<Eigen::Isometry3d> chainFrames(const Arm& arm, const Eigen::VectorXd& q);

/// Rigid motions inserted in the chain, one per link (or none): X_j is right-multiplied onto link j's
/// transform, so frame j+1 (0-based j) becomes base_T_j linkTransform(j) X_j: a link that bends, say.
using LinkInserts = std::vector<Eigen::Isometry3d>;
/// forwardKinematics and chainFrames with inserts (empty `inserts`: the plain chain).
Eigen::Isometry3d forwardKinematics(const Arm& arm, const Eigen::VectorXd& q, const LinkInserts& inserts);
std::vector<Eigen::Isometry3d> chainFrames(const Arm& arm, const Eigen::VectorXd& q, const LinkInserts& inserts);
/// The same into `frames` (its storage reused: a fit's every sample at every iteration).
void chainFrames(const Arm& arm, const Eigen::VectorXd& q, const LinkInserts& inserts, std::vector<Eigen::Isometry3d>& frames);

bool withinLimits(const Arm& arm, const Eigen::VectorXd& q);

/// Characteristic length of the arm (m): sum of |a| and |d| over all rows and the fixed transforms.
/// Scales translational rows so that they are comparable with rotational ones.
double characteristicLength(const Arm& arm);

}  // namespace orbcal::sim
