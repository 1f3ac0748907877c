#pragma once
// Measured data as users have it: CSV files from a laser tracker or motion-capture system (joint
// readings, the measured pose of a marker on the flange in the measuring system's own frame, and
// covariates such as joint torques, temperature and time), described by a small YAML file beside
// them that says what each column is. No column is renamed or converted by hand.
//
//   format: orbcal-measurements-1
//   robot: iiwa7.yaml                      # relative to this file or absolute, or builtin:NAME; a URDF's
//                                          # chain: {file: arm.urdf, base_link: L, tip_link: T} (each optional:
//                                          # the root link, the only leaf link)
//   files: [run1_0kg.csv, run2_1.25kg.csv] # relative to this file or absolute; a file = a session
//   joints: {columns: [theta_1, ..., theta_7], unit: rad}       # or deg; one name per joint of the robot
//   pose:                                  # one of:
//     matrix: [m_00, ..., m_33]            #   16 names, row-major homogeneous 4x4
//     # position: [x, y, z]                #   3 names, with
//     # quaternion_wxyz: [qw, qx, qy, qz]  #   optionally 4 names (without: position-only data)
//     # points: [[x1, y1, z1], [x2, y2, z2], ...]  #   a rigid body: 3 names per marker point, each a
//                                          #   point fixed on the tool with its own unknown offset;
//                                          #   a point's cells may be empty in a row (not seen), not all
//                                          #   of a row's (needs registration: {base: shared|known, marker: shared})
//     length_unit: mm                      #   m or mm
//   covariates:                            # optional, by physical role
//     torque: {columns: [tau_1, ..., tau_7], unit: N*m}   # or Nm; sense: actuator (default) or load, below
//     temperature: {column: temp_C, unit: degC}           # or K
//     time: {column: time_s, unit: s}                     # or ms, min, h
//     direction: {columns: [dir_1, ..., dir_7]}   # approach direction per joint (+1/-1/0)
//   registration: {base: shared, marker: per_session}   # shared | per_session | known
//   world_T_base: {xyz_m: [x, y, z], rpy_deg: [r, p, y]}  # exactly when base: known
//   flange_T_marker: {xyz_m: [...], rpy_deg: [...]}       # exactly when marker: known
//   noise: {position_mm: 0.05, rotation_deg: 0.01, joint_deg: 0.01}  # optional, each key too; the
//                                          # tracker's sigmas per axis and the joint readings' (vs the true
//                                          # angles, 0: exact); absent ones are estimated from the fit
//
// Torques: orbcal's sense is the torque each joint's actuator applies about its axis (sim/gravity.hpp:
// at rest it holds the arm, tau_j = dU/dq_j), in which a compliance c > 0 is a joint that sags. A
// sensor that reports the load's torque on the joint (the negative) is declared `sense: load`; the
// torques are then read negated.
//
// Every key but covariates and noise (and their entries) is required; an unknown key or an empty
// value (`unit:` and nothing) is an InputError naming the description and the key, never a default.
//
// CSV: a header line, then one sample per line; spaces after commas, CRLF line endings, a UTF-8 BOM
// and trailing empty lines are accepted, columns the description does not name are ignored. Errors
// are one-line InputErrors naming the file, the line and the column: a cell that is not a finite
// number, a column named by the description but absent (or named twice in the header), a row with
// the wrong cell count, a joint reading outside the robot's limits, a pose matrix whose bottom row is
// not [0 0 0 1] or whose rotation is not orthonormal (max |R^T R - I| > 1e-6, or det < 0), a
// quaternion whose norm differs from 1 by more than 1e-6, a file without data rows, and a value
// outside its physical range (the message gives the range in the column's unit): a position or a
// matrix translation beyond 10 km (kMaxLengthM), a torque beyond 1e6 N m, a temperature outside -150
// to 200 degC, a time beyond 1e10 s (Unix time stamps fit), a time earlier than the row before it in
// the same file (rows are samples in the order they were taken). A column the description names for
// two quantities (or twice in one list) is an error naming both keys. A rotation matrix within the
// tolerance is used as given; a quaternion within it is normalised.
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "orbcal/sim/arm.hpp"
#include "orbcal/sim/sample.hpp"

namespace orbcal::sim {

class ConfigNode;

/// The noise a description (`noise:`) or the command line may state, per axis, 1 sigma: a tracker's
/// position noise within 1 nm to 100 mm, its rotation noise within 1e-7 deg to 10 deg, joint readings'
/// within 0 to 10 deg (0: exact).
inline constexpr double kMinNoisePositionMm = 1e-6, kMaxNoisePositionMm = 100.0;
inline constexpr double kMinNoiseRotationDeg = 1e-7, kMaxNoiseRotationDeg = 10.0;
inline constexpr double kMaxNoiseJointDeg = 10.0;

/// How an unknown registration frame is shared between sessions.
enum class FrameSharing {
  kShared,      ///< one frame for all sessions, estimated
  kPerSession,  ///< one frame per session (e.g. a marker re-mounted between runs), estimated
  kKnown        ///< given (world_T_base / flange_T_marker of MeasuredData), not estimated
};

/// "shared", "per_session", "known", as the description and the model file write them.
const char* frameSharingName(FrameSharing s);
/// Reads one of those names; InputError naming the file and the key otherwise.
FrameSharing readFrameSharing(const ConfigNode& node);

struct MeasuredPose {
  JointSample sample;
  Eigen::Isometry3d world_T_marker = Eigen::Isometry3d::Identity();  ///< measured; m
  bool has_rotation = true;  ///< false: position-only data (the rotation is identity and unused)
  int point = -1;            ///< rigid-body data: which marker point (from 0) world_T_marker's position is; -1: the marker
  std::string where;         ///< "<file>: line L", for messages (as loaded; not written)
};

struct MeasuredData {
  std::string description;           ///< path of the YAML description
  std::string robot_file;            ///< as resolved
  Arm arm;                           ///< the nominal arm
  std::vector<std::string> files;    ///< one per session, as resolved
  std::vector<MeasuredPose> poses;   ///< every sample of every session, in file order
  FrameSharing base = FrameSharing::kShared;
  FrameSharing marker = FrameSharing::kShared;
  /// With FrameSharing::kKnown: the given frame (description keys `world_T_base`, `flange_T_marker`
  /// as {xyz_m, rpy_deg}); identity otherwise.
  Eigen::Isometry3d world_T_base = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d flange_T_marker = Eigen::Isometry3d::Identity();
  std::optional<double> noise_position_m;      ///< 1 sigma per axis, when the description gives it
  std::optional<double> noise_rotation_rad;    ///< 1 sigma per axis
  std::optional<double> noise_joint_rad;       ///< joint readings vs the true angles, 1 sigma per joint
  /// Which covariates the files give (then every sample has them). has_direction is false when the
  /// directions were filled from the sample order (fillApproachDirections) rather than read.
  bool has_torque = false, has_temperature = false, has_time = false, has_direction = false;
  /// As the description declares them (the values are SI above): pose.length_unit ("m", "mm"),
  /// joints.unit ("rad", "deg"), and whether the rotations came from quaternion_wxyz columns. For
  /// messages that name which other reading would fit.
  std::string length_unit = "m", angle_unit = "rad";
  bool quaternion = false;
  /// Rigid-body data (pose.points): the number of marker points per row; each measured point of a row is
  /// one MeasuredPose (position only, its `point` set), in the row's order. 0: one marker per row.
  int points = 0;

  int numSessions() const { return static_cast<int>(files.size()); }
};

/// Reads a description and every CSV file it names; SI units inside (rad, m, N m, degC, s). The
/// session of a sample is the index of its file in `files`. Without direction columns, each
/// sample's direction is filled from the order (fillApproachDirections). Joint angles outside the
/// arm's limits, a non-orthonormal rotation (beyond 1e-6), a NaN, a missing column, a wrong count
/// of joint columns, an unknown key: InputError naming the file, the line and the column (or the key).
MeasuredData loadMeasuredData(const std::string& description_path);

/// Approach directions from the sample order within each session: sign(q_k - q_{k-1}) per joint.
/// A joint that moved less than `threshold_rad` keeps the direction of its last real move (the gear
/// stays against the flank that move left it on); before any move of the session it is 0.
void fillApproachDirections(std::vector<MeasuredPose>& poses, double threshold_rad = 1e-6);

/// Writes `data` as a description plus one CSV per session (session_1.csv, session_2.csv, ...: numbered from 1, as frames.yaml numbers sessions) into
/// `folder` (created; every file written atomically), with the columns: index, q1_rad..qN_rad,
/// [tau1_Nm..tauN_Nm], [temperature_C], [time_s], x_m, y_m, z_m, [qw, qx, qy, qz], [dir1..dirN]
/// (the pose as position and quaternion; no quaternion when no sample has_rotation; covariates as
/// the has_* flags say). Registration, known frames and noise are written too. `robot_file` is
/// written as given (relative to the folder, absolute, or builtin:NAME). Returns the description's
/// path. loadMeasuredData reads it back to the same samples and positions bit for bit (numbers
/// written with %.17g); rotations (through a quaternion), known frames (through roll-pitch-yaw) and
/// noise (through mm and deg) come back to rounding.
/// Rigid-body data (points > 0) gets p1_x_m, p1_y_m, p1_z_m, p2_x_m, ... in place of x_m..qz: consecutive
/// poses of one configuration with rising `point` share a row, a point not among them has empty cells.
/// std::invalid_argument when a session from 0 to the largest has no sample, or a sample lacks a
/// value its columns need (or holds a NaN there).
std::string writeMeasuredData(const MeasuredData& data, const std::string& folder, const std::string& robot_file,
                              const std::string& description_name = "measurements.yaml");

}  // namespace orbcal::sim
