// The Effect value type, the EffectKind defaults and the catalog's list.
#include "orbcal/sim/effect.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/effect_syntax.hpp"
#include "orbcal/sim/model.hpp"

namespace orbcal::sim {

// The catalog: one line per kind, each defined in its own file (sim/src/effects/NAME.cpp) as
// `const EffectKind& NAMEKind()`. The order is the order of diagnose's candidates and of listings.
#define ORBCAL_EFFECT_KINDS(X) \
  X(compliance) X(cyclic) X(scale) X(backlash) X(thermal) X(drift) X(mount) X(coupling) X(link_bending) X(empirical) X(empirical_torque)

#define ORBCAL_DECLARE_KIND(name) const EffectKind& name##Kind();
ORBCAL_EFFECT_KINDS(ORBCAL_DECLARE_KIND)
#undef ORBCAL_DECLARE_KIND

const std::vector<const EffectKind*>& catalog() {
#define ORBCAL_LIST_KIND(name) &name##Kind(),
  static const std::vector<const EffectKind*> kinds{ORBCAL_EFFECT_KINDS(ORBCAL_LIST_KIND)};
#undef ORBCAL_LIST_KIND
  return kinds;
}

std::string effectSyntax(const EffectKind& k) {
  return k.name() + (k.takesJoints() ? ":J,..." : "") + (k.maxOrder() > 0 ? "[/K]" : "");
}

std::string effectSyntaxList() {
  std::string list;
  for (const EffectKind* k : catalog()) list += (list.empty() ? "" : " ") + effectSyntax(*k);
  return list;
}

const EffectKind* findEffectKind(const std::string& name) {
  for (const EffectKind* k : catalog()) {
    if (k->name() == name) return k;
  }
  return nullptr;
}

std::string signConventions(const std::vector<Effect>& effects) {
  std::vector<const EffectKind*> seen;
  std::string out;
  for (const Effect& e : effects) {
    if (std::find(seen.begin(), seen.end(), &e.kind()) != seen.end()) continue;
    seen.push_back(&e.kind());
    const std::string text = e.kind().signConvention();
    if (!text.empty()) out += text + "\n\n";
  }
  return out;
}

Effect recordFittedRanges(const Effect& e, const Arm& arm, const std::vector<JointSample>& samples) {
  std::vector<FittedRange> ranges;
  for (const DrivingVariable& v : e.kind().drivingVariables(e, arm)) {
    FittedRange r{v.column, std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
    for (const JointSample& s : samples) {
      const double x = v.value(s) * v.scale;
      if (!std::isfinite(x)) continue;
      r.lo = std::min(r.lo, x);
      r.hi = std::max(r.hi, x);
    }
    if (r.lo <= r.hi) ranges.push_back(r);
  }
  return e.withFittedRanges(std::move(ranges));
}

std::vector<FittedRange> trustedRanges(const Effect& e, const Arm& arm) {
  if (!e.fittedRanges().empty() || !e.kind().empirical()) return e.fittedRanges();
  std::vector<FittedRange> out;
  for (const DrivingVariable& v : e.kind().drivingVariables(e, arm)) out.push_back({v.column, e.lo() * v.scale, e.hi() * v.scale});
  return out;
}

std::vector<RangeExcess> rangeExcesses(const std::vector<Effect>& effects, const Arm& arm, const std::vector<JointSample>& samples) {
  std::vector<RangeExcess> out;
  for (const Effect& e : effects) {
    const std::vector<FittedRange> ranges = trustedRanges(e, arm);
    for (const DrivingVariable& v : e.kind().drivingVariables(e, arm)) {
      const auto r = std::find_if(ranges.begin(), ranges.end(), [&](const FittedRange& f) { return f.column == v.column; });
      if (r == ranges.end()) continue;
      RangeExcess x{e.spec(), e.kind().empirical(), v, *r, {}, 0, 0.0};
      for (const JointSample& s : samples) {
        const double value = v.value(s) * v.scale;
        const double beyond = std::isfinite(value) ? std::max({0.0, r->lo - value, value - r->hi}) : 0.0;
        x.excess.push_back(beyond);
        x.outside += beyond > 0.0;
        x.max_excess = std::max(x.max_excess, beyond);
      }
      out.push_back(std::move(x));
    }
  }
  return out;
}

std::string rangeExcessText(const RangeExcess& r) {
  const auto num = [](double v) { return formatNumber("%.3g", v); };
  return r.effect + ": " + std::to_string(r.outside) + " of " + std::to_string(r.excess.size()) + " samples leave " +
         r.variable.name + "'s fitted range " + num(r.range.lo) + ".." + num(r.range.hi) + " " + r.variable.unit + ", by up to " +
         num(r.max_excess) + " " + r.variable.unit +
         (r.empirical ? ": this empirical correction is not to be trusted there"
                           : ": its prediction there is an extrapolation of what the data showed");
}

std::string ofJoints(const std::vector<int>& joints) {
  std::string js;
  for (std::size_t i = 0; i < joints.size(); ++i) {
    js += (i ? (i + 1 == joints.size() ? " and " : ", ") : "") + std::to_string(joints[i] + 1);
  }
  return (joints.size() > 1 ? " of joints " : " of joint ") + js;
}

// ---- Effect -------------------------------------------------------------------------------------

Effect::Effect(const EffectKind& kind, std::vector<int> joints, int order, double reference)
    : kind_(&kind),
      joints_(std::move(joints)),
      order_(order == 0 ? kind.defaultOrder() : order),
      reference_(std::isnan(reference) ? kind.defaultReference() : reference) {}

Effect Effect::withFittedRanges(std::vector<FittedRange> ranges) const {
  Effect e = *this;
  e.ranges_ = std::move(ranges);
  return e;
}

Effect Effect::withRange(double lo, double hi) const {
  Effect e = *this;
  e.lo_ = lo;
  e.hi_ = hi;
  return e;
}

const std::string& Effect::name() const {
  // Kinds are singletons: their names are computed once.
  static std::vector<std::pair<const EffectKind*, std::string>> names = [] {
    std::vector<std::pair<const EffectKind*, std::string>> n;
    for (const EffectKind* k : catalog()) n.emplace_back(k, k->name());
    return n;
  }();
  for (const auto& [k, n] : names) {
    if (k == kind_) return n;
  }
  throw std::logic_error("Effect: a kind outside the catalog");
}

std::string Effect::spec() const {
  std::string s = name();
  for (std::size_t i = 0; i < joints_.size(); ++i) s += (i == 0 ? ":" : ",") + std::to_string(joints_[i] + 1);
  if (kind_->maxOrder() > 0 && order_ != kind_->defaultOrder()) s += "/" + std::to_string(order_);
  if (kind_->empirical()) s += "@" + exactNumber(lo_) + ".." + exactNumber(hi_);
  return s;
}

// ---- EffectKind defaults ------------------------------------------------------------------------

void EffectKind::check(const Effect& e, int num_joints, const std::string& what) const {
  if (takesJoints() && e.joints().empty()) {
    throw InputError(what + ": " + name() + " needs joints, e.g. " + name() + ":2,4");
  }
  for (int j : e.joints()) {
    if (j < 0 || j >= num_joints) {
      throw InputError(what + ": " + name() + ": joint " + std::to_string(j + 1) + " is out of range 1.." + std::to_string(num_joints));
    }
  }
  if (maxOrder() > 0 && (e.order() < 1 || e.order() > maxOrder())) {
    throw InputError(what + ": " + name() + "'s order (/K) must be 1.." + std::to_string(maxOrder()));
  }
  if (empirical() && !(e.lo() < e.hi() && std::isfinite(e.lo()) && std::isfinite(e.hi()))) {
    throw InputError(what + ": " + name() + " needs its variable's range, @lo..hi with lo < hi (SI units)");
  }
}

std::vector<std::string> EffectKind::keys(const Effect& e) const {
  if (e.joints().empty()) return {name()};
  std::vector<std::string> k;
  for (int j : e.joints()) k.push_back(name() + ":" + std::to_string(j + 1));
  return k;
}

void EffectKind::addJointCorrection(const Effect&, const ParamBlock&, const Eigen::VectorXd&, const JointSample&, const Arm&,
                                    Eigen::VectorXd&, JointCorrectionJacobian*) const {}

void EffectKind::addChainInserts(const Effect&, const ParamBlock&, const Eigen::VectorXd&, const JointSample&, const NominalChain&,
                                 std::vector<ChainInsert>&) const {}

const std::vector<Eigen::Isometry3d>& NominalChain::frames() const {
  if (frames_.empty()) frames_ = chainFrames(arm_, q_);
  return frames_;
}

std::pair<double, double> EffectKind::lengthScale(const Effect&, const ParamBlock&, const Eigen::VectorXd&,
                                                  const JointSample&) const {
  return {1.0, 0.0};
}

void EffectKind::requireCovariates(const JointSample&, int) const {}

std::pair<std::string, std::string> EffectKind::angleVariable(const Arm& arm, int j) {
  return {jointEdgeColumn(arm, j), jointEdgeLabel(arm, j)};
}

std::pair<std::string, std::string> EffectKind::torqueVariable(const Arm& arm, int j) {
  return {jointEffortColumn(arm, j), jointEffortLabel(arm, j)};
}

DrivingVariable EffectKind::angleDriver(const Arm& arm, int j) {
  DrivingVariable v;
  v.column = jointEdgeColumn(arm, j);
  v.name = jointValueName(arm, j);
  v.unit = jointEdgeUnit(arm, j);
  v.scale = jointEdgeScale(arm, j);
  v.extremes = DrivingVariable::Extremes::kBothEnds;
  v.value = [j](const JointSample& s) { return s.q_rad[j]; };
  return v;
}

DrivingVariable EffectKind::torqueDriver(const Arm& arm, int j) {
  DrivingVariable v;
  v.column = jointEffortColumn(arm, j);
  v.name = jointEffortName(arm, j);
  v.unit = arm.isPrismatic(j) ? "N" : "N m";
  v.extremes = DrivingVariable::Extremes::kMagnitude;
  v.value = [j](const JointSample& s) { return s.hasTorque() ? s.tau_Nm[j] : 0.0; };
  return v;
}

std::string EffectKind::widerRangeAdvice() { return "move the joints over a wider range, with more distinct angles per joint"; }

std::vector<Effect> EffectKind::perJointCandidates(int joints) const {
  std::vector<Effect> c;
  for (int j = 0; j < joints; ++j) c.emplace_back(*this, std::vector<int>{j});
  return c;
}

std::string EffectKind::perJointLinearFormula(const ParamBlock& b, const std::string& variable) {
  std::string f;
  for (std::size_t i = 0; i < b.joints.size(); ++i) {
    const std::string n = std::to_string(b.joints[i] + 1);
    f += (i ? "; " : "") + ("dq" + n + " = " + b.params[i].name + " * " + variable + n);
  }
  return f;
}

ParamBlock EffectKind::jointBlockOf(const Effect& e, const std::function<void(ParamBlock&, const std::string&, int)>& params) const {
  ParamBlock b;
  b.effect = name();
  b.joints = e.joints();
  for (int j : e.joints()) params(b, std::to_string(j + 1), j);
  return b;
}

bool fitsJointTypes(const Effect& e, const Arm& arm) {
  if (e.kind().acceptsPrismatic()) return true;
  for (int j : e.joints()) {
    if (j < arm.numJoints() && arm.isPrismatic(j)) return false;
  }
  return true;
}

void checkJointTypes(const Effect& e, const Arm& arm, const std::string& what) {
  if (fitsJointTypes(e, arm)) return;
  for (int j : e.joints()) {
    if (j >= arm.numJoints() || !arm.isPrismatic(j)) continue;
    throw InputError(what + ": " + e.spec() + " does not apply to joint " + std::to_string(j + 1) +
                     ", a prismatic joint (there: scale, backlash, cyclic, compliance)");
  }
}

ParamBlock EffectKind::jointBlock(const Effect& e, const std::function<void(ParamBlock&, const std::string&)>& params) const {
  ParamBlock b;
  b.effect = name();
  b.joints = e.joints();
  for (int j : e.joints()) params(b, std::to_string(j + 1));
  return b;
}

}  // namespace orbcal::sim
