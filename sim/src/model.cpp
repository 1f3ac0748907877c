#include "orbcal/sim/model.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "orbcal/sim/config.hpp"
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

namespace {

ParamInfo angleParam(std::string name, double typical_rad) {
  return {std::move(name), "rad", "deg", kRadToDeg, typical_rad, Quantity::kAngle};
}
ParamInfo lengthParam(std::string name, double typical_m) {
  return {std::move(name), "m", "mm", 1e3, typical_m, Quantity::kLength};
}

/// Typical magnitudes: the EKF prior and the column scale. DH errors as orbcal's default EKF prior
/// (1 deg, 5 mm); registration frames as the closed-form guess's error on a few-mm nominal model
/// (10 mm, 1 deg); effects at the upper end of what the catalog's sources report (see README).
constexpr double kTypicalAngle = 1.0 * kDegToRad;
constexpr double kTypicalLength = 5e-3;
constexpr double kTypicalFrameAngle = 1.0 * kDegToRad;
constexpr double kTypicalFrameLength = 10e-3;

ParamBlock frameBlock(const std::string& effect, int session) {
  ParamBlock b;
  b.effect = effect;
  b.session = session;
  const std::string p = effect + (session >= 0 ? std::to_string(session + 1) : std::string()) + "_";
  for (const char* axis : {"x", "y", "z"}) b.params.push_back(lengthParam(p + axis, kTypicalFrameLength));
  for (const char* axis : {"rx", "ry", "rz"}) b.params.push_back(angleParam(p + axis, kTypicalFrameAngle));
  return b;
}

void requireJoints(const std::vector<int>& joints, int n, const std::string& what, const std::string& effect) {
  if (joints.empty()) throw InputError(what + ": " + effect + " needs joints, e.g. " + effect + ":2,4");
  for (int j : joints) {
    if (j < 0 || j >= n) {
      throw InputError(what + ": " + effect + ": joint " + std::to_string(j + 1) + " is out of range 1.." + std::to_string(n));
    }
  }
}

template <class... Ts>
struct Overloaded : Ts... {
  using Ts::operator()...;
};
template <class... Ts>
Overloaded(Ts...) -> Overloaded<Ts...>;

}  // namespace

ParamBlock geometryBlock(const Arm& arm) {
  ParamBlock b;
  b.effect = "geometry";
  for (int i = 0; i < arm.numParams(); ++i) {
    b.params.push_back(isAngleParam(arm, i) ? angleParam(paramName(arm, i), kTypicalAngle)
                                            : lengthParam(paramName(arm, i), kTypicalLength));
  }
  return b;
}

// ---- Effects ------------------------------------------------------------------------------------

std::string effectName(const Effect& e) {
  return std::visit(Overloaded{[](const Compliance&) { return "compliance"; }, [](const Cyclic&) { return "cyclic"; },
                               [](const Scale&) { return "scale"; }, [](const Backlash&) { return "backlash"; },
                               [](const Thermal&) { return "thermal"; }, [](const Drift&) { return "drift"; },
                               [](const Mount&) { return "mount"; }},
                    e);
}

std::vector<int> effectJoints(const Effect& e) {
  return std::visit(Overloaded{[](const Compliance& x) { return x.joints; }, [](const Cyclic& x) { return x.joints; },
                               [](const Scale& x) { return x.joints; }, [](const Backlash& x) { return x.joints; },
                               [](const auto&) { return std::vector<int>{}; }},
                    e);
}

const std::vector<std::string>& effectNames() {
  static const std::vector<std::string> names{"compliance", "cyclic", "scale",  "backlash",
                                              "thermal",    "drift",  "mount",  "distortion"};
  return names;
}

Effect parseEffect(const std::string& spec, int num_joints, const std::string& what) {
  const auto colon = spec.find(':');
  const std::string name = spec.substr(0, colon);
  std::string rest = colon == std::string::npos ? "" : spec.substr(colon + 1);
  int harmonics = 2;
  if (const auto slash = rest.find('/'); slash != std::string::npos) {
    if (name != "cyclic") throw InputError(what + ": '" + spec + "': only cyclic takes /K (harmonics)");
    try {
      harmonics = std::stoi(rest.substr(slash + 1));
    } catch (const std::exception&) {
      harmonics = 0;
    }
    if (harmonics < 1 || harmonics > 8) throw InputError(what + ": '" + spec + "': harmonics must be 1..8");
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
  const bool global = name == "thermal" || name == "drift" || name == "mount";
  if (global && !joints.empty()) throw InputError(what + ": '" + spec + "': " + name + " takes no joints");
  if (name == "compliance" || name == "cyclic" || name == "scale" || name == "backlash") {
    requireJoints(joints, num_joints, what, name);
  }
  if (name == "compliance") return Compliance{joints};
  if (name == "cyclic") return Cyclic{joints, harmonics};
  if (name == "scale") return Scale{joints};
  if (name == "backlash") return Backlash{joints};
  if (name == "thermal") return Thermal{};
  if (name == "drift") return Drift{};
  if (name == "mount") return Mount{};
  if (name == "distortion") {
    throw InputError(what + ": '" + spec + "': distortion is a camera effect of image datasets (error-set files and "
                     "orbcal calibrate DATASET_DIR --estimate-frames), not an effect of the arm's chain");
  }
  throw InputError(what + ": '" + spec + "': unknown effect (expected compliance, cyclic, scale, backlash, thermal, drift or mount)");
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
  b.params.push_back({"dk1", "1", "1", 1.0, 1e-2, Quantity::kOther});
  b.params.push_back({"dk2", "1", "1", 1.0, 1e-2, Quantity::kOther});
  b.params.push_back({"dp1", "1", "1", 1.0, 1e-3, Quantity::kOther});
  b.params.push_back({"dp2", "1", "1", 1.0, 1e-3, Quantity::kOther});
  return b;
}

std::string formatEffect(const Effect& e) {
  std::string s = effectName(e);
  const std::vector<int> joints = effectJoints(e);
  for (std::size_t i = 0; i < joints.size(); ++i) s += (i == 0 ? ":" : ",") + std::to_string(joints[i] + 1);
  if (const auto* c = std::get_if<Cyclic>(&e); c && c->harmonics != 2) s += "/" + std::to_string(c->harmonics);
  return s;
}

std::vector<ParamBlock> effectBlocks(const Effect& e, int num_sessions) {
  std::vector<ParamBlock> out;
  const auto jointBlock = [&](const std::vector<int>& joints, auto makeParams) {
    ParamBlock b;
    b.effect = effectName(e);
    b.joints = joints;
    for (int j : joints) makeParams(b, std::to_string(j + 1));
    out.push_back(std::move(b));
  };
  std::visit(
      Overloaded{
          [&](const Compliance& x) {
            // 1e-4 rad/(N m): a harmonic drive of ~10^4 N m/rad (the iiwa's joints: Bischoff et al. 2010).
            jointBlock(x.joints, [](ParamBlock& b, const std::string& j) {
              b.params.push_back({"c" + j, "rad/(N*m)", "rad/(N*m)", 1.0, 1e-4, Quantity::kOther});
            });
          },
          [&](const Cyclic& x) {
            jointBlock(x.joints, [&](ParamBlock& b, const std::string& j) {
              for (int k = 1; k <= x.harmonics; ++k) {
                b.params.push_back(angleParam("cyclic" + j + "_sin" + std::to_string(k), 0.01 * kDegToRad));
                b.params.push_back(angleParam("cyclic" + j + "_cos" + std::to_string(k), 0.01 * kDegToRad));
              }
            });
          },
          [&](const Scale& x) {
            jointBlock(x.joints, [](ParamBlock& b, const std::string& j) {
              // 2e-4 (200 ppm): the order of the joint-scale errors identified on industrial arms.
              b.params.push_back({"s" + j, "1", "ppm", 1e6, 2e-4, Quantity::kOther});
            });
          },
          [&](const Backlash& x) {
            jointBlock(x.joints, [](ParamBlock& b, const std::string& j) {
              b.params.push_back(angleParam("b" + j, 0.01 * kDegToRad));
            });
          },
          [&](const Thermal&) {
            ParamBlock b;
            b.effect = "thermal";
            // Aluminium 23e-6 /K, steel 12e-6 /K.
            b.params.push_back({"alpha_thermal", "1/K", "ppm/K", 1e6, 2.3e-5, Quantity::kOther});
            out.push_back(std::move(b));
          },
          [&](const Drift&) {
            ParamBlock b;
            b.effect = "drift";
            for (const char* a : {"x", "y", "z"}) {
              b.params.push_back({std::string("drift_v") + a, "m/s", "mm/h", 3.6e6, 1e-3 / 3600.0, Quantity::kOther});
            }
            for (const char* a : {"x", "y", "z"}) {
              b.params.push_back({std::string("drift_w") + a, "rad/s", "deg/h", kRadToDeg * 3600.0, 0.01 * kDegToRad / 3600.0,
                                  Quantity::kOther});
            }
            out.push_back(std::move(b));
          },
          [&](const Mount&) {
            for (int s = 1; s < num_sessions; ++s) out.push_back(frameBlock("mount", s));
          }},
      e);
  return out;
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
                                  bool geometry) {
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
  const auto addFrames = [&](const std::string& name, FrameSharing s) {
    if (s == FrameSharing::kShared) m.layout.add(frameBlock(name, -1));
    if (s == FrameSharing::kPerSession) {
      for (int k = 0; k < sessions; ++k) m.layout.add(frameBlock(name, k));
    }
  };
  addFrames("base", base);
  addFrames("marker", marker);
  if (geometry) m.layout.add(geometryBlock(m.arm));
  std::vector<std::string> seen;  // "compliance:2", "thermal", ... once each
  for (const Effect& e : m.effects) {
    const std::vector<int> joints = effectJoints(e);
    std::vector<std::string> keys;
    if (joints.empty()) keys.push_back(effectName(e));
    for (const int j : joints) {
      if (j < 0 || j >= m.arm.numJoints()) throw std::invalid_argument("makeKinematicModel: effect joint out of range");
      keys.push_back(effectName(e) + ":" + std::to_string(j + 1));
    }
    for (const std::string& k : keys) {
      if (std::find(seen.begin(), seen.end(), k) != seen.end()) {
        throw std::invalid_argument("the effect " + k + " is given twice");
      }
      seen.push_back(k);
    }
    std::vector<int>& mine = m.effect_blocks.emplace_back();
    for (ParamBlock& b : effectBlocks(e, sessions)) mine.push_back(m.layout.add(std::move(b)));
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
int frameBlockIndex(const KinematicModel& m, const std::string& name, FrameSharing sharing, int session) {
  if (sharing == FrameSharing::kKnown) return -1;
  return m.layout.find(name, sharing == FrameSharing::kPerSession ? session : -1);
}

double deltaTemperature(const Thermal& t, const JointSample& s) {
  if (!s.hasTemperature()) throw std::invalid_argument("the thermal effect needs a temperature for every sample");
  return s.temperature_C - t.reference_C;
}
double deltaTime(const Drift& d, const JointSample& s) {
  if (!s.hasTime()) throw std::invalid_argument("the drift effect needs a time for every sample");
  return s.time_s - d.reference_s;
}

/// Adds the joint effects' dq (and, where J_dq_p is given, d dq / d p) of one block.
void addJointEffect(const Effect& e, const ParamBlock& b, const Eigen::VectorXd& p, const JointSample& s,
                    Eigen::VectorXd& dq, Eigen::MatrixXd* J_dq_p) {
  std::visit(Overloaded{[&](const Compliance&) {
                          if (!s.hasTorque()) {
                            throw std::invalid_argument(
                                "the compliance effect needs joint torques: measured, or from the robot file's masses");
                          }
                          for (std::size_t i = 0; i < b.joints.size(); ++i) {
                            const int j = b.joints[i], col = b.offset + static_cast<int>(i);
                            dq[j] += p[col] * s.tau_Nm[j];
                            if (J_dq_p) (*J_dq_p)(j, col) += s.tau_Nm[j];
                          }
                        },
                        [&](const Cyclic& c) {
                          int col = b.offset;
                          for (const int j : b.joints) {
                            for (int k = 1; k <= c.harmonics; ++k, col += 2) {
                              const double sn = std::sin(k * s.q_rad[j]), cs = std::cos(k * s.q_rad[j]);
                              dq[j] += p[col] * sn + p[col + 1] * cs;
                              if (J_dq_p) {
                                (*J_dq_p)(j, col) += sn;
                                (*J_dq_p)(j, col + 1) += cs;
                              }
                            }
                          }
                        },
                        [&](const Scale&) {
                          for (std::size_t i = 0; i < b.joints.size(); ++i) {
                            const int j = b.joints[i], col = b.offset + static_cast<int>(i);
                            dq[j] += p[col] * s.q_rad[j];
                            if (J_dq_p) (*J_dq_p)(j, col) += s.q_rad[j];
                          }
                        },
                        [&](const Backlash&) {
                          if (s.direction.size() != s.q_rad.size()) {
                            throw std::invalid_argument("the backlash effect needs the approach direction of every joint");
                          }
                          for (std::size_t i = 0; i < b.joints.size(); ++i) {
                            const int j = b.joints[i], col = b.offset + static_cast<int>(i);
                            dq[j] += p[col] * s.direction[j];
                            if (J_dq_p) (*J_dq_p)(j, col) += s.direction[j];
                          }
                        },
                        [](const auto&) {}},
             e);
}

/// Walks the effects with their layout blocks (effects with several blocks, i.e. mount, visit each).
template <class F>
void forEachEffectBlock(const KinematicModel& m, F&& f) {
  for (std::size_t i = 0; i < m.effects.size(); ++i) {
    for (const int b : m.effect_blocks[i]) f(m.effects[i], m.layout.block(b));
  }
}

Eigen::VectorXd jointCorrectionsImpl(const KinematicModel& m, const Eigen::VectorXd& p, const JointSample& s,
                                     Eigen::MatrixXd* J_dq_p) {
  Eigen::VectorXd dq = Eigen::VectorXd::Zero(m.arm.numJoints());
  if (J_dq_p) *J_dq_p = Eigen::MatrixXd::Zero(m.arm.numJoints(), m.layout.size());
  forEachEffectBlock(m, [&](const Effect& e, const ParamBlock& b) { addJointEffect(e, b, p, s, dq, J_dq_p); });
  return dq;
}

/// The model's effect of type T (the catalog's global effects occur at most once) and the offset of
/// its parameters; {nullptr, -1} when absent.
template <class T>
std::pair<const T*, int> findEffect(const KinematicModel& m) {
  for (std::size_t i = 0; i < m.effects.size(); ++i) {
    if (const auto* e = std::get_if<T>(&m.effects[i])) return {e, m.layout.block(m.effect_blocks[i].front()).offset};
  }
  return {nullptr, -1};
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

Arm effectiveArm(const KinematicModel& m, const Eigen::VectorXd& p, const JointSample& s) {
  Arm arm = m.arm;
  if (m.geometry) {
    const ParamBlock& g = m.layout.block(m.layout.find("geometry"));
    arm = withErrors(m.arm, p.segment(g.offset, g.size()));
  }
  if (const auto [t, t_off] = findEffect<Thermal>(m); t) {
    const double scale = 1.0 + p[t_off] * deltaTemperature(*t, s);
    for (DhRow& r : arm.joints) {
      r.a_m *= scale;
      r.d_m *= scale;
      r.xyz_m *= scale;  // the URDF convention's lengths (zero in the DH conventions)
    }
  }
  return arm;
}

Eigen::Isometry3d flangePose(const KinematicModel& m, const Eigen::VectorXd& p, const JointSample& s) {
  checkSizes(m, p, s);
  return forwardKinematics(effectiveArm(m, p, s), s.q_rad + jointCorrections(m, p, s));
}

Eigen::Isometry3d predictMarkerPose(const KinematicModel& m, const Eigen::VectorXd& p, const JointSample& s,
                                    Eigen::MatrixXd* J_e_p, Eigen::MatrixXd* J_e_q) {
  checkSizes(m, p, s);
  const int n = m.arm.numJoints();
  Eigen::MatrixXd J_dq_p;
  const Eigen::VectorXd q = s.q_rad + jointCorrectionsImpl(m, p, s, J_e_p ? &J_dq_p : nullptr);
  const Arm arm = effectiveArm(m, p, s);

  // The chain's factors: world_T_base = W0 X_b; D; F; flange_T_marker = M0 X_m; Y (mount).
  const int b_blk = frameBlockIndex(m, "base", m.base, s.session);
  const int m_blk = frameBlockIndex(m, "marker", m.marker, s.session);
  const int y_blk = s.session > 0 ? m.layout.find("mount", s.session) : -1;
  const auto [drift, d_off] = findEffect<Drift>(m);
  const auto seg = [&](int blk) { return p.segment(m.layout.block(blk).offset, 6); };

  const Eigen::Isometry3d W = b_blk >= 0 ? m.baseStart(s.session) * frameDelta(seg(b_blk)) : m.baseStart(s.session);
  Eigen::Isometry3d D = Eigen::Isometry3d::Identity();
  Eigen::VectorXd d_tw(6);
  double dt = 0.0;
  if (drift) {
    dt = deltaTime(*drift, s);
    d_tw << dt * p.segment<3>(d_off), dt * p.segment<3>(d_off + 3);
    D = frameDelta(d_tw);
  }
  const Eigen::Isometry3d F = forwardKinematics(arm, q);
  const Eigen::Isometry3d M = m_blk >= 0 ? m.markerStart(s.session) * frameDelta(seg(m_blk)) : m.markerStart(s.session);
  const Eigen::Isometry3d Y = y_blk >= 0 ? frameDelta(seg(y_blk)) : Eigen::Isometry3d::Identity();
  const Eigen::Isometry3d MY = M * Y;
  const Eigen::Isometry3d world_T_marker = W * D * F * MY;
  if (!J_e_p && !J_e_q) return world_T_marker;

  // Flange-frame columns of every DH parameter (theta columns double as the joints' columns), moved
  // to the marker frame.
  const Matrix6d Ad_marker_flange = adjoint(MY.inverse());
  const Matrix6Xd J_geo = Ad_marker_flange * identificationJacobian(arm, q, ErrorFrame::kTool);
  Matrix6Xd J_q(6, n);
  for (int j = 0; j < n; ++j) J_q.col(j) = J_geo.col(paramIndex(arm, j, kTheta));
  if (J_e_q) *J_e_q = J_q;
  if (!J_e_p) return world_T_marker;

  Eigen::MatrixXd& J = *J_e_p;
  J = J_q * J_dq_p;  // joint-angle effects
  if (b_blk >= 0) {
    J.middleCols(m.layout.block(b_blk).offset, 6) += adjoint((D * F * MY).inverse()) * frameDeltaJacobian(seg(b_blk));
  }
  if (m_blk >= 0) J.middleCols(m.layout.block(m_blk).offset, 6) += adjoint(Y.inverse()) * frameDeltaJacobian(seg(m_blk));
  if (y_blk >= 0) J.middleCols(m.layout.block(y_blk).offset, 6) += frameDeltaJacobian(seg(y_blk));
  if (drift) J.middleCols(d_off, 6) += adjoint((F * MY).inverse()) * frameDeltaJacobian(d_tw) * dt;

  // Geometry: lengths enter as (nominal + error) (1 + alpha dT).
  const auto [thermal, t_off] = findEffect<Thermal>(m);
  const double dT = thermal ? deltaTemperature(*thermal, s) : 0.0;
  const double expansion = thermal ? 1.0 + p[t_off] * dT : 1.0;
  if (m.geometry) {
    const int g = m.layout.block(m.layout.find("geometry")).offset;
    for (int i = 0; i < m.arm.numParams(); ++i) {
      J.col(g + i) += isAngleParam(m.arm, i) ? J_geo.col(i) : Matrix6Xd(expansion * J_geo.col(i));
    }
  }
  if (thermal) {
    // d/d alpha of the scaled lengths: dT (a + da) and dT (d + dd) along their own columns; the
    // unscaled lengths are the effective ones divided by the expansion.
    auto col = J.col(t_off);
    for (int j = 0; j < n; ++j) {
      if (arm.convention == DhConvention::kUrdf) {
        for (int a = 0; a < 3; ++a) col += (dT / expansion) * arm.joints[j].xyz_m[a] * J_geo.col(paramIndex(arm, j, ParamKind(kOx + a)));
      } else {
        col += (dT / expansion) * (arm.joints[j].a_m * J_geo.col(paramIndex(arm, j, kA)) + arm.joints[j].d_m * J_geo.col(paramIndex(arm, j, kD)));
      }
    }
  }
  return world_T_marker;
}

FoldedModel foldParameters(const KinematicModel& m, const Eigen::VectorXd& p) {
  if (p.size() != m.layout.size()) throw std::invalid_argument("foldParameters: wrong parameter count");
  KinematicModel out = m;
  if (m.geometry) {
    const ParamBlock& g = m.layout.block(m.layout.find("geometry"));
    out.arm = withErrors(m.arm, p.segment(g.offset, g.size()));
  }
  const auto foldFrames = [&](const std::string& name, FrameSharing sharing, std::vector<Eigen::Isometry3d>& frames) {
    for (std::size_t k = 0; k < frames.size(); ++k) {
      const int blk = frameBlockIndex(m, name, sharing, static_cast<int>(k));
      if (blk >= 0) frames[k] = frames[k] * frameDelta(p.segment(m.layout.block(blk).offset, 6));
    }
  };
  foldFrames("base", m.base, out.world_T_base);
  foldFrames("marker", m.marker, out.flange_T_marker);
  Eigen::VectorXd q = Eigen::VectorXd::Zero(p.size());
  for (const ParamBlock& b : m.layout.blocks()) {
    if (b.effect != "base" && b.effect != "marker" && b.effect != "geometry") q.segment(b.offset, b.size()) = p.segment(b.offset, b.size());
  }
  return {std::move(out), std::move(q)};
}

}  // namespace orbcal::sim
