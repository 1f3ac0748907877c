// cyclic: a transmission error periodic in the joint angle (gear eccentricity, the harmonic drive's
// wave generator: first and second harmonics; tooth and bearing patterns: higher ones). On a prismatic
// joint the error is periodic in the travel, with a lead screw's lead as its period (kLeadScrewPeriodM).
#include <algorithm>
#include <cmath>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/sim/model.hpp"

namespace orbcal::sim {
namespace {

/// The period of a prismatic joint's cyclic error (m): 5 mm, the smallest standard lead of a ball
/// screw (ISO 3408-1), whose error repeats once per turn of the screw.
constexpr double kLeadScrewPeriodM = 0.005;

/// The phase of harmonic 1 at joint value q: q itself (rad) on a revolute joint, 2 pi q / lead on a prismatic one.
double cyclicPhase(const Arm& arm, int j, double q) { return arm.isPrismatic(j) ? 2.0 * kPi * q / kLeadScrewPeriodM : q; }

class CyclicKind final : public EffectKind {
 public:
  std::string name() const override { return "cyclic"; }
  std::string words(const Effect& e) const override {
    return "a cyclic transmission error" + ofJoints(e.joints()) +
           (e.order() != 2 ? " (harmonics 1-" + std::to_string(e.order()) + ")" : "");
  }
  std::string physics() const override {
    return "a transmission whose output lags its input by a periodic function of the angle: gear eccentricity (harmonic 1), "
           "the harmonic drive's elliptical wave generator (harmonic 2), tooth and bearing patterns (higher)";
  }
  int defaultOrder() const override { return 2; }
  int maxOrder() const override { return 8; }
  bool acceptsPrismatic() const override { return true; }
  std::vector<DrivingVariable> drivingVariables(const Effect& e, const Arm& arm) const override {
    std::vector<DrivingVariable> v;
    for (const int j : e.joints()) v.push_back(angleDriver(arm, j));
    return v;
  }
  std::vector<ParamBlock> blocks(const Effect& e, const Arm& arm, int) const override {
    // On a prismatic joint 0.01 mm: a ball screw's lead deviation over one turn is of micrometres to tens of them.
    return {jointBlockOf(e, [&](ParamBlock& b, const std::string& j, int joint) {
      const auto param = [&](const std::string& name) {
        return arm.isPrismatic(joint) ? lengthParam(name, 1e-5) : angleParam(name, 0.01 * kDegToRad);
      };
      for (int k = 1; k <= e.order(); ++k) {
        b.params.push_back(param("cyclic" + j + "_sin" + std::to_string(k)));
        b.params.push_back(param("cyclic" + j + "_cos" + std::to_string(k)));
      }
    })};
  }
  void addJointCorrection(const Effect& e, const ParamBlock& b, const Eigen::VectorXd& p, const JointSample& s, const Arm& arm,
                          Eigen::VectorXd& dq, JointCorrectionJacobian* J) const override {
    int col = b.offset;
    for (const int j : b.joints) {
      const double phase = cyclicPhase(arm, j, s.q_rad[j]);
      for (int k = 1; k <= e.order(); ++k, col += 2) {
        const double sn = std::sin(k * phase), cs = std::cos(k * phase);
        dq[j] += p[col] * sn + p[col + 1] * cs;
        if (J) {
          J->add(j, col, sn);
          J->add(j, col + 1, cs);
        }
      }
    }
  }
  std::string correctionFormula(const Effect& e, const ParamBlock& b, const Arm& arm) const override {
    std::string f;
    std::size_t col = 0;
    for (std::size_t i = 0; i < b.joints.size(); ++i) {
      const std::string n = std::to_string(b.joints[i] + 1);
      f += (i ? "; dq" : "dq") + n + " =";
      for (int k = 1; k <= e.order(); ++k, col += 2) {
        // The phase of harmonic k: k qN on a revolute joint, k 2 pi qN / lead on a prismatic one (cyclicPhase).
        const std::string kq = "(" + std::to_string(k) + " * " +
                               (arm.isPrismatic(b.joints[i]) ? "2 * pi * q" + n + " / " + formatNumber("%.6g", kLeadScrewPeriodM) : "q" + n) + ")";
        f += (k > 1 ? " + " : " ") + b.params[col].name + " * sin" + kq + " + " + b.params[col + 1].name + " * cos" + kq;
      }
    }
    return f;
  }
  /// Harmonics 1..c.harmonics on every joint, and 1..c.max_order where that reaches further: the score
  /// test of the longer series sees a higher harmonic; diagnose then picks the order by cross-validation.
  std::vector<Effect> candidates(const CandidateContext& c) const override {
    std::vector<Effect> out;
    for (int j = 0; j < c.joints; ++j) out.emplace_back(*this, std::vector<int>{j}, c.harmonics);
    if (c.harmonics < c.max_order) {
      for (int j = 0; j < c.joints; ++j) out.emplace_back(*this, std::vector<int>{j}, std::min(c.max_order, maxOrder()));
    }
    return out;
  }
  std::pair<std::string, std::string> revealingVariable(const Effect& e, const Arm& arm) const override {
    return angleVariable(arm, e.joints().front());
  }
  std::string separateBy() const override { return widerRangeAdvice(); }
};

}  // namespace

const EffectKind& cyclicKind() {
  static const CyclicKind k;
  return k;
}

}  // namespace orbcal::sim
