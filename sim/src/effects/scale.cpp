// scale: an encoder or gear-ratio error, the joint's reading off by a fixed fraction of its angle.
#include "orbcal/sim/model.hpp"

namespace orbcal::sim {
namespace {

class ScaleKind final : public EffectKind {
 public:
  std::string name() const override { return "scale"; }
  std::string words(const Effect& e) const override { return "an encoder scale error" + ofJoints(e.joints()); }
  std::string physics() const override {
    return "the gear ratio or encoder resolution the controller assumes differs from the real one: dq = s q";
  }
  bool acceptsPrismatic() const override { return true; }  // a lead screw's pitch or an encoder's scale: dq = s q in m
  std::vector<DrivingVariable> drivingVariables(const Effect& e, const Arm& arm) const override {
    std::vector<DrivingVariable> v;
    for (const int j : e.joints()) v.push_back(angleDriver(arm, j));
    return v;
  }
  std::vector<ParamBlock> blocks(const Effect& e, const Arm&, int) const override {
    // 2e-4 (200 ppm): the order of the joint-scale errors identified on industrial arms.
    return {jointBlock(e, [](ParamBlock& b, const std::string& j) {
      b.params.push_back({"s" + j, "1", "ppm", 1e6, 2e-4, Quantity::kOther});
    })};
  }
  void addJointCorrection(const Effect&, const ParamBlock& b, const Eigen::VectorXd& p, const JointSample& s, const Arm&,
                          Eigen::VectorXd& dq, JointCorrectionJacobian* J) const override {
    for (std::size_t i = 0; i < b.joints.size(); ++i) {
      const int j = b.joints[i], col = b.offset + static_cast<int>(i);
      dq[j] += p[col] * s.q_rad[j];
      if (J) J->add(j, col, s.q_rad[j]);
    }
  }
  std::string correctionFormula(const Effect&, const ParamBlock& b, const Arm&) const override { return perJointLinearFormula(b, "q"); }
  std::vector<Effect> candidates(const CandidateContext& c) const override { return perJointCandidates(c.joints); }
  std::pair<std::string, std::string> revealingVariable(const Effect& e, const Arm& arm) const override {
    return angleVariable(arm, e.joints().front());
  }
  std::string separateBy() const override { return widerRangeAdvice(); }
};

}  // namespace

const EffectKind& scaleKind() {
  static const ScaleKind k;
  return k;
}

}  // namespace orbcal::sim
