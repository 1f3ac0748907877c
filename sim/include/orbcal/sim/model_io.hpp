#pragma once
// The calibrated-model file (`model.yaml`): a robot file for the geometry (the nominal DH rows with
// the identified errors folded in), the registration frames, the effects with their parameter values,
// and, for people, every fitted parameter with its 1-sigma. `orbcal calibrate` writes it, `orbcal
// simulate` writes the truth of a simulated dataset in the same format, `orbcal evaluate` reads both.
//
//   format: orbcal-model-2             # orbcal-model-1 is read too, unless it holds a compliance (its
//                                      # sign was the other; sim/src/effects/compliance.cpp)
//   robot: robot.yaml                  # relative to this file (written beside it)
//   sessions: 2
//   registration:
//     base: shared                     # shared | per_session | known
//     marker: per_session
//     world_T_base: [{xyz_m: [...], rpy_deg: [...]}]         # one, or one per session
//     flange_T_marker: [{...}, {...}]
//   effects:
//     - {spec: "compliance:2,4", parameters: {c2: 1.2e-05, c4: 3.1e-06},  # SI values; c > 0 sags
//        range: {tau2_Nm: [-61.2, 58.0], tau4_Nm: [-20.4, 21.9]}}       # optional: what its driving variables
//                                      # covered in the data it was fitted on (display units, as the key says)
//   alternatives: [alternative1.yaml]  # optional (diagnose): models the data could not tell from this one,
//                                      # relative to this file; `orbcal evaluate` compares their predictions
//   parameters:                        # for people: every fitted parameter (SI) and its 1-sigma (finite, >= 0)
//     - {name: theta2, effect: geometry, value: 1e-4, sigma: 2e-6, unit: rad, held: false}
//
// loadModelFile checks `parameters:` against the model above it, so the file cannot say two things:
// one row per parameter of the fitted model (geometry, registration, effects, in the layout's order)
// with its name, block and unit, every value within its physical bound (sim::physicalBound), an
// effect's value equal to the one under `effects:`.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "orbcal/sim/model.hpp"

namespace orbcal::sim {

struct ParameterRow {
  std::string name, effect, unit;
  double value = 0.0, sigma = 0.0;  ///< SI; sigma NaN when not known
  bool held = false;
};

/// Writes `robot_name` (the model's arm) and `model_name` into `folder` atomically. `p` holds the
/// effect parameters (sim::foldParameters' p); `rows` are listed under `parameters:` (a value or sigma
/// that is not finite: std::runtime_error, nothing written). Returns the path of the model file.
std::string writeModelFile(const KinematicModel& model, const Eigen::VectorXd& p, const std::vector<ParameterRow>& rows,
                           const std::string& folder, const std::string& header, const std::string& model_name = "model.yaml",
                           const std::string& robot_name = "robot.yaml", const std::vector<std::string>& alternatives = {});

/// The robot that the file `path` (a model or effects file, parsed as `root`) names at its key `robot`:
/// a path relative to the file's folder, an absolute one, or builtin:NAME. Errors name the file and key.
Arm loadRobotNamedBy(const ConfigNode& root, const std::string& path);

struct LoadedModel {
  KinematicModel model;
  Eigen::VectorXd p;  ///< effect parameters in model.layout (geometry and frames zero)
  std::vector<std::string> alternatives;  ///< model files the data could not tell from it (paths as readable from here)
};
/// Reads a model file; errors are InputError naming the file and the key: effect values outside their
/// physical bounds, and a parameter list that does not match the model (see above).
LoadedModel loadModelFile(const std::string& path);

}  // namespace orbcal::sim
