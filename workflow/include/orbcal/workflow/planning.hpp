#pragma once
// Configurations and their identifiability, as `orbcal configs` and `orbcal identifiability` run them:
// generated (and chosen by an observability index) configurations written to a CSV, and the
// identifiability report of a configuration set for a measurement kind.
#include <optional>
#include <string>

#include "orbcal/calib/observability.hpp"
#include "orbcal/calib/planning.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/workflow/callbacks.hpp"

namespace orbcal::workflow {

struct ConfigsOptions {
  sim::RobotSource robot;
  std::string scene = "builtin:default_scene.yaml";
  sim::GeneratorSettings gen;                       ///< gen.count: the configurations kept; gen.floor_z_m: a floor
  /// A joint box narrower than the robot's limits (sim::withJointBox), one bound per joint as people type
  /// them: deg for a revolute joint, mm for a prismatic one (sim::jointEdgeScale); empty: none.
  Eigen::VectorXd box_lower_edge, box_upper_edge;
  std::string out = "configurations.csv";           ///< written atomically
  std::optional<calib::ObservabilityIndex> select;  ///< choose gen.count of a pool by this index
  int pool = 1000;                                  ///< with select: the pool generated
  calib::PoseNoiseModel noise;                      ///< with select: R of the whitened pose Jacobian
  int random_subsets = 100;                         ///< with select: random subsets the choice is compared with
  /// Each configuration written this many times in a row: measured so, their scatter is the noise
  /// (pure error) that diagnose and calibrate judge residuals against when no noise is stated.
  int repeat = 1;
  Callbacks callbacks;                              ///< progress (callbacks.hpp)
};
struct ConfigsResult {
  int written = 0;
  sim::GeneratorStats stats;  ///< of the generation (the pool's with select)
  std::string selection;      ///< with select: what was chosen, its indices against random subsets (lines)
};
/// Generates configurations in which the camera sees the whole board (with select: a pool, of which the
/// gen.count that maximise the index are kept) and writes them to o.out. InputError when pool < count.
ConfigsResult runConfigs(const ConfigsOptions& o);

/// `orbcal fk`'s answer, base_T_flange of `arm` at joint values q (SI: rad, m for a prismatic joint). As
/// text: the rotation matrix, the position in mm to the nanometre, roll-pitch-yaw in deg (R = Rz Ry Rx)
/// to 1e-9 deg, and whether q is within the joint limits. With `json`: {"robot", "joints" ({"q1_mm": .., "q2_deg": ..}: each
/// joint in its edge unit, sim::jointEdgeColumn), "base_T_flange" (4x4, metres),
/// "position_mm", "rpy_deg", "within_limits"}, every number exact (sim::jsonNumber: reads back bit for bit).
std::string forwardKinematicsText(const sim::Arm& arm, const Eigen::VectorXd& q, bool json);

struct IdentifiabilityOptions {
  sim::RobotSource robot;
  std::string scene = "builtin:default_scene.yaml";
  std::string configs;          ///< configurations CSV; empty: generated with gen
  sim::GeneratorSettings gen;
  calib::MeasurementSetup setup;
  bool base_known = true;       ///< else the measuring system's frame is estimated with the arm
};
/// The identifiability report of `orbcal identifiability`: every parameter's class, the minimal set and
/// its observability indices. InputError when no configuration gives a measurement of the kind.
std::string runIdentifiability(const IdentifiabilityOptions& o);

}  // namespace orbcal::workflow
