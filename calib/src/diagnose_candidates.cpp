// The candidate causes diagnose tries on a dataset: the catalog's, and the empirical corrections.
#include <algorithm>
#include <cmath>

#include "diagnose_candidates.hpp"

namespace orbcal::calib {

using sim::Effect;

std::vector<Effect> catalogCandidates(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs,
                                      const DiagnoseOptions& o) {
  sim::CandidateContext ctx;
  ctx.arm = &data.arm;
  ctx.joints = data.arm.numJoints();
  ctx.torque = data.has_torque || !data.arm.masses.empty();
  ctx.masses = !data.arm.masses.empty();
  for (const sim::MeasuredPose& p : data.poses) ctx.direction |= p.sample.direction.size() > 0 && p.sample.direction.cwiseAbs().sum() > 0;
  ctx.temperature = data.has_temperature;
  ctx.time = data.has_time;
  ctx.sessions = data.numSessions();
  ctx.shared_marker = data.marker == sim::FrameSharing::kShared;
  ctx.harmonics = o.harmonics;
  ctx.max_order = o.max_order;
  std::vector<sim::JointSample> samples;
  for (const MarkerObservation& ob : obs) samples.push_back(ob.sample);
  std::vector<Effect> c;
  for (const sim::EffectKind* k : sim::catalog()) {
    for (const Effect& e : k->candidates(ctx)) {
      if (sim::fitsJointTypes(e, data.arm)) c.push_back(k->adaptTo(e, samples));
    }
  }
  return c;
}

std::vector<Effect> empiricalCandidates(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs, int degree) {
  std::vector<Effect> out;
  const bool torque = !obs.empty() && obs.front().sample.hasTorque();
  for (int j = 0; j < data.arm.numJoints(); ++j) {
    for (const char* name : {"empirical", "empirical_torque"}) {
      const sim::EffectKind& kind = *sim::findEffectKind(name);
      if (kind.needs().torque && !torque) continue;
      const Effect e(kind, {j, j}, std::clamp(degree, 1, kind.maxOrder()));
      if (!sim::fitsJointTypes(e, data.arm)) continue;
      double lo = kind.variable(e, obs.front().sample), hi = lo;
      for (const MarkerObservation& ob : obs) {
        lo = std::min(lo, kind.variable(e, ob.sample));
        hi = std::max(hi, kind.variable(e, ob.sample));
      }
      if (hi - lo > 1e-9 * std::max(1.0, std::abs(hi))) out.push_back(e.withRange(lo, hi));
    }
  }
  return out;
}

}  // namespace orbcal::calib
