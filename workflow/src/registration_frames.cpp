// The registration frames of a measured-data fit as the reports show them: frames (position in mm,
// rotation as roll, pitch, yaw in deg), not the parameter rows of their increments.
#include <algorithm>
#include <cmath>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/measured.hpp"
#include "orbcal/sim/urdf.hpp"
#include "orbcal/workflow/measured.hpp"
#include "measured_verdict.hpp"

namespace orbcal::workflow {

namespace {

using sim::formatNumber;

std::string triple(const Eigen::Vector3d& v, double scale, const char* format) {
  return formatNumber(format, v.x() * scale) + ", " + formatNumber(format, v.y() * scale) + ", " + formatNumber(format, v.z() * scale);
}

/// Whether the data determine a fitted frame's parameters (block `b`): "yes", or its held parameters and
/// those determined only in a combination with others ("held: marker1_rx; only in a combination: base_z with d1").
std::string determinedCell(const calib::Fit& fit, const sim::ParamBlock& b) {
  const std::vector<std::string> partners =
      measured_detail::combinationPartners(fit.identifiability.redundancies, fit.model.layout.size());
  std::string held, combined;
  for (int i = 0; i < b.size(); ++i) {
    const std::string& name = b.params[static_cast<std::size_t>(i)].name;
    const std::string& with = partners[static_cast<std::size_t>(b.offset + i)];
    if (std::binary_search(fit.estimate.held.begin(), fit.estimate.held.end(), b.offset + i)) {
      held += (held.empty() ? "" : ", ") + name;
    } else if (!with.empty()) {
      combined += (combined.empty() ? "" : "; ") + name + " with " + with;
    }
  }
  if (held.empty() && combined.empty()) return "yes";
  return (held.empty() ? "" : "held: " + held) + (held.empty() || combined.empty() ? "" : "; ") +
         (combined.empty() ? "" : "only in a combination: " + combined);
}

/// The 1-sigma columns of a fitted frame (its block `b` of the fit's layout, parameterized as X0 (Exp(w), t)):
/// the position's per axis of the parent frame (R0 Sigma_t R0^T: the translation is t0 + R0 t) in mm, the
/// rotation's about the frame's own axes in deg, then whether the data determine it (determinedCell).
std::string sigmaCells(const calib::Fit& fit, const sim::ParamBlock& b, const Eigen::Matrix3d& R0) {
  const Eigen::MatrixXd& C = fit.estimate.covariance;
  if (C.rows() < b.offset + b.size()) return "- | - | " + determinedCell(fit, b);
  const Eigen::Matrix3d position = R0 * C.block<3, 3>(b.offset, b.offset) * R0.transpose();
  const Eigen::Vector3d sp = position.diagonal().cwiseMax(0.0).cwiseSqrt();
  const Eigen::Vector3d sr = C.block<3, 3>(b.offset + 3, b.offset + 3).diagonal().cwiseMax(0.0).cwiseSqrt();
  return triple(sp, 1e3, "%.3g") + " | " + triple(sr, sim::kRadToDeg, "%.3g") + " | " + determinedCell(fit, b);
}

/// The rows of one frame kind (kBase: world_T_base, kMarker: flange_T_marker): one per fitted block
/// (shared: all sessions; per session: each), or the known frames (`known` says whose).
std::string frameRows(const calib::Fit& fit, const sim::KinematicModel& folded, sim::BlockKind kind, const std::string& known) {
  const bool base = kind == sim::BlockKind::kBase;
  const std::string name = base ? "world_T_base" : "flange_T_marker";
  const std::vector<Eigen::Isometry3d>& frames = base ? folded.world_T_base : folded.flange_T_marker;
  const sim::FrameSharing sharing = base ? fit.model.base : fit.model.marker;
  std::string md;
  const auto row = [&](std::size_t k, const std::string& session, const std::string& rest) {
    const Eigen::Isometry3d& T = frames[std::min(k, frames.size() - 1)];
    md += "| " + name + " | " + session + " | " + triple(T.translation(), 1e3, "%.3f") + " | " +
          triple(sim::rpyFromRotation(T.linear()), sim::kRadToDeg, "%.4f") + " | " + rest + " |\n";
  };
  if (sharing == sim::FrameSharing::kKnown) {
    row(0, "all (" + known + ")", "- | - | not fitted");
    return md;
  }
  for (const sim::ParamBlock& b : fit.model.layout.blocks()) {
    if (b.kind != kind) continue;
    const std::size_t k = b.session < 0 ? 0 : static_cast<std::size_t>(b.session);
    const Eigen::Matrix3d R0 = (base ? fit.model.baseStart(static_cast<int>(k)) : fit.model.markerStart(static_cast<int>(k))).linear();
    row(k, b.session < 0 ? "all (shared)" : std::to_string(b.session + 1), sigmaCells(fit, b, R0));
  }
  return md;
}

}  // namespace

std::string registrationFramesTable(const calib::Fit& fit, const std::string& known) {
  const sim::KinematicModel folded = sim::foldParameters(fit.model, fit.p).model;
  return "The registration frames, each a_T_b mapping coordinates in frame b to frame a: `world_T_base` the robot's base in "
         "the measuring system's frame, `flange_T_marker` the marker on the flange (sessions numbered from 1, as `frames.yaml` "
         "numbers them). Rotation as roll, pitch, yaw (R = Rz(yaw) Ry(pitch) Rx(roll)); 1-sigma of the position per axis of "
         "frame a, of the rotation about the frame's own axes; determined: whether the data determine the frame's parameters "
         "(held: not at all, kept at their starting value; only in a combination: with the parameters named).\n\n"
         "| frame | session | position x, y, z (mm) | roll, pitch, yaw (deg) | 1-sigma x, y, z (mm) | 1-sigma about x, y, z (deg) | determined |\n"
         "|---|---|---|---|---|---|---|\n" +
         frameRows(fit, folded, sim::BlockKind::kBase, known) + frameRows(fit, folded, sim::BlockKind::kMarker, known);
}

}  // namespace orbcal::workflow
