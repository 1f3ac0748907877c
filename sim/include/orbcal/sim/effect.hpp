#pragma once
// The effect catalog: one type per physical cause, each in one file of sim/src/effects/ and one line
// of the list in sim/src/effects/catalog.cpp. A kind carries everything orbcal knows of its cause:
// its name and people's words, its parameters with units and typical sizes (ParamBlock), its forward
// model and analytic Jacobian, what it reads (torques, temperature, time, approach directions, masses,
// sessions), the variable that reveals it in residuals, the measurement that tells it from its
// look-alikes, and the candidates diagnose tests on a given dataset. Estimators, diagnose, reports and
// files read these; none of them switches on an effect's name.
//
// A cause enters the model's chain (sim/model.hpp) in one or more of three ways:
//  1. a joint-angle correction dq(p, s) and d dq / dp (compliance, cyclic, scale, backlash, coupling);
//  2. a rigid perturbation X = frameDelta(xi(p, s)) inserted at a place of the chain: after the base
//     frame (drift), at a link's far end or the flange (link bending), after the marker frame (mount);
//  3. a scale of the arm's lengths (thermal).
#include <Eigen/Core>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "orbcal/sim/arm.hpp"
#include "orbcal/sim/sample.hpp"

namespace orbcal::sim {

struct ParamBlock;
struct ParamInfo;
class EffectKind;

/// A variable an effect's correction is a function of (a joint's torque or angle, the temperature, the
/// time): the range of the data it was fitted on is recorded over it (model.yaml), evaluations say where
/// new data leave that range, and diagnose validates by holding out its extremes.
struct DrivingVariable {
  std::string column;  ///< its name in model.yaml and residuals.csv, in display units: "tau4_Nm", "q3_deg", "temperature_C"
  std::string name;    ///< people's words: "joint 4 torque"
  std::string unit;    ///< display unit: "N m", "deg", "mm", "N", "degC", "s"
  double scale = 1.0;  ///< display value = SI value * scale
  /// Which samples carry the largest load: the largest |x| (a torque or force, whose sign is a direction),
  /// both ends (an angle, a temperature), or the largest x (time: the latest).
  enum class Extremes { kMagnitude, kBothEnds, kUpper };
  Extremes extremes = Extremes::kBothEnds;
  std::function<double(const JointSample&)> value;  ///< SI
};

/// The range [lo, hi] (display units) a driving variable covered in the data an effect was fitted on.
struct FittedRange {
  std::string column;  ///< DrivingVariable::column
  double lo = 0.0, hi = 0.0;
};

/// One cause of the catalog on given joints: a kind plus what it is applied to. Joints are numbered
/// from 0 inside the code and from 1 wherever people read or write them.
class Effect {
 public:
  /// `order`: the kind's order (cyclic: number of harmonics; compliance: polynomial degree 1 or 3;
  /// 0: the kind's default). `reference`: the covariate value at which the effect is zero (thermal:
  /// degC; drift: s); NaN: the kind's default.
  Effect(const EffectKind& kind, std::vector<int> joints = {}, int order = 0,
         double reference = std::numeric_limits<double>::quiet_NaN());
  /// No effect yet (a placeholder to assign to; kind() must not be called on it).
  Effect() = default;
  /// An empirical effect's variable range [lo, hi] (SI): the data it was fitted on, its basis's domain
  /// and the range outside which it must not be trusted.
  Effect withRange(double lo, double hi) const;
  const EffectKind& kind() const { return *kind_; }
  const std::string& name() const;
  const std::vector<int>& joints() const { return joints_; }
  int order() const { return order_; }
  double reference() const { return reference_; }
  double lo() const { return lo_; }
  double hi() const { return hi_; }
  /// "compliance:2,4", "cyclic:3/4", "coupling:3,2" (parseEffect's syntax).
  std::string spec() const;
  /// The ranges of its driving variables over the data it was fitted on (recordFittedRanges); empty
  /// where not recorded (an effect not fitted, a model file written before ranges were recorded).
  Effect withFittedRanges(std::vector<FittedRange> ranges) const;
  const std::vector<FittedRange>& fittedRanges() const { return ranges_; }

 private:
  const EffectKind* kind_ = nullptr;
  std::vector<int> joints_;
  int order_ = 0;
  double reference_ = 0.0;
  double lo_ = 0.0, hi_ = 0.0;
  std::vector<FittedRange> ranges_;
};

/// What an effect reads besides the joint readings.
struct EffectNeeds {
  bool torque = false;       ///< joint torques (measured, or from the robot's masses)
  bool masses = false;       ///< the robot's mass model itself (loads of the links)
  bool temperature = false;
  bool time = false;
  bool direction = false;    ///< the approach direction of every joint
  bool sessions = false;     ///< more than one session
};

/// What a dataset offers the candidates of diagnose.
struct CandidateContext {
  const Arm* arm = nullptr;   ///< the nominal arm (geometry and masses)
  int joints = 0;
  bool torque = false, masses = false, temperature = false, time = false, direction = false;
  int sessions = 1;
  bool shared_marker = true;  ///< the marker frame is shared between sessions (else mount is absorbed)
  int harmonics = 2;          ///< orders of the cyclic candidates (diagnose's option)
  int max_order = 6;          ///< the highest order a candidate may search (cyclic: harmonics)
};

/// A rigid perturbation an effect inserts in the chain: X = frameDelta(xi), xi = [t; w] in the frame
/// at `place`, and d xi / d p over the effect's block (6 x block size).
struct ChainInsert {
  enum class Place { kBase, kLink, kFlange, kMarker };
  Place place = Place::kBase;
  int link = -1;  ///< kLink: X is right-multiplied onto chainFrames()[link + 1], after link `link`'s transform (0-based)
  Eigen::Matrix<double, 6, 1> xi = Eigen::Matrix<double, 6, 1>::Zero();
  Eigen::MatrixXd J_xi_p;  ///< 6 x block size
  int offset = 0;          ///< the block's first parameter in p
};

/// d dq / d p of one sample's joint corrections, kept as its entries: each correction's parameter moves
/// one joint, so the dense n x P matrix a flexible model had per sample was almost all zeros, cleared
/// and scanned at every evaluation.
class JointCorrectionJacobian {
 public:
  struct Entry {
    int joint = 0;
    int param = 0;
    double value = 0.0;
  };
  void clear() { entries_.clear(); }
  /// d dq[joint] / d p[param] += value.
  void add(int joint, int param, double value) { entries_.push_back({joint, param, value}); }
  const std::vector<Entry>& entries() const { return entries_; }

 private:
  std::vector<Entry> entries_;
};

/// The model's nominal arm at a sample's joint readings, where chain inserts are evaluated: its frames
/// (chainFrames) computed when an effect first asks and shared by the sample's other effects (a
/// flexible model bends every link: one chain, not one per link, at each evaluation).
class NominalChain {
 public:
  NominalChain(const Arm& arm, const Eigen::VectorXd& q) : arm_(arm), q_(q) {}
  const Arm& arm() const { return arm_; }
  const Eigen::VectorXd& q() const { return q_; }
  const std::vector<Eigen::Isometry3d>& frames() const;

 private:
  const Arm& arm_;
  const Eigen::VectorXd& q_;
  mutable std::vector<Eigen::Isometry3d> frames_;  ///< empty until asked
};

/// The catalog's interface. Kinds are stateless singletons (catalog()).
class EffectKind {
 public:
  virtual ~EffectKind() = default;
  virtual std::string name() const = 0;
  /// People's words: "compliance of joint 2 (deflection under its torque)"; `of` is " of joint 2".
  virtual std::string words(const Effect& e) const = 0;
  /// The physical reason, one or two sentences for the manual and --help.
  virtual std::string physics() const = 0;
  /// Its parameters' sign convention, one sentence for reports ("" where the signs need none).
  virtual std::string signConvention() const { return ""; }
  /// The sign physics gives parameter `i` of block `b` on every real arm (+1, -1; a compliance is
  /// positive: a joint yields to its load), 0 where either sign occurs. The simulator draws with it.
  virtual int physicalSign(const ParamBlock& /*b*/, int /*i*/) const { return 0; }
  /// Empirical, not a physical cause: a smooth function fitted where no cause of the catalog explains
  /// the structure. Its spec carries the variable's range ("@lo..hi", SI).
  virtual bool empirical() const { return false; }
  /// For an empirical kind: the value of its variable at sample s (rad, N m), and its label.
  virtual double variable(const Effect&, const JointSample&) const { return 0.0; }
  /// Whether the effect takes joints ("compliance:2"), and how many at least.
  virtual bool takesJoints() const { return true; }
  /// Whether it applies to a prismatic joint, whose variable is a length (scale, backlash, a lead
  /// screw's cyclic error, compliance along the axis do); fitsJointTypes refuses the others there.
  virtual bool acceptsPrismatic() const { return false; }
  /// Its default order (Effect::order() 0 means this) and the orders it accepts ("/K"); 0 0: none.
  virtual int defaultOrder() const { return 0; }
  /// The covariate value at which the effect is zero, where it reads one (thermal: 20 degC).
  virtual double defaultReference() const { return 0.0; }
  virtual int maxOrder() const { return 0; }
  /// Throws InputError (prefixed by `what`) when the joints or order do not fit the kind.
  virtual void check(const Effect& e, int num_joints, const std::string& what) const;
  /// What may occur once in a model ("compliance:2"; a global effect: its name). Default: one key per joint.
  virtual std::vector<std::string> keys(const Effect& e) const;
  virtual EffectNeeds needs() const { return {}; }
  /// The variables its correction is a function of (none by default: a mount change, a backlash's
  /// direction). One place per kind: ranges, extrapolation warnings and diagnose's extremes folds read it.
  virtual std::vector<DrivingVariable> drivingVariables(const Effect& /*e*/, const Arm& /*arm*/) const { return {}; }
  /// Parameter blocks (one per effect; mount: one per session after the first).
  virtual std::vector<ParamBlock> blocks(const Effect& e, const Arm& arm, int num_sessions) const = 0;

  // The forward model (zero by default) and its Jacobian, per block.
  virtual void addJointCorrection(const Effect& e, const ParamBlock& b, const Eigen::VectorXd& p, const JointSample& s,
                                  const Arm& arm, Eigen::VectorXd& dq, JointCorrectionJacobian* J_dq_p) const;
  /// The joint-angle correction of addJointCorrection written out for programs outside orbcal (the
  /// effects export, sim/export.hpp): "dq2 = -(c2 * tau2)", in the names of block `b`'s parameters (SI)
  /// and the variables qN (joint N's reading, rad; m for a prismatic joint of `arm`), tauN (its actuator's
  /// torque, N m; force, N) and dirN (its approach direction, +1/-1/0), joints from 1, and the constant pi;
  /// one formula per joint, "; " between them. "" for a kind that is no joint-angle correction.
  virtual std::string correctionFormula(const Effect& /*e*/, const ParamBlock& /*b*/, const Arm& /*arm*/) const { return ""; }
  /// Rigid inserts (appended to `out`), evaluated on the model's nominal arm at the joint readings
  /// (`chain`: what the fitted geometry and joint corrections would change in them is second order), so
  /// that their Jacobian columns are exact.
  virtual void addChainInserts(const Effect& e, const ParamBlock& b, const Eigen::VectorXd& p, const JointSample& s,
                               const NominalChain& chain, std::vector<ChainInsert>& out) const;
  /// Length scale (1 + ...) and its derivative over the block's first parameter; {1, 0} by default.
  virtual std::pair<double, double> lengthScale(const Effect& e, const ParamBlock& b, const Eigen::VectorXd& p,
                                                const JointSample& s) const;

  // Diagnosis.
  /// The effects of this kind diagnose tests on a dataset (one per joint, pair, link ...).
  virtual std::vector<Effect> candidates(const CandidateContext& c) const = 0;
  /// The variable that reveals it on `arm`: {residuals.csv column, axis label}, e.g. {"tau2_Nm", "joint 2
  /// torque (N m)"}; a joint's value and effort in the units of its type (sim::jointEdgeColumn).
  virtual std::pair<std::string, std::string> revealingVariable(const Effect& e, const Arm& arm) const = 0;
  /// The measurement that separates it from its look-alikes.
  virtual std::string separateBy() const = 0;
  /// The effect with what it takes from the data it will be fitted to (compliance: the torque scale its
  /// parameters' typical magnitudes follow), predictions unchanged; the effect itself by default.
  virtual Effect adaptTo(const Effect& e, const std::vector<JointSample>& /*samples*/) const { return e; }
  /// Checks that a sample carries what the effect reads; throws std::invalid_argument otherwise.
  virtual void requireCovariates(const JointSample& s, int num_joints) const;

 protected:
  /// The revealing variables of residuals.csv: joint j's value {"q3_deg", "joint 3 angle (deg)"} and
  /// effort {"tau3_Nm", "joint 3 torque (N m)"} (j from 0; a prismatic joint's in mm and N).
  static std::pair<std::string, std::string> angleVariable(const Arm& arm, int j);
  static std::pair<std::string, std::string> torqueVariable(const Arm& arm, int j);
  /// Joint j's value (angle or position) and effort (torque or force) as driving variables (j from 0).
  static DrivingVariable angleDriver(const Arm& arm, int j);
  static DrivingVariable torqueDriver(const Arm& arm, int j);
  /// What separates causes that follow a joint's angle (cyclic, scale, coupling).
  static std::string widerRangeAdvice();
  /// One effect per joint (the usual candidates of a joint effect).
  std::vector<Effect> perJointCandidates(int joints) const;
  /// The formula of a correction linear in one variable per joint, one parameter each (block order):
  /// "dq2 = s2 * q2; dq4 = s4 * q4" for variable "q" (the variable's name is followed by the joint, from 1).
  static std::string perJointLinearFormula(const ParamBlock& b, const std::string& variable);
  /// One block over the effect's joints, `params` adding each joint's parameters (joint as "2").
  ParamBlock jointBlock(const Effect& e, const std::function<void(ParamBlock&, const std::string&)>& params) const;
  /// The same with the joint's index (from 0) too, for parameters whose unit follows the joint's type.
  ParamBlock jointBlockOf(const Effect& e, const std::function<void(ParamBlock&, const std::string&, int)>& params) const;
};

/// Every kind of the catalog, in its order.
const std::vector<const EffectKind*>& catalog();
/// The kind named `name`, or null.
const EffectKind* findEffectKind(const std::string& name);

/// The sign conventions of the kinds among `effects`, each kind's once, one paragraph per kind
/// ("" when none has one): what a report on a model with these effects says beside its parameters.
std::string signConventions(const std::vector<Effect>& effects);

/// False when the effect acts on a prismatic joint of `arm` and its kind does not apply to one.
bool fitsJointTypes(const Effect& e, const Arm& arm);
/// Throws InputError "<what>: <effect> does not apply to joint N, a prismatic joint (...)" unless fitsJointTypes.
void checkJointTypes(const Effect& e, const Arm& arm, const std::string& what);

/// Records on `e` the range each of its driving variables covers in `samples` (the data it is fitted on).
Effect recordFittedRanges(const Effect& e, const Arm& arm, const std::vector<JointSample>& samples);
/// The ranges to check new data against: the recorded ones; for an empirical effect without them, its
/// basis's domain [lo, hi] (its spec's).
std::vector<FittedRange> trustedRanges(const Effect& e, const Arm& arm);

/// How far samples leave one driving variable's fitted range.
struct RangeExcess {
  std::string effect;       ///< the effect's spec
  bool empirical = false;   ///< an empirical correction (EffectKind::empirical): not to be trusted outside
  DrivingVariable variable;
  FittedRange range;        ///< display units
  std::vector<double> excess;  ///< per sample: display units beyond the range (0 inside)
  int outside = 0;          ///< samples beyond it
  double max_excess = 0.0;  ///< display units
};
/// One entry per driving variable with a range of each effect of `effects`, in order.
std::vector<RangeExcess> rangeExcesses(const std::vector<Effect>& effects, const Arm& arm, const std::vector<JointSample>& samples);
/// "compliance:4/3: 40 of 198 samples leave joint 4 torque's fitted range -2.1..21.4 N m, by up to 13.2 N m: its
/// prediction there is an extrapolation" (the empirical corrections': "is not to be trusted there").
std::string rangeExcessText(const RangeExcess& r);

/// " of joint 2", " of joints 2 and 4" (people's words for joints numbered from 0).
std::string ofJoints(const std::vector<int>& joints);

}  // namespace orbcal::sim
