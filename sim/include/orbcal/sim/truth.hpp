#pragma once
// The plant of a simulation: the "true arm" that `orbcal run`, `orbcal render` and `orbcal experiment`
// move. `--errors table3|zero|random` injects a named set of DH errors (errors.hpp); `--errors FILE`
// reads an error-set file, which may add physical effects of the catalog (model.hpp) and the
// covariates they read, so that the renderer sees a bent, warm or geared arm:
//
//   format: orbcal-errors-1
//   geometry: table3            # table3 | zero | random | {random: {angle_sigma_deg: 0.3, length_sigma_mm: 1, seed: 1}}
//                               # | one row per joint: [{theta_deg: .., alpha_deg: .., a_mm: .., d_mm: ..}, ...]
//                               #   (with beta_deg: .. too, and only, for a hayati arm; a urdf arm:
//                               #   theta_deg, x_mm, y_mm, z_mm, roll_deg, pitch_deg, yaw_deg)
//   effects:                    # optional; SI values, parameter names as sim::effectBlocks gives them
//     - {spec: "cyclic:2", parameters: {cyclic2_sin1: 2.6e-4, cyclic2_cos1: 0, cyclic2_sin2: 0, cyclic2_cos2: 8.7e-5}}
//     - {spec: "compliance:2", parameters: {c2: 1.0e-4}}
//     - {spec: "distortion", parameters: {dk1: -0.05, dk2: 0.02, dp1: 0, dp2: 0}}   # a camera effect
//   covariates:                 # optional: what the effects read, sample by sample
//     payload_kg: 0             # at the flange; default: the robot file's masses.payload
//     temperature: {start_C: 20, rise_C: 10, tau_s: 1800}   # each key optional: 20, 0, 1800
//     sample_period_s: 15
//
// Sample k (k = 0, 1, ... in the order the arm visits its configurations) is taken at t_k = k *
// sample_period_s and T(t_k) = start_C + rise_C (1 - exp(-t_k / tau_s)); its joint torques are the
// gravity torques (sim/gravity.hpp) of the robot file's masses with the payload, at the true joints;
// each joint's approach direction is the sign of its move from the previous sample's true joints
// (sim::fillApproachDirections on the two; 0 for the first sample and for a joint that did not move).
//
// Every effect must be given with all its parameters. A bare `geometry: random` uses ErrorSetSpec's
// defaults (0.3 deg, 1 mm, seed 1), not the command line's --error-* options, so the file alone fixes
// the plant. One-line InputErrors naming the file and the key for: an unknown key, a missing or
// unknown parameter, an effect listed twice (list every joint in one spec), `compliance` when the
// robot file has no masses and the payload is 0 (no torques to deflect under), `thermal` without
// covariates.temperature (a constant 20 degC, the reference, would hide it), and `mount` (a marker
// re-mounted between sessions: a rendered dataset is one session). `drift` moves the base with t_k.
// `distortion` (sim::distortionBlock) is a camera effect: the images are taken through the scene
// camera's OpenCV distortion plus (dk1, dk2, dp1, dp2), while the dataset's scene.yaml keeps the
// scene's, so the calibration sees lens distortion its camera model does not have (TrueArm::camera).
#include <Eigen/Geometry>
#include <optional>
#include <string>

#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/model.hpp"
#include "orbcal/sim/scene.hpp"

namespace orbcal::sim {

inline constexpr const char* kErrorSetFormat = "orbcal-errors-1";
/// The name of the error-set file's copy in a dataset folder.
inline constexpr const char* kDatasetErrorSetFile = "errors.yaml";

/// What a simulated plant's effects read, as a function of the sample index k.
struct CovariateProfile {
  double payload_kg = 0.0;            ///< at the flange, COM from the robot file's masses.payload
  double temperature_start_C = 20.0;  ///< T(t) = start + rise (1 - exp(-t / tau))
  double temperature_rise_C = 0.0;
  double temperature_tau_s = 1800.0;
  double sample_period_s = 15.0;      ///< t_k = k * period
  double temperatureAt(double t_s) const;
};

/// The plant: nominal arm + DH errors + effects + the covariates they read.
struct TrueArm {
  std::string name;            ///< "table3", "zero", "random", or the error-set file as given
  std::string file_text;       ///< the error-set file's bytes (copied into datasets); empty for a named set
  KinematicModel model;        ///< frames known (identity), geometry, effects; arm = nominal with the payload
  Eigen::VectorXd p;           ///< in model.layout: the DH errors, then the effects' values (SI)
  CovariateProfile covariates;
  /// The `distortion` camera effect: (dk1, dk2, dp1, dp2) added to the scene camera's (k1, k2, p1, p2).
  Eigen::Vector4d camera_distortion_delta = Eigen::Vector4d::Zero();
  bool has_camera_distortion = false;  ///< the error-set file lists `distortion`

  bool fromFile() const { return !file_text.empty(); }
  /// Chain effects or a camera effect.
  bool hasEffects() const { return !model.effects.empty() || has_camera_distortion; }
  /// The camera the plant's images are taken with: `scene_camera` with the distortion effect added.
  Camera camera(const Camera& scene_camera) const;
  /// The DH errors, arm.numParams() of them (y order; what manifests store as true_errors).
  Eigen::VectorXd geometryErrors() const;
  /// The covariates of the k-th sample at joints q (q_previous: the sample before, or null for the first).
  JointSample sample(int k, const Eigen::VectorXd& q, const Eigen::VectorXd* q_previous) const;
  /// base_T_flange of the plant (drift included: D(t) base_T_flange, the base frame at t = 0).
  /// Without effects exactly forwardKinematics(withErrors(nominal, geometryErrors()), q).
  Eigen::Isometry3d flangePose(const JointSample& s) const;
  Eigen::Isometry3d flangePose(int k, const Eigen::VectorXd& q, const Eigen::VectorXd* q_previous) const;
};

/// True for the named sets makeErrorSet knows: table3, zero, random.
bool isNamedErrorSet(const std::string& name);
/// spec.name table3 | zero | random (makeErrorSet, no effects) or the path of an error-set file.
/// Throws InputError naming `what` (e.g. "--errors") for a file that cannot be read, or the file and
/// the key for one that is wrong.
TrueArm makeTrueArm(const Arm& nominal, const ErrorSetSpec& spec, const std::string& what);
/// Parses the text of an error-set file; `source` names it in messages.
TrueArm parseTrueArm(const Arm& nominal, const std::string& text, const std::string& source);
/// DH errors only (no effects, default covariates).
TrueArm geometricTrueArm(const Arm& nominal, const Eigen::VectorXd& y, const std::string& name = "custom");
/// The plant of a simulated dataset: its errors.yaml (true_errors.file) when it has one, checked
/// against the manifest's true_errors, else the manifest's true_errors alone; nullopt without
/// true_errors (real data).
std::optional<TrueArm> datasetTrueArm(const Dataset& dataset);

/// The injected effects for people, one line per effect ("  cyclic:2  cyclic2_sin1 +0.0149 deg, ...")
/// in display units, then the covariates they read; "" without effects.
std::string formatEffects(const TrueArm& truth);

}  // namespace orbcal::sim
