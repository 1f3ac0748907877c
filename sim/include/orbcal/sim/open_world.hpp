#pragma once
// "Open-world" measured tracker datasets: data whose hidden cause lies outside (or beyond) the effect
// catalog of sim/model.hpp, to test that `orbcal diagnose` never calls such data clean. The generator is
// written independently of the catalog: its forward model composes the DH rows (sim::linkTransform,
// sim::forwardKinematics) and reads gravity torques (sim::gravityTorques) only; it uses no
// KinematicModel, Effect, predictMarkerPose or truth.cpp injector.
//
// The measurement: world_T_marker = world_T_base * base_T_flange(true arm, true angles [, bending])
// * flange_T_marker, plus Gaussian tracker noise (per axis: position sigma_p, rotation sigma_r as a
// rotation vector applied in the world frame). The true arm is the nominal one with DH errors drawn
// from N(0, 0.3 deg) and N(0, 1 mm); world_T_base (metres away, random rotation) and flange_T_marker
// (~0.1 m, random rotation) are random and unknown to the fit (registration shared). The readings q
// (drawn uniformly within the joint limits) are written, the true angles are q + dq:
//
//   harmonic3/4   dq_j = a sin(k q_j + phi), k = 3 or 4 (transmission error beyond the catalog's 1-2)
//   coupling      dq_i = k q_j, i != j (joint i's reading off by a multiple of joint j's, e.g. a
//                 differential wrist)
//   stiffening    dq_j = c1 tau_j + c3 tau_j^3, with |c3| tau_max^2 >= |c1| (the cubic term carries at
//                 least half the deflection at the largest |tau_j| of the dataset), same sign
//   link_bending  no dq: the body moved by joint i (from the origin of its DH frame to the origin of the
//                 next frame, or the flange for the last joint; length L) is a cantilever under the
//                 gravity force F of everything it carries (the later links' masses and the payload):
//                 at its far end a displacement F_perp L^3 / (3 E I) and a tilt |F_perp| L^2 / (2 E I)
//                 about L^ x F_perp^ (towards the load), F_perp the part of F perpendicular to the link;
//                 inserted in the chain at the far end. The amplitude is the compliance 1 / (E I).
//   two_catalog   dq_a = c tau_a (compliance of joint a) and dq_b = A sin(q_b + phi) (first harmonic of
//                 joint b), a != b
//
// tau are the static gravity torques (sim/gravity.hpp) of the mass model at the readings, with a payload:
// the robot's masses, or, for a robot file without link masses, an assumed model (each link a mass of
// link_density x its length, at its mid-point). They are written as the torque covariate.
//
// Signal-to-noise ratio (the definition every amplitude is scaled by): the RMS over the dataset's
// configurations of the cause's raw effect on the measured 3-D position, |p(with cause) - p(without)|
// (same true arm, frames and readings, no noise), equals snr x sqrt(3) sigma_p, the 3-D RMS of the
// tracker's position noise. What a re-fit of geometry and registration could absorb is NOT removed.
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "orbcal/sim/arm.hpp"
#include "orbcal/sim/measured.hpp"

namespace orbcal::sim {

enum class OpenCauseKind { kHarmonic3, kHarmonic4, kCoupling, kStiffening, kLinkBending, kTwoCatalog };

/// "harmonic3", "harmonic4", "coupling", "stiffening", "link_bending", "two_catalog".
const char* openCauseName(OpenCauseKind kind);
const std::vector<OpenCauseKind>& openCauseKinds();
/// The kind of a name above; std::invalid_argument naming the valid ones otherwise.
OpenCauseKind parseOpenCause(const std::string& name);

/// A hidden cause with its values (SI). Joints numbered from 0.
struct OpenCause {
  OpenCauseKind kind = OpenCauseKind::kHarmonic3;
  int joint_a = 0;   ///< harmonic: j; coupling: i (the reading that is off); stiffening: j; link_bending: the
                     ///< joint whose body bends; two_catalog: a (compliance)
  int joint_b = -1;  ///< coupling: j (the source); two_catalog: b (cyclic); else -1
  double a = 0.0;    ///< harmonic: a (rad); coupling: k (rad/rad); stiffening: c1 (rad/(N m));
                     ///< link_bending: 1/(E I) (1/(N m^2)); two_catalog: c (rad/(N m))
  double b = 0.0;    ///< stiffening: c3 (rad/(N m)^3); two_catalog: A (rad); else 0
  double phase_rad = 0.0;  ///< harmonic and two_catalog's cyclic term
  int harmonic = 0;        ///< k of harmonic3/4 (3 or 4); two_catalog's cyclic term is 1
};

struct OpenWorldSpec {
  Arm arm;                                       ///< the nominal robot (e.g. loadArm("builtin:iiwa7.yaml"))
  OpenCauseKind cause = OpenCauseKind::kHarmonic3;
  int joint_a = -1, joint_b = -1;                ///< the cause's joints (see OpenCause); -1: drawn (seeded)
  double snr = 5.0;                              ///< see the header comment
  int samples = 200;
  double noise_position_m = 0.1e-3;              ///< tracker, 1 sigma per axis
  double noise_rotation_rad = 0.01 * 3.14159265358979323846 / 180.0;
  /// Joint readings vs the true angles, 1 sigma per joint: each measurement's true angles are the
  /// readings + the cause's dq + N(0, noise_joint_rad) (its own draw; 0: none). Stated in the data.
  double noise_joint_rad = 0.0;
  /// Measurements of each configuration: the same readings, fresh tracker and joint noise (pure error).
  int repeats = 1;
  double dh_angle_sigma_rad = 0.3 * 3.14159265358979323846 / 180.0;  ///< DH errors of the true arm
  double dh_length_sigma_m = 1e-3;
  double base_distance_m = 3.0;                  ///< |world_T_base translation|
  double marker_offset_m = 0.1;                  ///< |flange_T_marker translation|
  double payload_kg = 2.0;                       ///< at payload_com_flange_m
  Eigen::Vector3d payload_com_flange_m = Eigen::Vector3d(0.0, 0.0, 0.05);
  double link_density_kg_per_m = 100.0;          ///< the assumed mass model, for a robot without link masses
  std::uint64_t seed = 1;
};

/// What was hidden, and everything needed to recompute the measurements without noise.
struct OpenWorldTruth {
  OpenCause cause;
  Arm arm;                        ///< the true arm: nominal + dh_errors (its `masses` untouched)
  Eigen::VectorXd dh_errors;      ///< in sim::Arm's y layout, SI
  MassModel masses;               ///< the torques' and the bending's mass model, payload included
  Eigen::Isometry3d world_T_base = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d flange_T_marker = Eigen::Isometry3d::Identity();
  double snr = 0.0;
  double target_rms_m = 0.0;      ///< snr x sqrt(3) sigma_p
  double effect_rms_m = 0.0;      ///< achieved RMS of the raw position effect
};

struct OpenWorldDataset {
  MeasuredData data;  ///< readings, torques, noisy poses; arm = the nominal; noise stated; one session
  OpenWorldTruth truth;
};

/// Draws a dataset (deterministic per spec.seed). std::invalid_argument for an arm or cause the spec
/// cannot serve (fewer than 2 joints for coupling/two_catalog, no gravity-loaded joint for stiffening
/// or compliance, a given joint out of range).
OpenWorldDataset generateOpenWorld(const OpenWorldSpec& spec);

/// dq (true angle - reading) of a joint-space cause at readings q and torques tau; zero for link_bending.
Eigen::VectorXd causeJointOffsets(const OpenCause& cause, const Eigen::VectorXd& q, const Eigen::VectorXd& tau);

/// The cantilever's deflection as a transform of the link's frame: x -> p + delta + R (x - p), with p
/// the link's far end (from the frame's origin), delta = F_perp L^3 compliance / 3 and R a rotation by
/// |F_perp| L^2 compliance / 2 about L^ x F_perp^; `force_N` in the same frame; compliance = 1/(E I).
Eigen::Isometry3d cantileverDeflection(const Eigen::Vector3d& far_end_m, const Eigen::Vector3d& force_N,
                                       double compliance);

/// The noiseless measured pose world_T_marker of readings q (torques tau, as written), with or without
/// the hidden cause; `joint_error` (empty: none) is added to the true angles (the joint readings' noise).
Eigen::Isometry3d openWorldMarkerPose(const OpenWorldTruth& truth, const Eigen::VectorXd& q, const Eigen::VectorXd& tau,
                                      bool with_cause, const Eigen::VectorXd& joint_error = {});

/// Writes the dataset as a measurement description + CSV (sim::writeMeasuredData; noise in the `noise:`
/// key) and truth.yaml beside it (the cause, its joints from 1, values, SNR). `robot_file` is what the
/// description names (e.g. "builtin:iiwa7.yaml"). Returns the description's path; loadMeasuredData reads
/// it back.
std::string writeOpenWorld(const OpenWorldDataset& dataset, const std::string& folder, const std::string& robot_file);

}  // namespace orbcal::sim
