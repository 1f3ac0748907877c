#pragma once
// Synthetic measured data (`orbcal simulate`): what a laser tracker or motion-capture system would
// record of an arm whose true model has geometric errors and physical effects, measured in an unknown
// frame through an unknown marker. The truth is returned (and written by the command as a model file),
// so tests can hide an effect in the data and check that it is found.
#include <cstdint>
#include <string>
#include <vector>

#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/measured.hpp"
#include "orbcal/sim/model.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::sim {

struct SimulationSpec {
  int samples = 200;                 ///< in all, split evenly over the sessions
  int sessions = 1;
  std::uint64_t seed = 1;
  ErrorSetSpec geometry{"random", 0.05 * kDegToRad, 0.5e-3, 1};  ///< DH errors of the true arm
  std::vector<Effect> effects;       ///< injected
  /// Effect parameter values in the effects' layout order (SI); empty: drawn from N(0, typical) with
  /// magnitudes at least half a typical value (so a drawn effect is never negligible), and the sign
  /// physics gives where it gives one (EffectKind::physicalSign: a compliance is positive, the joint sags).
  Eigen::VectorXd effect_values;
  FrameSharing base = FrameSharing::kShared;
  FrameSharing marker = FrameSharing::kPerSession;
  double base_distance_m = 3.0;      ///< the tracker's distance from the arm's base
  double marker_offset_m = 0.1;      ///< the marker's distance from the flange origin
  double marker_twist_deg = 40.0;    ///< the marker's rotation about the flange z axis
  double noise_position_m = 0.05e-3;  ///< tracker noise, 1 sigma per axis
  double noise_rotation_rad = 0.01 * kDegToRad;
  bool rotation = true;              ///< false: position-only data
  double joint_noise_rad = 0.0;      ///< between the readings and the true joint angles
  /// Payload per session (kg) at the flange, for the gravity torques (needs the robot's masses for
  /// torques; without masses no torque column is written).
  std::vector<double> payload_kg{0.0};
  double torque_noise_Nm = 0.05;
  /// Temperature: T(t) = start + rise (1 - exp(-t / tau)) (a warm-up), degC.
  double temperature_start_C = 20.0, temperature_rise_C = 10.0, temperature_tau_s = 1800.0;
  double sample_period_s = 15.0;     ///< time between samples
  double joint_range_fraction = 0.8;  ///< configurations drawn uniformly within this fraction of each joint's range
  std::vector<int> still_joints;      ///< joints (from 0) held at 0 rad in every configuration (a sweep of the others)
  /// Motion capture: a rigid body of this many marker points on the tool (0: one marker's pose or
  /// position), each at marker_offset_m from the flange in a random direction, measured as positions
  /// (sim/marker_points.hpp); the marker sharing is then shared. Each point of a row is missing with
  /// probability missing_marker_rate (seeded); a row keeps at least one.
  int markers = 0;
  double missing_marker_rate = 0.0;
};

struct SimulatedData {
  MeasuredData data;        ///< what the measuring system recorded (arm = the nominal)
  KinematicModel truth;     ///< the true model: nominal arm, true frames, the effects
  Eigen::VectorXd p_true;   ///< in truth.layout: geometric errors and effect values (frames exact: zero)
};

/// Throws InputError for an inconsistent spec (naming the setting).
SimulatedData simulateMeasured(const Arm& nominal, const SimulationSpec& spec);

}  // namespace orbcal::sim
