#pragma once
// A calibrated model's parts for programs outside orbcal (docs/export.md describes both files):
//
// frames.yaml: the registration frames, each a_T_b (p_a = R p_b + t: coordinates in frame b mapped
// to frame a) as a 4x4 homogeneous matrix row by row (translation in metres) and as xyz_m + a unit
// quaternion [x, y, z, w] (Hamilton, the rotation R of the matrix):
//   format: orbcal-frames-1
//   sessions: 2
//   world_T_base: {sharing: shared, frames: [{session: all, matrix: [[..], ..], xyz_m: [..], quaternion_xyzw: [..]}]}
//   flange_T_marker: {sharing: per_session, frames: [{session: 1, ...}, {session: 2, ...}]}
//
// effects.yaml: the fitted effects, one entry per effect and joint, with the formula that applies it:
//   format: orbcal-effects-1
//   robot: robot.yaml                  # the calibrated robot, relative to this file
//   sessions: 1
//   joints: [{joint: 1, name: iiwa_joint_1}, ...]                    # from 1; the URDF's names
//   effects:
//     - effect: compliance
//       spec: "compliance:2"            # orbcal's --effects syntax
//       joint: 2                        # the joint whose angle it corrects (absent: not a joint effect)
//       joint_name: iiwa_joint_2
//       applies_to: joint_angle         # joint_angle: q_link = q + dq; chain: not a joint-angle correction
//       formula: "dq2 = -(c2 * tau2)"   # EffectKind::correctionFormula
//       parameters: [{name: c2, value: 1.2e-05, unit: "rad/(N*m)"}]   # SI
//     - {effect: mount, spec: "mount", applies_to: chain, description: "...", parameters: [...]}
// An effect on several joints ("compliance:2,4") gives one entry per joint (per pair for coupling).
// A joint stands at q + dq, q its reading (rad; m for a prismatic joint), dq the sum of its entries' formulas, evaluated
// at the readings q, the actuators' torques tau (N m; a prismatic joint's force, N) and the approach directions dir (+1/-1/0).
#include <Eigen/Core>
#include <string>

#include "orbcal/sim/model.hpp"

namespace orbcal::sim {

/// The content of frames.yaml for the folded model `m` (sim::foldParameters); `header` goes first as
/// '#' comment lines.
std::string formatFramesFile(const KinematicModel& m, const std::string& header = "");

/// The content of effects.yaml for the folded model `m` and its effect parameters `p` (foldParameters'
/// p); `robot` is the robot file it names (relative to effects.yaml). A value that is not finite:
/// std::runtime_error, nothing returned.
std::string formatEffectsFile(const KinematicModel& m, const Eigen::VectorXd& p, const std::string& robot = "robot.yaml",
                              const std::string& header = "");

struct LoadedEffects {
  KinematicModel model;  ///< the robot and the entries' effects; no geometry or frame parameters
  Eigen::VectorXd p;     ///< the entries' parameter values in model.layout
};
/// Reads effects.yaml: the robot it names, every entry's spec, joint, formula (the spec's: the file
/// cannot say two things) and parameters (names and units those of the spec's parameters, values
/// within sim::physicalBound). Errors are
/// InputError naming the file and the key. sim::jointCorrections(model, p, sample) gives the dq.
LoadedEffects loadEffectsFile(const std::string& path);

}  // namespace orbcal::sim
