// empirical, empirical_torque: what is left when no physical cause of the catalog explains the
// structure in the residuals. Joint i's angle is corrected by a smooth function of one variable x (joint
// j's angle, or its torque): dq_i = sum_{k=1..K} c_k P_k(s), s = (2x - lo - hi) / (hi - lo) in [-1, 1]
// over the data's range, P_k the Legendre polynomials. Why this basis: a joint-angle correction is the
// smallest thing that can move the whole pose the way real unmodelled causes do (transmissions,
// couplings, loads), a polynomial is smooth with few parameters on a range that need not be a full turn
// (unlike Fourier terms), the Legendre polynomials are orthogonal on that range (well conditioned),
// and K is chosen by cross-validation, which regularizes it. Outside [lo, hi] a polynomial extrapolates
// without any physical reason: `orbcal evaluate` warns where new data leaves the range.
#include <cmath>
#include <stdexcept>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/model.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::sim {
namespace {

/// P_1..P_K at s (Bonnet's recursion) into P (resized to K).
void legendre(double s, int K, Eigen::VectorXd& P) {
  P.resize(K);
  double p0 = 1.0, p1 = s;
  for (int k = 1; k <= K; ++k) {
    P[k - 1] = p1;
    const double p2 = ((2.0 * k + 1.0) * s * p1 - k * p0) / (k + 1.0);
    p0 = p1;
    p1 = p2;
  }
}

/// joints = [i, j]: joint i corrected as a function of joint j's angle (or torque).
class EmpiricalKind : public EffectKind {
 public:
  explicit EmpiricalKind(bool torque) : torque_(torque) {}
  std::string name() const override { return torque_ ? "empirical_torque" : "empirical"; }
  bool empirical() const override { return true; }
  std::string words(const Effect& e) const override {
    return "an empirical correction of joint " + std::to_string(e.joints()[0] + 1) + " as a smooth function (degree " +
           std::to_string(e.order()) + ") of joint " + std::to_string(e.joints()[1] + 1) + "'s " + (torque_ ? "torque" : "angle") +
           " (not a physical cause; valid for " + rangeText(e) + ")";
  }
  std::string physics() const override {
    return "none named: a smooth correction of one joint's angle against one variable, for structure no cause of the catalog "
           "explains; trusted only within the range of the data it was fitted on";
  }
  int defaultOrder() const override { return 3; }
  int maxOrder() const override { return 8; }
  EffectNeeds needs() const override {
    EffectNeeds n;
    n.torque = torque_;
    return n;
  }
  void check(const Effect& e, int num_joints, const std::string& what) const override {
    EffectKind::check(e, num_joints, what);
    if (e.joints().size() != 2) throw InputError(what + ": " + name() + " takes two joints i,j (joint i corrected from joint j)");
  }
  std::vector<std::string> keys(const Effect& e) const override {
    return {name() + ":" + std::to_string(e.joints()[0] + 1) + "," + std::to_string(e.joints()[1] + 1)};
  }
  double variable(const Effect& e, const JointSample& s) const override {
    return torque_ ? s.tau_Nm[e.joints()[1]] : s.q_rad[e.joints()[1]];
  }
  std::vector<DrivingVariable> drivingVariables(const Effect& e, const Arm& arm) const override {
    return {torque_ ? torqueDriver(arm, e.joints()[1]) : angleDriver(arm, e.joints()[1])};
  }
  std::vector<ParamBlock> blocks(const Effect& e, const Arm&, int) const override {
    ParamBlock b;
    b.effect = name();
    b.joints = e.joints();
    const std::string ij = std::to_string(e.joints()[0] + 1) + "_" + std::to_string(e.joints()[1] + 1);
    // 0.01 deg per term: the size of the residual structure worth a correction on a tracker's data.
    for (int k = 1; k <= e.order(); ++k) b.params.push_back(angleParam(name() + ij + "_P" + std::to_string(k), 0.01 * kDegToRad));
    return {b};
  }
  void addJointCorrection(const Effect& e, const ParamBlock& b, const Eigen::VectorXd& p, const JointSample& s, const Arm&,
                          Eigen::VectorXd& dq, JointCorrectionJacobian* J) const override {
    const double x = variable(e, s);
    thread_local Eigen::VectorXd P;  // every sample at every iteration: no allocation each time
    legendre((2.0 * x - e.lo() - e.hi()) / (e.hi() - e.lo()), e.order(), P);
    const int i = e.joints()[0];
    dq[i] += P.dot(p.segment(b.offset, e.order()));
    for (int k = 0; J && k < e.order(); ++k) J->add(i, b.offset + k, P[k]);
  }
  std::string correctionFormula(const Effect& e, const ParamBlock& b, const Arm&) const override {
    std::string f = "dq" + std::to_string(e.joints()[0] + 1) + " =";
    for (int k = 1; k <= e.order(); ++k) f += (k > 1 ? " + " : " ") + b.params[static_cast<std::size_t>(k - 1)].name + " * P" + std::to_string(k) + "(x)";
    return f + ", x = (2 * " + (torque_ ? "tau" : "q") + std::to_string(e.joints()[1] + 1) + " - lo - hi) / (hi - lo), lo = " +
           exactNumber(e.lo()) + ", hi = " + exactNumber(e.hi()) + ", Pk the Legendre polynomials: P1(x) = x, P2(x) = (3 x^2 - 1) / 2, (k + 1) P(k+1)(x) = (2k + 1) x Pk(x) - k P(k-1)(x)";
  }
  void requireCovariates(const JointSample& s, int) const override {
    if (torque_ && !s.hasTorque()) throw std::invalid_argument("the empirical_torque correction needs joint torques");
  }
  /// None of its own: diagnose proposes empirical corrections on the variables its evidence names.
  std::vector<Effect> candidates(const CandidateContext&) const override { return {}; }
  std::pair<std::string, std::string> revealingVariable(const Effect& e, const Arm& arm) const override {
    return torque_ ? torqueVariable(arm, e.joints()[1]) : angleVariable(arm, e.joints()[1]);
  }
  std::string separateBy() const override {
    return "measure more configurations across the variable's range; an empirical term names no cause to separate";
  }

 private:
  std::string rangeText(const Effect& e) const {
    return torque_ ? formatNumber("%.1f", e.lo()) + ".." + formatNumber("%.1f", e.hi()) + " N m"
                   : formatNumber("%.1f", e.lo() * kRadToDeg) + ".." + formatNumber("%.1f", e.hi() * kRadToDeg) + " deg";
  }
  bool torque_;
};

}  // namespace

const EffectKind& empiricalKind() {
  static const EmpiricalKind k(false);
  return k;
}
const EffectKind& empirical_torqueKind() {
  static const EmpiricalKind k(true);
  return k;
}

}  // namespace orbcal::sim
