// backlash: lost motion in a transmission; the joint settles on one side of the play or the other
// depending on the direction it approached from.
#include <stdexcept>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/sim/model.hpp"

namespace orbcal::sim {
namespace {

class BacklashKind final : public EffectKind {
 public:
  std::string name() const override { return "backlash"; }
  std::string words(const Effect& e) const override { return "backlash" + ofJoints(e.joints()); }
  std::string physics() const override {
    return "play between gear teeth: the output stops short by b in the direction the joint came from, dq = b d with "
           "d = +1/-1 the approach direction";
  }
  EffectNeeds needs() const override {
    EffectNeeds n;
    n.direction = true;
    return n;
  }
  bool acceptsPrismatic() const override { return true; }
  std::vector<ParamBlock> blocks(const Effect& e, const Arm& arm, int) const override {
    // A prismatic joint's play is a length: 0.02 mm, the axial play of a preloaded ball screw's nut
    // is of that order (tens of micrometres at most).
    return {jointBlockOf(e, [&](ParamBlock& b, const std::string& j, int joint) {
      b.params.push_back(arm.isPrismatic(joint) ? lengthParam("b" + j, 2e-5) : angleParam("b" + j, 0.01 * kDegToRad));
    })};
  }
  void addJointCorrection(const Effect&, const ParamBlock& b, const Eigen::VectorXd& p, const JointSample& s, const Arm&,
                          Eigen::VectorXd& dq, JointCorrectionJacobian* J) const override {
    for (std::size_t i = 0; i < b.joints.size(); ++i) {
      const int j = b.joints[i], col = b.offset + static_cast<int>(i);
      dq[j] += p[col] * s.direction[j];
      if (J) J->add(j, col, s.direction[j]);
    }
  }
  std::string correctionFormula(const Effect&, const ParamBlock& b, const Arm&) const override { return perJointLinearFormula(b, "dir"); }
  void requireCovariates(const JointSample& s, int) const override {
    if (s.direction.size() != s.q_rad.size()) {
      throw std::invalid_argument("the backlash effect needs the approach direction of every joint");
    }
  }
  std::vector<Effect> candidates(const CandidateContext& c) const override {
    return c.direction ? perJointCandidates(c.joints) : std::vector<Effect>{};
  }
  std::pair<std::string, std::string> revealingVariable(const Effect& e, const Arm&) const override {
    const std::string n = std::to_string(e.joints().front() + 1);
    return {"dir" + n, "joint " + n + " approach direction"};
  }
  std::string separateBy() const override { return "approach the same configurations from both directions"; }
};

}  // namespace

const EffectKind& backlashKind() {
  static const BacklashKind k;
  return k;
}

}  // namespace orbcal::sim
