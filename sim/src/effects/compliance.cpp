// compliance: a joint that deflects under the torque it carries (harmonic drives, belts, gearboxes),
// linearly, or stiffening with load (degree 3: harmonic drives are softer near zero torque).
//
// Signs: tau_j is the torque joint j's actuator applies (sim/gravity.hpp: at rest tau_j = dU/dq_j, U the
// potential energy). The joint yields to its load, i.e. against that torque: the link stands at the
// reading plus dq_j = -(c_j tau_j + c3_j tau_j^3), so c_j = 1/k_j > 0 for a transmission of stiffness
// k_j (N m/rad): a joint that sags under gravity has a positive c.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "orbcal/sim/config.hpp"

#include "orbcal/sim/model.hpp"

namespace orbcal::sim {
namespace {

class ComplianceKind final : public EffectKind {
 public:
  std::string name() const override { return "compliance"; }
  std::string words(const Effect& e) const override {
    return (e.order() == 3 ? "stiffening compliance" : "compliance") + ofJoints(e.joints()) +
           (e.order() == 3 ? " (deflection -(c1 tau + c3 tau^3) under its torque)" : " (deflection under its torque)");
  }
  std::string physics() const override {
    return "a joint's transmission (harmonic drive, gearbox, belt) twists under the torque it carries, yielding to its load: "
           "dq = -c tau; harmonic drives stiffen with load, dq = -(c1 tau + c3 tau^3) (compliance:J/3)";
  }
  std::string signConvention() const override {
    return "Compliance signs: tau_j is the torque joint j's actuator applies about its axis (right-hand rule; at rest it holds "
           "the arm, tau_j = dU/dq_j with U the potential energy; a description's `sense: load` flips a sensor that reports "
           "the load's torque instead). The joint yields to its load: the link stands at the reading plus "
           "dq_j = -(c_j tau_j + c3_j tau_j^3), so c_j = 1/k_j is positive for a joint of stiffness k_j (N m/rad): positive c "
           "means the joint sags under gravity; c3_j < 0 where it stiffens with load.";
  }
  /// c_j > 0 (every real joint yields to its load); the cubic term takes either sign.
  int physicalSign(const ParamBlock& b, int i) const override {
    const int per = b.size() / std::max<int>(1, static_cast<int>(b.joints.size()));  // c, or c and c_cubic, per joint
    return i % per == 0 ? 1 : 0;
  }
  int defaultOrder() const override { return 1; }
  /// Effect::reference() of a compliance is the torque scale tau_s (N m) its typical magnitudes follow
  /// (not a zero point: the predictions do not depend on it). 50 N m: the gravity torques of a 7 kg,
  /// 1 m arm's shoulder.
  double defaultReference() const override { return 50.0; }
  /// tau_s from the data: the RMS of its joints' torques (the largest of them).
  Effect adaptTo(const Effect& e, const std::vector<JointSample>& samples) const override {
    double tau_s = 0.0;
    for (const int j : e.joints()) {
      double ss = 0.0;
      int n = 0;
      for (const JointSample& s : samples) {
        if (!s.hasTorque()) continue;
        ss += s.tau_Nm[j] * s.tau_Nm[j];
        ++n;
      }
      if (n > 0) tau_s = std::max(tau_s, std::sqrt(ss / n));
    }
    return tau_s > 0.0 ? Effect(*this, e.joints(), e.order(), tau_s).withRange(e.lo(), e.hi()) : e;
  }
  int maxOrder() const override { return 3; }
  void check(const Effect& e, int num_joints, const std::string& what) const override {
    EffectKind::check(e, num_joints, what);
    if (e.order() == 2) throw InputError(what + ": compliance's degree (/K) is 1 (linear) or 3 (c1 tau + c3 tau^3)");
  }
  EffectNeeds needs() const override {
    EffectNeeds n;
    n.torque = true;
    return n;
  }
  std::vector<DrivingVariable> drivingVariables(const Effect& e, const Arm& arm) const override {
    std::vector<DrivingVariable> v;
    for (const int j : e.joints()) v.push_back(torqueDriver(arm, j));
    return v;
  }
  bool acceptsPrismatic() const override { return true; }  // along the axis: dq = -c f, f the actuator's force
  std::vector<ParamBlock> blocks(const Effect& e, const Arm& arm, int) const override {
    // 1e-4 rad/(N m): a harmonic drive of ~10^4 N m/rad (the iiwa's joints: Bischoff et al. 2010), or,
    // at torque scales above 50 N m, what deflects by 0.29 deg (5e-3 rad) at the scale; the cubic term
    // at the size that doubles that deflection at the scale. Typical magnitudes set the fit's column
    // scales: a cubic term of a 10^5 N m joint is 10^12 times a 10 N m one's.
    const double tau_s = e.reference() > 0.0 ? e.reference() : defaultReference();
    // A prismatic joint (a lead-screw or belt drive) in m/N: 1e-6, a drive of ~10^6 N/m, or at force scales
    // above 50 N what deflects by 0.05 mm at the scale.
    const double c1 = std::min(1e-4, 5e-3 / tau_s), c3 = c1 / (tau_s * tau_s);
    const double s1 = std::min(1e-6, 5e-5 / tau_s), s3 = s1 / (tau_s * tau_s);
    return {jointBlockOf(e, [&](ParamBlock& b, const std::string& j, int joint) {
      if (arm.isPrismatic(joint)) {
        b.params.push_back({"c" + j, "m/N", "m/N", 1.0, s1, Quantity::kOther});
        if (e.order() == 3) b.params.push_back({"c" + j + "_cubic", "m/N^3", "m/N^3", 1.0, s3, Quantity::kOther});
        return;
      }
      b.params.push_back({"c" + j, "rad/(N*m)", "rad/(N*m)", 1.0, c1, Quantity::kOther});
      if (e.order() == 3) b.params.push_back({"c" + j + "_cubic", "rad/(N*m)^3", "rad/(N*m)^3", 1.0, c3, Quantity::kOther});
    })};
  }
  void addJointCorrection(const Effect& e, const ParamBlock& b, const Eigen::VectorXd& p, const JointSample& s, const Arm&,
                          Eigen::VectorXd& dq, JointCorrectionJacobian* J) const override {
    const int per = e.order() == 3 ? 2 : 1;
    for (std::size_t i = 0; i < b.joints.size(); ++i) {
      const int j = b.joints[i], col = b.offset + per * static_cast<int>(i);
      const double tau = s.tau_Nm[j];  // the actuator's; the joint yields against it (see the top)
      dq[j] -= p[col] * tau;
      if (J) J->add(j, col, -tau);
      if (per == 2) {
        dq[j] -= p[col + 1] * tau * tau * tau;
        if (J) J->add(j, col + 1, -(tau * tau * tau));
      }
    }
  }
  std::string correctionFormula(const Effect& e, const ParamBlock& b, const Arm&) const override {
    const std::size_t per = e.order() == 3 ? 2 : 1;
    std::string f;
    for (std::size_t i = 0; i < b.joints.size(); ++i) {
      const std::string n = std::to_string(b.joints[i] + 1), tau = "tau" + n;
      f += (i ? "; " : "") + ("dq" + n + " = -(" + b.params[per * i].name + " * " + tau) +
           (per == 2 ? " + " + b.params[per * i + 1].name + " * " + tau + "^3" : std::string()) + ")";
    }
    return f;
  }
  void requireCovariates(const JointSample& s, int) const override {
    if (!s.hasTorque()) {
      throw std::invalid_argument("the compliance effect needs joint torques: measured, or from the robot file's masses");
    }
  }
  std::vector<Effect> candidates(const CandidateContext& c) const override {
    if (!c.torque) return {};
    std::vector<Effect> out = perJointCandidates(c.joints);
    for (int j = 0; j < c.joints; ++j) out.emplace_back(*this, std::vector<int>{j}, 3);
    return out;
  }
  std::pair<std::string, std::string> revealingVariable(const Effect& e, const Arm& arm) const override {
    return torqueVariable(arm, e.joints().front());
  }
  std::string separateBy() const override {
    return "measure with several payloads (or poses that load the joints differently), so that each joint's torque varies "
           "independently of the others and of the pose";
  }
};

}  // namespace

const EffectKind& complianceKind() {
  static const ComplianceKind k;
  return k;
}

}  // namespace orbcal::sim
