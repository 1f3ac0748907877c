// mount: the marker (or tool) is taken off and put back between sessions, so each later session sees
// it through a slightly different rigid change.
#include "orbcal/sim/model.hpp"

namespace orbcal::sim {
namespace {

class MountKind final : public EffectKind {
 public:
  std::string name() const override { return "mount"; }
  std::string words(const Effect&) const override { return "a change of the marker mount between sessions"; }
  std::string physics() const override {
    return "a marker or tool re-mounted between sessions sits slightly differently: sessions 2.. see the marker frame "
           "through a rigid change Y_s";
  }
  bool takesJoints() const override { return false; }
  EffectNeeds needs() const override {
    EffectNeeds n;
    n.sessions = true;
    return n;
  }
  std::vector<ParamBlock> blocks(const Effect&, const Arm&, int num_sessions) const override {
    std::vector<ParamBlock> out;
    for (int s = 1; s < num_sessions; ++s) out.push_back(frameBlock(BlockKind::kMount, s));
    return out;
  }
  void addChainInserts(const Effect&, const ParamBlock& b, const Eigen::VectorXd& p, const JointSample& s, const NominalChain&,
                       std::vector<ChainInsert>& out) const override {
    if (b.session != s.session) return;
    ChainInsert c;
    c.place = ChainInsert::Place::kMarker;
    c.xi = p.segment<6>(b.offset);
    c.J_xi_p = Eigen::MatrixXd::Identity(6, 6);
    c.offset = b.offset;
    out.push_back(std::move(c));
  }
  std::vector<Effect> candidates(const CandidateContext& c) const override {
    return c.sessions > 1 && c.shared_marker ? std::vector<Effect>{Mount{}} : std::vector<Effect>{};
  }
  std::pair<std::string, std::string> revealingVariable(const Effect&, const Arm&) const override { return {"session", "session"}; }
  std::string separateBy() const override { return "add configurations that move the joints involved independently"; }
};

}  // namespace

const EffectKind& mountKind() {
  static const MountKind k;
  return k;
}

}  // namespace orbcal::sim
