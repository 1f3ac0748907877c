#pragma once
// Every measurement kind orbcal can calibrate from, as one choice over one set of configurations
// the absolute pose (Wang et al. 2023: a camera measures the end-effector pose), the
// position only (a laser tracker without orientation), the distance and/or the rotation angle between
// pairs of configurations (Jia et al. 2019: frame-free, so the board-to-base transform is never
// needed), and the laser range to a plane (Liu et al. 2012). One place builds the model of a kind, so
// the identifiability classes, the observability indices, pose selection and the simulation studies
// treat every kind alike:
//  - planningModel: before anything is measured, the model whose observations are the nominal
//    predictions (zero innovation at y = 0): its Jacobian is all that identifiability and selection use;
//  - modelFromPoses: the model of a kind from measured (or simulated) marker poses: absolute and
//    position-only use them as they are; the relative kinds pair them (relativePairs).
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "orbcal/calib/marker_model.hpp"
#include "orbcal/calib/model.hpp"
#include "orbcal/calib/relative_models.hpp"
#include "orbcal/sim/model.hpp"

namespace orbcal::calib {

enum class MeasurementKind { kPose, kPosition, kDistance, kRotation, kDistanceRotation, kRange };

/// "pose", "position", "distance", "rotation", "dr" (distance and rotation), "range"; throws
/// sim::InputError naming `what` (e.g. "--model") and the choices otherwise.
MeasurementKind parseMeasurementKind(const std::string& text, const std::string& what);
/// The inverse of parseMeasurementKind.
std::string measurementKindName(MeasurementKind kind);
/// What it measures and whose system it is, one line for reports, e.g. "distance and rotation angle
/// between pairs of configurations (Jia et al. 2019)".
std::string measurementKindDescription(MeasurementKind kind);
/// The kinds whose measurement is a pose or a part of one (every kind but kRange).
bool isPoseKind(MeasurementKind kind);
/// The kinds measured between pairs of configurations (distance, rotation, dr).
bool isRelativeKind(MeasurementKind kind);

/// How the measurements of a kind are taken and how noisy they are.
struct MeasurementSetup {
  MeasurementKind kind = MeasurementKind::kPose;
  /// Pose noise per axis (pose, position; the relative kinds: sqrt(2) x, see relativePairs), and the
  /// joint noise carried into R (the relative kinds: into each pair's sigmas, addRelativeJointNoise).
  MarkerNoise noise;
  Pairing pairing = Pairing::kReference;  ///< relative kinds
  int reference = 0;                      ///< relative kinds with kReference: the reference pose's index
  RelativeGuard guard;                    ///< relative kinds
  LaserBeam beam;                         ///< range: the beam in the marker frame
  Plane plane = Plane::seed004();         ///< range: the nominal plane and its identified coefficients
  double range_sigma_m = 0.2e-3;          ///< range: one reading (Liu et al. 2012: 0.2 mm)
  int range_repeats = 10;                 ///< range: readings averaged per configuration (Liu et al. 2012: 10)
};

/// The relative rows of a relative kind (distance, rotation or both); throws std::invalid_argument
/// for the other kinds.
RelativeRows relativeRows(MeasurementKind kind);

/// The model of setup.kind over `samples`, each observation the prediction of `km` at p = 0 (for the
/// range kind: of the nominal plane, at the samples whose beam hits it). For identifiability,
/// observability and selection before anything is measured. The samples of a relative kind become
/// pairs (a sample per pair; with kReference, none for the reference itself); pairs the guard leaves
/// without a row, and range samples whose beam is parallel to the plane, are left out.
std::unique_ptr<MeasurementModel> planningModel(const MeasurementSetup& setup, const sim::KinematicModel& km,
                                                const std::vector<sim::JointSample>& samples);

/// The model of a pose kind from marker poses (measured, or simulatePoses'). Throws
/// std::invalid_argument for kRange (a range is not a pose).
std::unique_ptr<MeasurementModel> modelFromPoses(const MeasurementSetup& setup, const sim::KinematicModel& km,
                                                 std::vector<MarkerObservation> poses);

/// Samples of bare joint configurations (no covariates).
std::vector<sim::JointSample> samplesOf(const std::vector<Eigen::VectorXd>& configs);

/// Simulated marker poses: `truth` at p_true driven by each commanded sample's joints plus Gaussian
/// joint noise (joint_noise_sigma_rad), each pose perturbed on the right by N(0, sigma^2) per axis
/// (noise's position and rotation sigmas); the observations carry the commanded samples, as
/// real readings do. Seeded through rng.
std::vector<MarkerObservation> simulatePoses(const sim::KinematicModel& truth, const Eigen::VectorXd& p_true,
                                             const std::vector<sim::JointSample>& commanded, double joint_noise_sigma_rad,
                                             const MarkerNoise& noise, std::mt19937_64& rng);

}  // namespace orbcal::calib
