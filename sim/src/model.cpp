#include "orbcal/sim/model.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/marker_points.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::sim {

// ---- Layout -------------------------------------------------------------------------------------

int ParamLayout::add(ParamBlock block) {
  block.offset = size_;
  size_ += block.size();
  blocks_.push_back(std::move(block));
  return static_cast<int>(blocks_.size()) - 1;
}

int ParamLayout::blockOf(int i) const {
  for (std::size_t b = 0; b < blocks_.size(); ++b) {
    if (i >= blocks_[b].offset && i < blocks_[b].offset + blocks_[b].size()) return static_cast<int>(b);
  }
  throw std::out_of_range("ParamLayout: parameter " + std::to_string(i) + " of " + std::to_string(size_));
}

const ParamInfo& ParamLayout::param(int i) const {
  const ParamBlock& b = block(blockOf(i));
  return b.params[static_cast<std::size_t>(i - b.offset)];
}

bool isRegistrationFrame(BlockKind kind) { return kind == BlockKind::kBase || kind == BlockKind::kMarker || kind == BlockKind::kMount; }

int ParamLayout::find(BlockKind kind, int session) const {
  for (std::size_t b = 0; b < blocks_.size(); ++b) {
    if (blocks_[b].kind == kind && (session < 0 || blocks_[b].session == session)) return static_cast<int>(b);
  }
  return -1;
}

int ParamLayout::find(const std::string& effect, int session) const {
  for (std::size_t b = 0; b < blocks_.size(); ++b) {
    if (blocks_[b].effect == effect && (session < 0 || blocks_[b].session == session)) return static_cast<int>(b);
  }
  return -1;
}

Eigen::VectorXd ParamLayout::typical() const {
  Eigen::VectorXd t(size_);
  for (const ParamBlock& b : blocks_) {
    for (int i = 0; i < b.size(); ++i) t[b.offset + i] = b.params[static_cast<std::size_t>(i)].typical;
  }
  return t;
}

double physicalBound(const ParamInfo& info) {
  constexpr double kTypicalMultiple = 1e4;
  if (info.quantity == Quantity::kAngle) return kPi;
  if (info.quantity == Quantity::kLength) return 10.0;
  return kTypicalMultiple * info.typical;
}

std::string physicalRangeText(const ParamInfo& info) {
  const double b = physicalBound(info);
  const std::string why = info.quantity == Quantity::kAngle    ? "half a turn"
                          : info.quantity == Quantity::kLength ? "10 m"
                                                               : "1e4 times its typical magnitude, " +
                                                                     formatNumber("%.3g", info.typical) + " " + info.unit;
  return formatNumber("%.6g", -b) + " to " + formatNumber("%.6g", b) + " " + info.unit + " (" + why + ")";
}

double readParameterValue(const ConfigNode& node, const ParamInfo& info) {
  const double b = physicalBound(info);
  return node.asDoubleWithin(-b, b, physicalRangeText(info));
}

ParamInfo angleParam(std::string name, double typical_rad) {
  return {std::move(name), "rad", "deg", kRadToDeg, typical_rad, Quantity::kAngle};
}
ParamInfo lengthParam(std::string name, double typical_m) {
  return {std::move(name), "m", "mm", 1e3, typical_m, Quantity::kLength};
}

namespace {

/// Typical magnitudes: the EKF prior and the column scale. DH errors as orbcal's default EKF prior
/// (1 deg, 5 mm); registration frames as the closed-form guess's error on a few-mm nominal model
/// (10 mm, 1 deg); effects at the upper end of what the catalog's sources report (docs/own-robot-and-measured-data.md).
constexpr double kTypicalAngle = 1.0 * kDegToRad;
constexpr double kTypicalLength = 5e-3;
constexpr double kTypicalFrameAngle = 1.0 * kDegToRad;
constexpr double kTypicalFrameLength = 10e-3;

}  // namespace

ParamBlock frameBlock(BlockKind kind, int session) {
  if (!isRegistrationFrame(kind)) throw std::invalid_argument("frameBlock: not a frame's kind");
  const std::string effect = kind == BlockKind::kBase ? "base" : kind == BlockKind::kMarker ? "marker" : "mount";
  ParamBlock b;
  b.effect = effect;
  b.kind = kind;
  b.session = session;
  const std::string p = effect + (session >= 0 ? std::to_string(session + 1) : std::string()) + "_";
  for (const char* axis : {"x", "y", "z"}) b.params.push_back(lengthParam(p + axis, kTypicalFrameLength));
  for (const char* axis : {"rx", "ry", "rz"}) b.params.push_back(angleParam(p + axis, kTypicalFrameAngle));
  return b;
}

namespace {

}  // namespace

ParamBlock geometryBlock(const Arm& arm) {
  ParamBlock b;
  b.effect = "geometry";
  b.kind = BlockKind::kGeometry;
  for (int i = 0; i < arm.numParams(); ++i) {
    b.params.push_back(isAngleParam(arm, i) ? angleParam(paramName(arm, i), kTypicalAngle)
                                            : lengthParam(paramName(arm, i), kTypicalLength));
    b.params.back().joint = i / arm.paramsPerJoint();
  }
  return b;
}

// ---- Effects ------------------------------------------------------------------------------------

Compliance::operator Effect() const { return Effect(*findEffectKind("compliance"), joints, degree); }
Cyclic::operator Effect() const { return Effect(*findEffectKind("cyclic"), joints, harmonics); }
Scale::operator Effect() const { return Effect(*findEffectKind("scale"), joints); }
Backlash::operator Effect() const { return Effect(*findEffectKind("backlash"), joints); }
Thermal::operator Effect() const { return Effect(*findEffectKind("thermal"), {}, 0, reference_C); }
Drift::operator Effect() const { return Effect(*findEffectKind("drift"), {}, 0, reference_s); }
Mount::operator Effect() const { return Effect(*findEffectKind("mount")); }

std::string effectName(const Effect& e) { return e.name(); }
std::vector<int> effectJoints(const Effect& e) { return e.joints(); }

const std::vector<std::string>& effectNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const EffectKind* k : catalog()) n.push_back(k->name());
    n.push_back("distortion");
    return n;
  }();
  return names;
}

namespace {

std::string catalogList() {
  std::string s;
  const auto& kinds = catalog();
  for (std::size_t i = 0; i < kinds.size(); ++i) s += (i ? (i + 1 == kinds.size() ? " or " : ", ") : "") + kinds[i]->name();
  return s;
}

}  // namespace

Effect parseEffect(const std::string& spec, int num_joints, const std::string& what) {
  const auto colon = spec.find(':');
  const std::string name = spec.substr(0, colon);
  std::string rest = colon == std::string::npos ? "" : spec.substr(colon + 1);
  double lo = 0.0, hi = 0.0;
  if (const auto at = rest.find('@'); at != std::string::npos) {
    const std::string range = rest.substr(at + 1);
    const auto dots = range.find("..");
    char* end1 = nullptr;
    char* end2 = nullptr;
    if (dots != std::string::npos) {
      const std::string a = range.substr(0, dots), b = range.substr(dots + 2);
      lo = std::strtod(a.c_str(), &end1);
      hi = std::strtod(b.c_str(), &end2);
      if (a.empty() || b.empty() || *end1 != '\0' || *end2 != '\0') lo = hi = 0.0;
    }
    if (!(lo < hi)) throw InputError(what + ": '" + spec + "': expected @lo..hi with numbers lo < hi after '@'");
    rest = rest.substr(0, at);
  }
  if (name == "distortion") {
    throw InputError(what + ": '" + spec + "': distortion is a camera effect of image datasets (error-set files and "
                     "orbcal calibrate DATASET_DIR --estimate-frames), not an effect of the arm's chain");
  }
  const EffectKind* kind = findEffectKind(name);
  if (!kind) throw InputError(what + ": '" + spec + "': unknown effect (expected " + catalogList() + ")");
  int order = 0;
  if (const auto slash = rest.find('/'); slash != std::string::npos) {
    if (kind->maxOrder() == 0) throw InputError(what + ": '" + spec + "': " + name + " takes no /K (order)");
    char* end = nullptr;
    const std::string tok = rest.substr(slash + 1);
    order = static_cast<int>(std::strtol(tok.c_str(), &end, 10));
    if (tok.empty() || *end != '\0' || order < 1) order = -1;  // 0 would read as the kind's default order
    rest = rest.substr(0, slash);
  }
  std::vector<int> joints;
  std::istringstream in(rest);
  for (std::string tok; std::getline(in, tok, ',');) {
    char* end = nullptr;
    const long j = std::strtol(tok.c_str(), &end, 10);
    if (tok.empty() || *end != '\0') throw InputError(what + ": '" + spec + "': '" + tok + "' is not a joint number");
    joints.push_back(static_cast<int>(j) - 1);
  }
  if (!kind->takesJoints() && !joints.empty()) throw InputError(what + ": '" + spec + "': " + name + " takes no joints");
  if (!kind->empirical() && lo != hi) throw InputError(what + ": '" + spec + "': " + name + " takes no @lo..hi (range)");
  Effect e = Effect(*kind, joints, order).withRange(lo, hi);
  kind->check(e, num_joints, what + ": '" + spec + "'");
  return e;
}

bool isCameraEffect(const std::string& spec, const std::string& what) {
  const std::string name = spec.substr(0, spec.find(':'));
  if (name != "distortion") return false;
  if (spec != name) throw InputError(what + ": '" + spec + "': distortion takes no joints");
  return true;
}

ParamBlock distortionBlock() {
  ParamBlock b;
  b.effect = "distortion";
  b.kind = BlockKind::kCamera;
  b.params.push_back({"dk1", "1", "1", 1.0, 1e-2, Quantity::kOther});
  b.params.push_back({"dk2", "1", "1", 1.0, 1e-2, Quantity::kOther});
  b.params.push_back({"dp1", "1", "1", 1.0, 1e-3, Quantity::kOther});
  b.params.push_back({"dp2", "1", "1", 1.0, 1e-3, Quantity::kOther});
  return b;
}

std::string formatEffect(const Effect& e) { return e.spec(); }

std::vector<ParamBlock> effectBlocks(const Effect& e, const Arm& arm, int num_sessions) {
  checkJointTypes(e, arm, arm.source);
  return e.kind().blocks(e, arm, num_sessions);
}

// ---- Model --------------------------------------------------------------------------------------

const Eigen::Isometry3d& KinematicModel::baseStart(int session) const {
  return world_T_base[base == FrameSharing::kPerSession ? static_cast<std::size_t>(session) : 0];
}
const Eigen::Isometry3d& KinematicModel::markerStart(int session) const {
  return flange_T_marker[marker == FrameSharing::kPerSession ? static_cast<std::size_t>(session) : 0];
}

KinematicModel makeKinematicModel(Arm arm, int sessions, FrameSharing base, FrameSharing marker,
                                  std::vector<Eigen::Isometry3d> world_T_base,
                                  std::vector<Eigen::Isometry3d> flange_T_marker, std::vector<Effect> effects,
                                  bool geometry, std::vector<Eigen::Vector3d> marker_points) {
  if (sessions < 1) throw std::invalid_argument("makeKinematicModel: at least one session");
  const auto expect = [&](FrameSharing s) { return s == FrameSharing::kPerSession ? sessions : 1; };
  if (static_cast<int>(world_T_base.size()) != expect(base) || static_cast<int>(flange_T_marker.size()) != expect(marker)) {
    throw std::invalid_argument("makeKinematicModel: expected one frame, or one per session where per_session");
  }
  KinematicModel m;
  m.arm = std::move(arm);
  m.sessions = sessions;
  m.base = base;
  m.marker = marker;
  m.world_T_base = std::move(world_T_base);
  m.flange_T_marker = std::move(flange_T_marker);
  m.effects = std::move(effects);
  m.geometry = geometry;
  const auto addFrames = [&](BlockKind kind, FrameSharing s) {
    if (s == FrameSharing::kShared) m.layout.add(frameBlock(kind, -1));
    if (s == FrameSharing::kPerSession) {
      for (int k = 0; k < sessions; ++k) m.layout.add(frameBlock(kind, k));
    }
  };
  addFrames(BlockKind::kBase, base);
  addFrames(BlockKind::kMarker, marker);
  m.marker_points = std::move(marker_points);
  for (std::size_t k = 0; k < m.marker_points.size(); ++k) m.layout.add(pointBlock(static_cast<int>(k)));
  if (geometry) m.layout.add(geometryBlock(m.arm));
  std::vector<std::string> seen;  // "compliance:2", "thermal", ... once each
  for (const Effect& e : m.effects) {
    for (const int j : e.joints()) {
      if (j < 0 || j >= m.arm.numJoints()) throw std::invalid_argument("makeKinematicModel: effect joint out of range");
    }
    for (const std::string& k : e.kind().keys(e)) {
      if (std::find(seen.begin(), seen.end(), k) != seen.end()) {
        throw std::invalid_argument("the effect " + k + " is given twice");
      }
      seen.push_back(k);
    }
    std::vector<int>& mine = m.effect_blocks.emplace_back();
    for (ParamBlock& b : effectBlocks(e, m.arm, sessions)) mine.push_back(m.layout.add(std::move(b)));
  }
  return m;
}

KinematicModel flangeModel(const Arm& arm) {
  return makeKinematicModel(arm, 1, FrameSharing::kKnown, FrameSharing::kKnown, {Eigen::Isometry3d::Identity()},
                            {Eigen::Isometry3d::Identity()}, {});
}

Eigen::Matrix3d rightJacobianSO3(const Eigen::Vector3d& w) {
  const double th = w.norm();
  const Eigen::Matrix3d W = skew(w);
  if (th < 1e-6) return Eigen::Matrix3d::Identity() - 0.5 * W + W * W / 6.0;
  return Eigen::Matrix3d::Identity() - (1.0 - std::cos(th)) / (th * th) * W + (th - std::sin(th)) / (th * th * th) * W * W;
}

Eigen::Isometry3d frameDelta(const Eigen::Ref<const Eigen::VectorXd>& tw) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = expSO3(tw.tail<3>());
  X.translation() = tw.head<3>();
  return X;
}

namespace {

/// d(frameDelta)/d[t; w] as a right perturbation in the frame's own coordinates: [R^T dt; Jr(w) dw].
Matrix6d frameDeltaJacobian(const Eigen::Ref<const Eigen::VectorXd>& tw) {
  Matrix6d J = Matrix6d::Zero();
  J.topLeftCorner<3, 3>() = expSO3(tw.tail<3>()).transpose();
  J.bottomRightCorner<3, 3>() = rightJacobianSO3(tw.tail<3>());
  return J;
}

/// Index of the block of a frame for a session (shared or per session); -1 when the frame is known.
int frameBlockIndex(const KinematicModel& m, BlockKind kind, FrameSharing sharing, int session) {
  if (sharing == FrameSharing::kKnown) return -1;
  return m.layout.find(kind, sharing == FrameSharing::kPerSession ? session : -1);
}

/// Walks the effects with their layout blocks (effects with several blocks, i.e. mount, visit each).
template <class F>
void forEachEffectBlock(const KinematicModel& m, F&& f) {
  for (std::size_t i = 0; i < m.effects.size(); ++i) {
    for (const int b : m.effect_blocks[i]) f(m.effects[i], m.layout.block(b));
  }
}

Eigen::VectorXd jointCorrectionsImpl(const KinematicModel& m, const Eigen::VectorXd& p, const JointSample& s,
                                     JointCorrectionJacobian* J_dq_p) {
  Eigen::VectorXd dq = Eigen::VectorXd::Zero(m.arm.numJoints());
  if (J_dq_p) J_dq_p->clear();
  forEachEffectBlock(m, [&](const Effect& e, const ParamBlock& b) {
    e.kind().requireCovariates(s, m.arm.numJoints());
    e.kind().addJointCorrection(e, b, p, s, m.arm, dq, J_dq_p);
  });
  return dq;
}

/// The product of the effects' length scales and the derivative of its log over each parameter.
struct LengthScale {
  double scale = 1.0;
  std::vector<std::pair<int, double>> dlog;  ///< (parameter, d log(scale) / dp)
};
LengthScale lengthScaleOf(const KinematicModel& m, const Eigen::VectorXd& p, const JointSample& s) {
  LengthScale out;
  forEachEffectBlock(m, [&](const Effect& e, const ParamBlock& b) {
    const auto [scale, derivative] = e.kind().lengthScale(e, b, p, s);
    if (scale == 1.0 && derivative == 0.0) return;
    out.scale *= scale;
    out.dlog.emplace_back(b.offset, derivative / scale);
  });
  return out;
}

void checkSizes(const KinematicModel& m, const Eigen::VectorXd& p, const JointSample& s) {
  if (p.size() != m.layout.size()) {
    throw std::invalid_argument("kinematic model: expected " + std::to_string(m.layout.size()) + " parameters, got " +
                                std::to_string(p.size()));
  }
  checkJointVector(m.arm, s.q_rad, "kinematic model");
  if (s.session < 0 || s.session >= m.sessions) {
    throw std::invalid_argument("kinematic model: session " + std::to_string(s.session + 1) + " of " +
                                std::to_string(m.sessions));
  }
}

}  // namespace

Eigen::VectorXd jointCorrections(const KinematicModel& m, const Eigen::VectorXd& p, const JointSample& s) {
  return jointCorrectionsImpl(m, p, s, nullptr);
}

namespace {

/// The chain at p, scaled: only what chainFrames and identificationJacobian read (convention, fixed
/// end transforms, rows). The arm's name, source, limits, masses and URDF record are left out: copying
/// them for every sample at every evaluation was most of a fit's memory traffic.
Arm scaledArm(const KinematicModel& m, const Eigen::VectorXd& p, double length_scale) {
  Arm arm;
  arm.convention = m.arm.convention;
  arm.base_T_first = m.arm.base_T_first;
  arm.joints = m.arm.joints;
  arm.last_T_flange = m.arm.last_T_flange;
  if (m.geometry) {
    const ParamBlock& g = m.layout.block(m.layout.find(BlockKind::kGeometry));
    addErrors(arm, p.segment(g.offset, g.size()));  // in place: no second copy of the rows
  }
  if (length_scale != 1.0) {
    for (DhRow& r : arm.joints) {
      r.a_m *= length_scale;
      r.d_m *= length_scale;
      r.xyz_m *= length_scale;  // the URDF convention's lengths (zero in the DH conventions)
    }
  }
  return arm;
}

/// The effects' chain inserts at p for sample s. Each is evaluated on the nominal arm at the joint
/// readings (a link's load direction, say): what geometry errors and joint corrections change in an
/// insert is second order, and so the inserts' columns are exact.
struct Inserts {
  std::vector<ChainInsert> all;
  LinkInserts links;  ///< one per link where any effect bends a link, else empty
};
Inserts chainInserts(const KinematicModel& m, const Eigen::VectorXd& p, const JointSample& s) {
  Inserts out;
  out.all.reserve(8);  // one allocation, not one per growth (a flexible model inserts a few per sample)
  const NominalChain chain(m.arm, s.q_rad);
  forEachEffectBlock(m, [&](const Effect& e, const ParamBlock& b) { e.kind().addChainInserts(e, b, p, s, chain, out.all); });
  for (const ChainInsert& c : out.all) {
    if (c.place != ChainInsert::Place::kLink) continue;
    if (out.links.empty()) out.links.assign(static_cast<std::size_t>(m.arm.numJoints()), Eigen::Isometry3d::Identity());
    out.links[static_cast<std::size_t>(c.link)] = out.links[static_cast<std::size_t>(c.link)] * frameDelta(c.xi);
  }
  return out;
}

/// The product of the inserts at `place` in their order.
Eigen::Isometry3d insertsAt(const Inserts& in, ChainInsert::Place place) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  for (const ChainInsert& c : in.all) {
    if (c.place == place) X = X * frameDelta(c.xi);
  }
  return X;
}

/// Adds the columns of the chain inserts: each insert's right perturbation carried to the marker frame
/// through what follows it (`after`: the chain from just after the insert to the marker).
void addInsertColumns(const Inserts& in, const std::vector<Eigen::Isometry3d>& frames, const Eigen::Isometry3d& F,
                      const Eigen::Isometry3d& MY, Eigen::MatrixXd& J) {
  const auto after = [&](std::size_t k) {
    const ChainInsert& c = in.all[k];
    Eigen::Isometry3d rest = Eigen::Isometry3d::Identity();  // the later inserts at the same place (links: in the link's product)
    for (std::size_t l = k + 1; l < in.all.size(); ++l) {
      if (in.all[l].place == c.place && in.all[l].link == c.link) rest = rest * frameDelta(in.all[l].xi);
    }
    if (c.place == ChainInsert::Place::kBase) return Eigen::Isometry3d(rest * F * MY);
    if (c.place == ChainInsert::Place::kMarker) return rest;
    if (c.place == ChainInsert::Place::kFlange) return Eigen::Isometry3d(rest * MY);
    return Eigen::Isometry3d(rest * frames[static_cast<std::size_t>(c.link) + 1].inverse() * F * MY);
  };
  for (std::size_t k = 0; k < in.all.size(); ++k) {
    const ChainInsert& c = in.all[k];
    J.middleCols(c.offset, c.J_xi_p.cols()) += adjoint(after(k).inverse()) * frameDeltaJacobian(c.xi) * c.J_xi_p;
  }
}

}  // namespace

Arm effectiveArm(const KinematicModel& m, const Eigen::VectorXd& p, const JointSample& s) {
  return scaledArm(m, p, lengthScaleOf(m, p, s).scale);
}

Eigen::Isometry3d flangePose(const KinematicModel& m, const Eigen::VectorXd& p, const JointSample& s) {
  checkSizes(m, p, s);
  const Eigen::VectorXd q = s.q_rad + jointCorrections(m, p, s);
  const Arm arm = effectiveArm(m, p, s);
  const Inserts inserts = chainInserts(m, p, s);
  return forwardKinematics(arm, q, inserts.links) * insertsAt(inserts, ChainInsert::Place::kFlange);
}

Eigen::Isometry3d predictMarkerPose(const KinematicModel& m, const Eigen::VectorXd& p, const JointSample& s,
                                    Eigen::MatrixXd* J_e_p, Eigen::MatrixXd* J_e_q) {
  checkSizes(m, p, s);
  const int n = m.arm.numJoints();
  // The per-sample matrices of the Jacobian, kept per thread between calls: a fit evaluates this for
  // every sample at every iteration, and these allocations (with the chain frames' below) were about
  // half of a diagnosis's 10.6 million (the real iiwa7 0 kg run; 2.4 % of its instructions).
  thread_local JointCorrectionJacobian J_dq_p;
  thread_local Matrix6Xd J_flange, J_geo, J_q;
  const Eigen::VectorXd q = s.q_rad + jointCorrectionsImpl(m, p, s, J_e_p ? &J_dq_p : nullptr);
  const LengthScale lengths = lengthScaleOf(m, p, s);
  const Arm arm = scaledArm(m, p, lengths.scale);
  const Inserts inserts = chainInserts(m, p, s);

  // The chain's factors: world_T_base = W0 X_b; D (base inserts); F; flange_T_marker = M0 X_m; Y (marker inserts).
  const int b_blk = frameBlockIndex(m, BlockKind::kBase, m.base, s.session);
  const int m_blk = frameBlockIndex(m, BlockKind::kMarker, m.marker, s.session);
  const auto seg = [&](int blk) { return p.segment(m.layout.block(blk).offset, 6); };
  const Eigen::Isometry3d W = b_blk >= 0 ? m.baseStart(s.session) * frameDelta(seg(b_blk)) : m.baseStart(s.session);
  const Eigen::Isometry3d D = insertsAt(inserts, ChainInsert::Place::kBase);
  thread_local std::vector<Eigen::Isometry3d> frames;
  chainFrames(arm, q, inserts.links, frames);
  const Eigen::Isometry3d Xf = insertsAt(inserts, ChainInsert::Place::kFlange);
  const Eigen::Isometry3d F = frames.back() * Xf;
  const Eigen::Isometry3d M = m_blk >= 0 ? m.markerStart(s.session) * frameDelta(seg(m_blk)) : m.markerStart(s.session);
  const Eigen::Isometry3d Y = insertsAt(inserts, ChainInsert::Place::kMarker);
  const Eigen::Isometry3d MY = M * Y;
  const Eigen::Isometry3d world_T_marker = W * D * F * MY;
  if (!J_e_p && !J_e_q) return world_T_marker;

  // Flange-frame columns of every DH parameter (the zero-offset columns double as the joints' columns), moved
  // to the marker frame.
  const Matrix6d Ad_marker_flange = adjoint((Xf * MY).inverse());
  J_flange.resize(6, arm.numParams());
  identificationJacobian(arm, q, ErrorFrame::kTool, J_flange, inserts.links, frames);
  // Products of 6-row matrices, coefficient by coefficient: the blocked GEMM path costs more than the
  // arithmetic at these sizes (lazyProduct).
  J_geo.noalias() = Ad_marker_flange.lazyProduct(J_flange);
  J_q.resize(6, n);
  for (int j = 0; j < n; ++j) J_q.col(j) = J_geo.col(jointParamIndex(arm, j));
  if (J_e_q) *J_e_q = J_q;
  if (!J_e_p) return world_T_marker;

  Eigen::MatrixXd& J = *J_e_p;
  // Joint-angle effects: J_q J_dq_p. Each of their columns moves one joint or a few, so only J_dq_p's
  // entries are multiplied: the dense 6 x n x P product was a tenth of a flexible fit's arithmetic.
  J = Eigen::MatrixXd::Zero(6, m.layout.size());
  for (const JointCorrectionJacobian::Entry& e : J_dq_p.entries()) {
    if (e.value != 0.0) J.col(e.param) += e.value * J_q.col(e.joint);
  }
  if (b_blk >= 0) {
    J.middleCols(m.layout.block(b_blk).offset, 6) += adjoint((D * F * MY).inverse()) * frameDeltaJacobian(seg(b_blk));
  }
  if (m_blk >= 0) J.middleCols(m.layout.block(m_blk).offset, 6) += adjoint(Y.inverse()) * frameDeltaJacobian(seg(m_blk));
  addInsertColumns(inserts, frames, F, MY, J);

  // Geometry: lengths enter as (nominal + error) * scale.
  if (m.geometry) {
    const int g = m.layout.block(m.layout.find(BlockKind::kGeometry)).offset;
    for (int i = 0; i < m.arm.numParams(); ++i) {
      if (isAngleParam(m.arm, i)) {
        J.col(g + i) += J_geo.col(i);
      } else {
        J.col(g + i) += lengths.scale * J_geo.col(i);  // no temporary column (a conditional expression made one per column)
      }
    }
  }
  // d/dp of the scaled lengths L_eff = L scale: L_eff d log(scale)/dp along each length's own column.
  for (const auto& [col, dlog] : lengths.dlog) {
    for (int j = 0; j < n; ++j) {
      if (arm.convention == DhConvention::kUrdf) {
        for (int a = 0; a < 3; ++a) J.col(col) += dlog * arm.joints[j].xyz_m[a] * J_geo.col(paramIndex(arm, j, ParamKind(kOx + a)));
        if (arm.isPrismatic(j)) J.col(col) += dlog * arm.joints[j].d_m * J_geo.col(jointParamIndex(arm, j));  // the zero offset
      } else {
        J.col(col) += dlog * (arm.joints[j].a_m * J_geo.col(paramIndex(arm, j, kA)) + arm.joints[j].d_m * J_geo.col(paramIndex(arm, j, kD)));
      }
    }
  }
  return world_T_marker;
}

FoldedModel foldParameters(const KinematicModel& m, const Eigen::VectorXd& p) {
  if (p.size() != m.layout.size()) throw std::invalid_argument("foldParameters: wrong parameter count");
  KinematicModel out = m;
  if (m.geometry) {
    const ParamBlock& g = m.layout.block(m.layout.find(BlockKind::kGeometry));
    out.arm = withErrors(m.arm, p.segment(g.offset, g.size()));
  }
  const auto foldFrames = [&](BlockKind kind, FrameSharing sharing, std::vector<Eigen::Isometry3d>& frames) {
    for (std::size_t k = 0; k < frames.size(); ++k) {
      const int blk = frameBlockIndex(m, kind, sharing, static_cast<int>(k));
      if (blk >= 0) frames[k] = frames[k] * frameDelta(p.segment(m.layout.block(blk).offset, 6));
    }
  };
  foldFrames(BlockKind::kBase, m.base, out.world_T_base);
  foldFrames(BlockKind::kMarker, m.marker, out.flange_T_marker);
  out.marker_points = foldedMarkerPoints(m, p);
  Eigen::VectorXd q = Eigen::VectorXd::Zero(p.size());
  for (const std::vector<int>& blocks : m.effect_blocks) {
    for (const int i : blocks) q.segment(m.layout.block(i).offset, m.layout.block(i).size()) = p.segment(m.layout.block(i).offset, m.layout.block(i).size());
  }
  return {std::move(out), std::move(q)};
}

}  // namespace orbcal::sim
