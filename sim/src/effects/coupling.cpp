// coupling: a coupled transmission, joint i's angle off in proportion to joint j's (a differential
// wrist, cables or belts routed through an upstream joint, a controller's wrong coupling matrix).
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/model.hpp"

namespace orbcal::sim {
namespace {

/// joints = [i1, j1, i2, j2, ...]: pairs (joint whose angle is off, joint whose angle it follows).
class CouplingKind final : public EffectKind {
 public:
  std::string name() const override { return "coupling"; }
  std::string words(const Effect& e) const override {
    std::string s = "a coupled transmission (";
    for (std::size_t k = 0; k + 1 < e.joints().size(); k += 2) {
      s += (k ? "; " : "") + std::string("joint ") + std::to_string(e.joints()[k] + 1) + " off in proportion to joint " +
           std::to_string(e.joints()[k + 1] + 1) + "'s angle";
    }
    return s + ")";
  }
  std::string physics() const override {
    return "a transmission routed through another joint (a differential wrist, cables or belts passing an upstream joint) "
           "turns joint i by k q_j when joint j turns, unless the controller's coupling matrix is exact: dq_i = k_ij q_j";
  }
  void check(const Effect& e, int num_joints, const std::string& what) const override {
    EffectKind::check(e, num_joints, what);
    if (e.joints().size() % 2 != 0) throw InputError(what + ": coupling takes pairs of joints i,j (joint i off by k q_j)");
    for (std::size_t k = 0; k < e.joints().size(); k += 2) {
      if (e.joints()[k] == e.joints()[k + 1]) {
        throw InputError(what + ": coupling of a joint to itself is the scale effect (scale:" + std::to_string(e.joints()[k] + 1) + ")");
      }
    }
  }
  std::vector<std::string> keys(const Effect& e) const override {
    std::vector<std::string> k;
    for (std::size_t i = 0; i + 1 < e.joints().size(); i += 2) {
      k.push_back(name() + ":" + std::to_string(e.joints()[i] + 1) + "," + std::to_string(e.joints()[i + 1] + 1));
    }
    return k;
  }
  std::vector<DrivingVariable> drivingVariables(const Effect& e, const Arm& arm) const override {
    std::vector<DrivingVariable> v;  // joint i off by k q_j: q_j drives it
    for (std::size_t k = 0; k + 1 < e.joints().size(); k += 2) v.push_back(angleDriver(arm, e.joints()[k + 1]));
    return v;
  }
  std::vector<ParamBlock> blocks(const Effect& e, const Arm&, int) const override {
    ParamBlock b;
    b.effect = name();
    b.joints = e.joints();
    // 2e-4 rad/rad: the size of the scale errors of industrial joints, which a coupling term resembles.
    for (std::size_t k = 0; k + 1 < e.joints().size(); k += 2) {
      b.params.push_back({"k" + std::to_string(e.joints()[k] + 1) + "_" + std::to_string(e.joints()[k + 1] + 1), "1", "ppm", 1e6,
                          2e-4, Quantity::kOther});
    }
    return {b};
  }
  void addJointCorrection(const Effect&, const ParamBlock& b, const Eigen::VectorXd& p, const JointSample& s, const Arm&,
                          Eigen::VectorXd& dq, JointCorrectionJacobian* J) const override {
    for (std::size_t k = 0; k + 1 < b.joints.size(); k += 2) {
      const int i = b.joints[k], j = b.joints[k + 1], col = b.offset + static_cast<int>(k / 2);
      dq[i] += p[col] * s.q_rad[j];
      if (J) J->add(i, col, s.q_rad[j]);
    }
  }
  std::string correctionFormula(const Effect&, const ParamBlock& b, const Arm&) const override {
    std::string f;
    for (std::size_t k = 0; k + 1 < b.joints.size(); k += 2) {
      f += (k ? "; dq" : "dq") + std::to_string(b.joints[k] + 1) + " = " + b.params[k / 2].name + " * q" + std::to_string(b.joints[k + 1] + 1);
    }
    return f;
  }
  std::vector<Effect> candidates(const CandidateContext& c) const override {
    std::vector<Effect> out;
    for (int i = 0; i < c.joints; ++i) {
      for (int j = 0; j < c.joints; ++j) {
        if (i != j) out.emplace_back(*this, std::vector<int>{i, j});
      }
    }
    return out;
  }
  std::pair<std::string, std::string> revealingVariable(const Effect& e, const Arm& arm) const override {
    return angleVariable(arm, e.joints()[1]);
  }
  std::string separateBy() const override {
    return "move each joint alone from a reference configuration, so that every joint's angle varies independently";
  }
};

}  // namespace

const EffectKind& couplingKind() {
  static const CouplingKind k;
  return k;
}

}  // namespace orbcal::sim
