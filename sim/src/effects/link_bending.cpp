// link_bending: a link that bends under the gravity load it carries. A cantilever of length L and
// bending stiffness EI, clamped at its near joint and loaded at its far end by the force F (the
// weight of everything beyond it, its component across the link) deflects there by F L^3 / (3 EI)
// along F and tilts by F L^2 / (2 EI) about u x F (u along the link): a translation and a rotation
// together, which no rotation about a joint axis reproduces. The parameter is the compliance
// 1 / EI (1/(N m^2)); the loads come from the robot's mass model (a load inside the link, at a from
// its near end, moves the far end by P a^2 (3L - a) / 6EI and tilts it by P a^2 / 2EI).
#include <algorithm>
#include <cmath>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/model.hpp"

namespace orbcal::sim {
namespace {

/// "link_bending:J" bends the link joint J moves: from joint J's frame to the next joint's (or the
/// flange for the last joint). In chainFrames' indices that is frames[j] -> frames[j+1] in standard DH
/// and Hayati (joint j turns about z of frame j), frames[j+1] -> frames[j+2] in modified DH and the
/// URDF convention (frames[n+1] is the flange); the insert sits at its far end.
std::pair<int, int> segment(const Arm& arm, int j) {
  const bool at_own_frame = arm.convention == DhConvention::kModified || arm.convention == DhConvention::kUrdf;
  return at_own_frame ? std::make_pair(j + 1, j + 2) : std::make_pair(j, j + 1);
}

/// The length L of the link joint j moves, in `frames` (chainFrames).
double segmentLength(const Arm& arm, const std::vector<Eigen::Isometry3d>& frames, int j) {
  const auto [near, far] = segment(arm, j);
  return (frames[static_cast<std::size_t>(far)].translation() - frames[static_cast<std::size_t>(near)].translation()).norm();
}

class LinkBendingKind final : public EffectKind {
 public:
  std::string name() const override { return "link_bending"; }
  std::string words(const Effect& e) const override {
    std::string s = e.joints().size() > 1 ? "bending of the links joints " : "bending of the link joint ";
    for (std::size_t i = 0; i < e.joints().size(); ++i) {
      s += (i ? (i + 1 == e.joints().size() ? " and " : ", ") : "") + std::to_string(e.joints()[i] + 1);
    }
    return s + (e.joints().size() > 1 ? " move" : " moves") + " under the gravity load it carries";
  }
  std::string physics() const override {
    return "a link bends under the weight it carries like a cantilever: its far end moves by F L^3 / 3EI and tilts by "
           "F L^2 / 2EI, a translation with a tilt that no joint-angle error reproduces; the parameter is 1/EI";
  }
  EffectNeeds needs() const override {
    EffectNeeds n;
    n.masses = true;
    return n;
  }
  /// The link's bending load: its far end's deflection per unit 1/EI (N m^3, unitDeflection), which the
  /// pose and the masses it carries set (its near joint's torque need not follow it: joint 7's axis runs
  /// along its link).
  std::vector<DrivingVariable> drivingVariables(const Effect& e, const Arm& arm) const override {
    std::vector<DrivingVariable> out;
    for (const int l : e.joints()) {
      DrivingVariable v;
      v.column = "bending" + std::to_string(l + 1) + "_Nm3";
      v.name = "link " + std::to_string(l + 1) + "'s bending load";
      v.unit = "N m^3";
      v.extremes = DrivingVariable::Extremes::kMagnitude;
      v.value = [arm, l](const JointSample& s) { return unitDeflection(arm, chainFrames(arm, s.q_rad), l).head<3>().norm(); };
      out.push_back(std::move(v));
    }
    return out;
  }
  std::vector<ParamBlock> blocks(const Effect& e, const Arm& arm, int) const override {
    ParamBlock b;
    b.effect = name();
    b.joints = e.joints();
    for (int l : e.joints()) {
      b.params.push_back({"bend" + std::to_string(l + 1), "1/(N*m^2)", "1/(N*m^2)", 1.0, typicalCompliance(arm, l),
                          Quantity::kOther});
    }
    return {b};
  }
  void addChainInserts(const Effect&, const ParamBlock& b, const Eigen::VectorXd& p, const JointSample&, const NominalChain& chain,
                       std::vector<ChainInsert>& out) const override {
    const Arm& arm = chain.arm();
    const std::vector<Eigen::Isometry3d>& frames = chain.frames();
    for (std::size_t i = 0; i < b.joints.size(); ++i) {
      const int l = b.joints[i];
      ChainInsert c;
      const int far = segment(arm, l).second;
      c.place = far == arm.numJoints() + 1 ? ChainInsert::Place::kFlange : ChainInsert::Place::kLink;
      c.link = far - 1;
      c.offset = b.offset;
      c.J_xi_p = Eigen::MatrixXd::Zero(6, b.size());
      c.J_xi_p.col(static_cast<Eigen::Index>(i)) = unitDeflection(arm, frames, l);
      c.xi = c.J_xi_p * p.segment(b.offset, b.size());
      out.push_back(std::move(c));
    }
  }
  /// Links long enough to bend (at least 5 % of the arm's reach), loaded (masses given), and loaded
  /// across their length somewhere in the joint box: a column that stays along gravity (the iiwa's
  /// base link about its vertical first joint) never bends, whatever its stiffness.
  std::vector<Effect> candidates(const CandidateContext& c) const override {
    if (!c.masses || !c.arm) return {};
    const Arm& arm = *c.arm;
    std::vector<Effect> out;
    const std::vector<Eigen::Isometry3d> frames = chainFrames(arm, Eigen::VectorXd::Zero(arm.numJoints()));
    const double reach = characteristicLength(arm);
    for (int l = 0; l < c.joints; ++l) {
      if (segmentLength(arm, frames, l) >= 0.05 * reach && carriedMass(arm, l) > 0.0 && bendsSomewhere(arm, l)) out.emplace_back(*this, std::vector<int>{l});
    }
    return out;
  }
  /// Whether the far end moves at some of 64 configurations spread over the joint box (a deterministic
  /// lattice: joint k at the fraction frac(m (k + 1) phi) of its range, phi the golden ratio) by more
  /// than 1 % of the deflection of the typical stiffness under the full load across the link.
  static bool bendsSomewhere(const Arm& arm, int l) {
    const double phi = 0.6180339887498949, typical = typicalCompliance(arm, l);
    const double L = segmentLength(arm, chainFrames(arm, Eigen::VectorXd::Zero(arm.numJoints())), l);
    const double full = typical * carriedMass(arm, l) * arm.masses.gravity_base.norm() * L * L * L / 3.0;
    for (int m = 1; m <= 64; ++m) {
      Eigen::VectorXd q(arm.numJoints());
      for (int k = 0; k < arm.numJoints(); ++k) {
        const double f = std::fmod(m * (k + 1) * phi, 1.0);
        q[k] = arm.lower_rad[k] + f * (arm.upper_rad[k] - arm.lower_rad[k]);
      }
      if (typical * unitDeflection(arm, chainFrames(arm, q), l).head<3>().norm() > 0.01 * full) return true;
    }
    return false;
  }
  std::pair<std::string, std::string> revealingVariable(const Effect& e, const Arm& arm) const override {
    // The torque of the joint at the link's near end grows with the load the link carries.
    const auto [column, label] = torqueVariable(arm, e.joints().front());
    return {column, label + ", which link " + std::to_string(e.joints().front() + 1) + "'s load drives"};
  }
  std::string separateBy() const override {
    return "measure with several payloads, so that the links' loads vary independently of the joints' torques";
  }

  /// xi per unit 1/EI at the far end of the link joint l moves, in the far-end frame. Every mass the
  /// link carries (its own and the later links', links[i] in frames[i+1], and the payload, as point masses at their centres) loads it where it projects
  /// onto the link, at a = clamp(t, 0, L) from the near end: the far end moves by P_perp a^2 (3L - a) / 6
  /// along the load and tilts by P_perp a^2 / 2 about u x P_perp (a = L: F L^3 / 3, F L^2 / 2). Moments
  /// of masses beyond the far end, and the axial load, are left out (a slender link's bending is the
  /// transverse load's).
  static Eigen::Matrix<double, 6, 1> unitDeflection(const Arm& arm, const std::vector<Eigen::Isometry3d>& frames, int l) {
    Eigen::Matrix<double, 6, 1> xi = Eigen::Matrix<double, 6, 1>::Zero();
    const auto [near, far] = segment(arm, l);
    const Eigen::Vector3d o = frames[static_cast<std::size_t>(near)].translation();
    const Eigen::Vector3d span = frames[static_cast<std::size_t>(far)].translation() - o;
    const double L = span.norm();
    if (L < 1e-9) return xi;
    const Eigen::Vector3d u = span / L;
    Eigen::Vector3d d = Eigen::Vector3d::Zero(), w = Eigen::Vector3d::Zero();
    const auto load = [&](double mass, const Eigen::Vector3d& at) {
      const Eigen::Vector3d P = mass * arm.masses.gravity_base;
      const Eigen::Vector3d P_perp = P - P.dot(u) * u;
      const double a = std::clamp((at - o).dot(u), 0.0, L);
      d += a * a * (3.0 * L - a) / 6.0 * P_perp;
      w += a * a / 2.0 * u.cross(P_perp);
    };
    for (std::size_t i = static_cast<std::size_t>(l); i < arm.masses.links.size(); ++i) {
      load(arm.masses.links[i].mass_kg, frames[i + 1] * arm.masses.links[i].com_m);
    }
    load(arm.masses.payload_kg, frames.back() * arm.masses.payload_com_flange_m);
    const Eigen::Matrix3d Rt = frames[static_cast<std::size_t>(far)].linear().transpose();
    xi.head<3>() = Rt * d;
    xi.tail<3>() = Rt * w;
    return xi;
  }
  /// The mass the link joint l moves carries: its own (links[l], in frames[l+1]), the later links' and the payload.
  static double carriedMass(const Arm& arm, int l) {
    double m = arm.masses.payload_kg;
    for (std::size_t i = static_cast<std::size_t>(l); i < arm.masses.links.size(); ++i) m += arm.masses.links[i].mass_kg;
    return m;
  }
  /// 1/EI that moves the far end by 0.1 mm with the link horizontal under its full load, at the arm's
  /// nominal zero pose: a stiff aluminium tube of a light arm bends by tens of micrometres.
  static double typicalCompliance(const Arm& arm, int l) {
    const std::vector<Eigen::Isometry3d> frames = chainFrames(arm, Eigen::VectorXd::Zero(arm.numJoints()));
    const double L = segmentLength(arm, frames, l);
    const double F = carriedMass(arm, l) * arm.masses.gravity_base.norm();
    if (L < 1e-9 || F <= 0.0) return 1.0;
    return 3.0 * 1e-4 / (F * L * L * L);
  }
};

}  // namespace

const EffectKind& link_bendingKind() {
  static const LinkBendingKind k;
  return k;
}

}  // namespace orbcal::sim
