#pragma once
// The kinematic model a calibration fits: geometry (the DH errors of arm.hpp) + registration (the
// unknown frames of the measuring system and of the marker on the flange) + physical effects (the
// catalog below), behind one parameter vector p of named blocks (ParamLayout) that owns what every
// parameter means: its name, its unit and its typical magnitude (the prior sigma and column scale).
// Every estimator, report and identifiability table reads names, units and scales from the layout,
// so a new effect is one new type here and nothing changes downstream.
//
// The measurement it predicts is the pose of a marker in the measuring system's frame:
//
//   world_T_marker(p, s) = world_T_base(p) * D(p, t) * base_T_flange(arm(p, T), q + dq(p, s)) * flange_T_marker(p) * Y(p)
//
// where s is a JointSample (joint readings and covariates), D is the base drift with time, arm(p, T)
// the nominal DH rows plus the geometric errors with thermal expansion of the lengths, dq the
// joint-angle corrections of the joint effects, and Y the marker's change between sessions (mount).
// Every catalog effect enters the chain in one of two ways, and its Jacobian column is built from the
// same twists as the identification Jacobian (sim/jacobian.hpp):
//  1. a joint-angle correction dq_j(p, s): compliance c_j tau_j, cyclic harmonics of q_j, encoder
//     scale s_j q_j, backlash b_j times the approach direction; column = theta twist of joint j x
//     d(dq_j)/dp;
//  2. a perturbation of a chain frame: thermal expansion of every a and d, the registration frames,
//     the drift of the base with time, the mount change; column = the twist at that frame.
//
// Registration and mount frames are parameterized as X = (Exp(w), t) right-multiplied onto their
// starting value (t in the frame's own coordinates, w a rotation vector), so p = 0 is the starting
// model. The Jacobian J_e_p is that of the right perturbation of world_T_marker in the marker frame,
// e = poseMinus(world_T_marker(p + dp), world_T_marker(p)) ≈ J_e_p dp, checked against central
// differences in tests/sim/test_model.cpp.
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "orbcal/sim/arm.hpp"
#include "orbcal/sim/effect.hpp"
#include "orbcal/sim/jacobian.hpp"
#include "orbcal/sim/measured.hpp"
#include "orbcal/sim/sample.hpp"

namespace orbcal::sim {

// ---- Parameter layout ---------------------------------------------------------------------------

/// What a parameter measures, for the EKF's prior settings and for printing.
enum class Quantity { kAngle, kLength, kOther };

struct ParamInfo {
  std::string name;          ///< e.g. "theta2", "base_x", "c2", "cyclic2_sin1"
  std::string unit;          ///< SI unit of the value: "rad", "m", "rad/(N*m)", "1", "1/K", "m/s", "rad/s"
  std::string display_unit;  ///< unit people read: "deg", "mm", "rad/(N*m)", ...
  double display_scale = 1;  ///< value [unit] * display_scale = value [display_unit]
  double typical = 1;        ///< typical magnitude (SI): prior 1-sigma and column scale
  Quantity quantity = Quantity::kOther;
  int joint = -1;            ///< a geometry parameter's joint (its row of the table), from 0; -1 for every other
};

/// What a block is, told apart by type: the code that treats kinds of parameters differently (priors,
/// refits, reports) tests the kind, never the block's name.
enum class BlockKind {
  kGeometry,     ///< the DH errors (geometryBlock)
  kBase,         ///< the registration frame world_T_base (frameBlock)
  kMarker,       ///< the registration frame flange_T_marker
  kMount,        ///< a marker's change between sessions (the mount effect)
  kMarkerPoint,  ///< a rigid body's marker point offset (sim/marker_points.hpp)
  kCamera,       ///< the camera's lens (distortionBlock)
  kEffect,       ///< a catalog effect of the chain
  kOther,        ///< a measurement model's own parameters (a plane's coefficients)
};
/// The frames a calibration registers to each data set: base, marker, mount.
bool isRegistrationFrame(BlockKind kind);

struct ParamBlock {
  std::string effect;       ///< "geometry", "base", "marker", or a catalog effect's name (for people and files)
  BlockKind kind = BlockKind::kEffect;
  std::vector<int> joints;  ///< joints it acts on, from 0 (empty for frames and global effects)
  int session = -1;         ///< for per-session frames: the session; -1 otherwise
  int offset = 0;           ///< index of its first parameter in p
  std::vector<ParamInfo> params;
  int size() const { return static_cast<int>(params.size()); }
};

class ParamLayout {
 public:
  /// Appends a block (its offset is set here) and returns its index.
  int add(ParamBlock block);
  int size() const { return size_; }
  const std::vector<ParamBlock>& blocks() const { return blocks_; }
  const ParamBlock& block(int b) const { return blocks_.at(static_cast<std::size_t>(b)); }
  const ParamInfo& param(int i) const;
  int blockOf(int i) const;  ///< index of the block holding parameter i
  /// Index of the first block of `effect` (and `session`, where >= 0); -1 when absent.
  int find(const std::string& effect, int session = -1) const;
  /// Index of the first block of `kind` (and `session`, where >= 0); -1 when absent.
  int find(BlockKind kind, int session = -1) const;
  /// Typical magnitudes of every parameter (SI).
  Eigen::VectorXd typical() const;

 private:
  std::vector<ParamBlock> blocks_;
  int size_ = 0;
};

/// The geometric block of an arm: arm.paramsPerJoint() DH errors per joint in arm.hpp's order (theta,
/// alpha, a, d, and beta for the Hayati convention).
ParamBlock geometryBlock(const Arm& arm);

// ---- The effect catalog -------------------------------------------------------------------------
// Each cause is one EffectKind (sim/effect.hpp) in one file of sim/src/effects/. The structs below
// make the catalog's first causes by name (sim::Compliance{{1}} converts to an Effect) for code and
// tests that build models directly; parseEffect makes any of them from its spec.

/// Joint i deflects by c1_i tau_i (+ c3_i tau_i^3 with degree 3: a stiffening joint), rad per N m.
struct Compliance { std::vector<int> joints; int degree = 1; operator Effect() const; };
/// Transmission error of joint i: sum_{k=1..K} a_ik sin(k q_i) + b_ik cos(k q_i) (rad).
struct Cyclic { std::vector<int> joints; int harmonics = 2; operator Effect() const; };
/// Encoder scale error of joint i: dq_i = s_i q_i (s dimensionless).
struct Scale { std::vector<int> joints; operator Effect() const; };
/// Lost motion of joint i: dq_i = b_i d_i, d_i = +1/-1 the direction it approached from (0: did not move).
struct Backlash { std::vector<int> joints; operator Effect() const; };
/// Every DH length (a and d) expands by alpha (T - reference_C); alpha in 1/K.
struct Thermal { double reference_C = 20.0; operator Effect() const; };
/// The base frame moves linearly with time: D(t) = (Exp((t - reference_s) w), (t - reference_s) v),
/// parameters [v (m/s); w (rad/s)] in the base frame.
struct Drift { double reference_s = 0.0; operator Effect() const; };
/// The marker changes between sessions: sessions 2.. get a rigid change Y_s of the marker frame.
struct Mount { operator Effect() const; };

/// The catalog's names: "compliance", "cyclic", "scale", "backlash", "thermal", "drift", "mount", ...
std::string effectName(const Effect& e);
/// Joints the effect acts on (from 0); empty for global effects.
std::vector<int> effectJoints(const Effect& e);
/// Every name of the catalog, in order (and "distortion", which is a camera effect, not a chain effect).
const std::vector<std::string>& effectNames();
/// Parses "compliance:2,4", "cyclic:2" (the kind's default order), "cyclic:2,3/3" (order 3),
/// "coupling:3,2" (joint 3's error from joint 2's angle), "thermal", "drift", "mount" (joints from 1).
/// Throws InputError naming `what` (e.g. "--effects") for an unknown name, a joint out of range or a
/// joint effect without joints, and for "distortion": a camera effect, which the callers that have a
/// camera (error-set files, the corner model of image datasets) take out with isCameraEffect before
/// parsing the chain effects.
Effect parseEffect(const std::string& spec, int num_joints, const std::string& what);
/// True for the camera effects of the catalog: "distortion" (takes no joints; throws InputError naming
/// `what` for "distortion:..." with anything after the name).
bool isCameraEffect(const std::string& spec, const std::string& what);
/// The `distortion` block: lens distortion the scene's camera does not model, added to its OpenCV
/// coefficients (dk1, dk2, dp1, dp2; dimensionless, in normalised image coordinates). Typical
/// magnitudes: 0.01 for dk1 and dk2 (what a refocused or re-mounted lens, or intrinsics calibrated at
/// another temperature or distance, leave of k1 ~ -0.1..-0.3: a few percent of it; at the corner of a
/// 0.6-radius field it moves a point by ~2 px at f = 1000 px), 1e-3 for dp1 and dp2 (decentring is an
/// order smaller than radial distortion in assembled lenses). k3 is left to the scene: with k1 and k2
/// free it is nearly collinear with them over a board that does not fill the field.
ParamBlock distortionBlock();
/// The inverse of parseEffect: "compliance:2,4".
std::string formatEffect(const Effect& e);
/// Parameter blocks of an effect for an arm and a number of sessions.
std::vector<ParamBlock> effectBlocks(const Effect& e, const Arm& arm, int num_sessions);

/// The largest magnitude (SI) a parameter's value may have in a file orbcal reads (a model's or an error
/// set's effects, a model's parameter list): an angle half a turn, a length 10 m, any other quantity
/// 1e4 times its typical magnitude (typical magnitudes are at the upper end of what the catalog's
/// sources report, so no real arm comes near: a compliance of 1 rad/(N m), a scale error of 200%).
double physicalBound(const ParamInfo& info);
/// "-B to B <unit> (why)": the range physicalBound gives, for messages.
std::string physicalRangeText(const ParamInfo& info);
/// The value at `node` of parameter `info` (SI): a finite number within +-physicalBound(info), else an
/// InputError "<file>: <key>: '<value>' is outside -B to B <unit> (...)".
double readParameterValue(const ConfigNode& node, const ParamInfo& info);

/// Parameter makers for effect kinds (sim/src/effects/): an angle (rad, read in deg) and a length (m,
/// read in mm) of a typical magnitude.
ParamInfo angleParam(std::string name, double typical_rad);
ParamInfo lengthParam(std::string name, double typical_m);
/// The six parameters of a frame change [x, y, z (m); rx, ry, rz (rad)] of `kind` (kBase, kMarker or kMount),
/// named base[session]_x, marker..., mount...
ParamBlock frameBlock(BlockKind kind, int session);

// ---- The model ----------------------------------------------------------------------------------

struct KinematicModel {
  Arm arm;                                       ///< nominal geometry (and masses)
  int sessions = 1;
  FrameSharing base = FrameSharing::kKnown;      ///< how world_T_base is shared and whether it is estimated
  FrameSharing marker = FrameSharing::kKnown;
  /// Starting (nominal) frames: one, or one per session where per_session.
  std::vector<Eigen::Isometry3d> world_T_base{Eigen::Isometry3d::Identity()};
  std::vector<Eigen::Isometry3d> flange_T_marker{Eigen::Isometry3d::Identity()};
  std::vector<Effect> effects;
  bool geometry = true;                          ///< the DH errors are parameters
  /// Rigid-body data: the starting offsets of its marker points in the marker frame (m), each estimated
  /// (sim/marker_points.hpp); empty: the marker's pose or position is measured.
  std::vector<Eigen::Vector3d> marker_points;
  ParamLayout layout;                            ///< built by makeKinematicModel
  std::vector<std::vector<int>> effect_blocks;   ///< layout blocks of each effect (mount: one per session)

  const Eigen::Isometry3d& baseStart(int session) const;
  const Eigen::Isometry3d& markerStart(int session) const;
};

/// Builds the layout: base blocks, marker blocks, marker points, geometry, then each effect's blocks.
/// Frames given one per session where per_session (else one). Throws std::invalid_argument on
/// inconsistent sizes and on an effect given twice (the same kind on the same joint, or a global effect
/// twice).
KinematicModel makeKinematicModel(Arm arm, int sessions, FrameSharing base, FrameSharing marker,
                                  std::vector<Eigen::Isometry3d> world_T_base,
                                  std::vector<Eigen::Isometry3d> flange_T_marker, std::vector<Effect> effects,
                                  bool geometry = true, std::vector<Eigen::Vector3d> marker_points = {});

/// The Wang et al. 2023 model: the flange pose in the base frame, geometry only, frames known (identity).
KinematicModel flangeModel(const Arm& arm);

/// Joint-angle corrections dq (rad, one per joint) of the joint effects at p for sample s.
/// Throws std::invalid_argument when an effect needs a covariate the sample lacks (compliance: torque).
Eigen::VectorXd jointCorrections(const KinematicModel& m, const Eigen::VectorXd& p, const JointSample& s);

/// The arm the chain is evaluated with: nominal DH rows + the geometric errors, lengths expanded by
/// the thermal effect at the sample's temperature.
Arm effectiveArm(const KinematicModel& m, const Eigen::VectorXd& p, const JointSample& s);

/// base_T_flange of the model at p for sample s (effects included; registration excluded).
Eigen::Isometry3d flangePose(const KinematicModel& m, const Eigen::VectorXd& p, const JointSample& s);

/// world_T_marker at p for sample s. J_e_p (6 x layout.size()): Jacobian of the right perturbation
/// in the marker frame; J_e_q (6 x joints): the same for the joint readings (to carry joint noise
/// into a measurement covariance). Either may be null.
Eigen::Isometry3d predictMarkerPose(const KinematicModel& m, const Eigen::VectorXd& p, const JointSample& s,
                                    Eigen::MatrixXd* J_e_p = nullptr, Eigen::MatrixXd* J_e_q = nullptr);

/// The model with p folded in: geometric errors added to the DH rows, registration frames (and marker points) moved,
/// effect parameters returned in `effect_values` (the model keeps no values of its own). The
/// returned model's p = effectValuesAsParams(...) reproduces world_T_marker(p) exactly.
struct FoldedModel {
  KinematicModel model;
  Eigen::VectorXd p;  ///< zero except the effect parameters
};
FoldedModel foldParameters(const KinematicModel& m, const Eigen::VectorXd& p);

/// (Exp(w), t) of a 6-vector [t; w]: the registration parameterization.
Eigen::Isometry3d frameDelta(const Eigen::Ref<const Eigen::VectorXd>& tw);
/// Right Jacobian of SO(3) at the rotation vector w: Exp(w + dw) ≈ Exp(w) Exp(Jr(w) dw).
Eigen::Matrix3d rightJacobianSO3(const Eigen::Vector3d& w);

}  // namespace orbcal::sim
