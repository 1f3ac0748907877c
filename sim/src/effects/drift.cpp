// drift: the base (or the measuring system) creeps linearly with time: a warming mount, a settling
// tripod, a tracker's slow drift.
#include <stdexcept>

#include "orbcal/sim/model.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::sim {
namespace {

class DriftKind final : public EffectKind {
 public:
  std::string name() const override { return "drift"; }
  std::string words(const Effect&) const override { return "a drift of the base with time"; }
  std::string physics() const override {
    return "the base moves against the measuring system at a constant rate: a warming mount or floor, a settling tripod; "
           "D(t) = (Exp((t - t0) w), (t - t0) v)";
  }
  bool takesJoints() const override { return false; }
  EffectNeeds needs() const override {
    EffectNeeds n;
    n.time = true;
    return n;
  }
  std::vector<DrivingVariable> drivingVariables(const Effect&, const Arm&) const override {
    DrivingVariable v;
    v.column = "time_s";
    v.name = "time";
    v.unit = "s";
    v.extremes = DrivingVariable::Extremes::kUpper;  // a drift extrapolates forward in time
    v.value = [](const JointSample& s) { return s.time_s; };
    return {v};
  }
  std::vector<ParamBlock> blocks(const Effect&, const Arm&, int) const override {
    ParamBlock b;
    b.effect = name();
    for (const char* a : {"x", "y", "z"}) {
      b.params.push_back({std::string("drift_v") + a, "m/s", "mm/h", 3.6e6, 1e-3 / 3600.0, Quantity::kOther});
    }
    for (const char* a : {"x", "y", "z"}) {
      b.params.push_back({std::string("drift_w") + a, "rad/s", "deg/h", kRadToDeg * 3600.0, 0.01 * kDegToRad / 3600.0,
                          Quantity::kOther});
    }
    return {b};
  }
  void addChainInserts(const Effect& e, const ParamBlock& b, const Eigen::VectorXd& p, const JointSample& s, const NominalChain&,
                       std::vector<ChainInsert>& out) const override {
    const double dt = s.time_s - e.reference();
    ChainInsert c;
    c.place = ChainInsert::Place::kBase;
    c.xi = dt * p.segment<6>(b.offset);
    c.J_xi_p = dt * Eigen::MatrixXd::Identity(6, 6);
    c.offset = b.offset;
    out.push_back(std::move(c));
  }
  void requireCovariates(const JointSample& s, int) const override {
    if (!s.hasTime()) throw std::invalid_argument("the drift effect needs a time for every sample");
  }
  std::vector<Effect> candidates(const CandidateContext& c) const override {
    return c.time ? std::vector<Effect>{Drift{}} : std::vector<Effect>{};
  }
  std::pair<std::string, std::string> revealingVariable(const Effect&, const Arm&) const override { return {"time_s", "time (s)"}; }
  std::string separateBy() const override { return "repeat a reference configuration throughout the run"; }
};

}  // namespace

const EffectKind& driftKind() {
  static const DriftKind k;
  return k;
}

}  // namespace orbcal::sim
