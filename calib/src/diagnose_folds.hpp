#pragma once
// The held-out samples diagnose scores its models on (calib/src/diagnose_folds.cpp): random folds by
// configuration, and "leave the extremes out", the samples with the largest load on each variable that
// drives a candidate, so that no model wins on an advantage that lives only inside the training range.
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "orbcal/calib/diagnose.hpp"

namespace orbcal::calib {

struct Folds {
  std::vector<int> fold;  ///< fold of each observation
  int k = 0;
};

/// Folds by configuration (splitByConfiguration, equal shares): repeated measurements of one
/// configuration stay in one fold, and every fold's training set sees every session.
Folds makeFolds(const std::vector<MarkerObservation>& obs, int k, std::uint64_t seed);

struct CvResult {
  double sse = 0.0;                           ///< held-out whitened SSE
  std::vector<Eigen::VectorXd> residual;      ///< held-out residual per observation
  bool ok = true;
  /// "Leave the extremes out": per driving variable asked for (by column), the held-out whitened SSE of
  /// its extremes (extremesFold) predicted by a fit of the rest.
  std::map<std::string, double> extremes;
  double extremesSse() const;
};

/// The share of configurations "leave the extremes out" holds out per driving variable: a fifth, as a
/// random fold of diagnose's five.
constexpr double kExtremesShare = 0.2;
/// The driving variables (sim::EffectKind::drivingVariables) of `effects`, each once (by column), in order.
std::vector<sim::DrivingVariable> drivingVariablesOf(const std::vector<sim::Effect>& effects, const sim::Arm& arm);
/// "Leave the extremes out": 1 for each observation of the configurations (calib::configurationGroups)
/// that carry the largest load on `v` (its DrivingVariable::Extremes: the largest |x|, both ends, the
/// largest x), the top `share` of them, at least one and never all; 0 for the others.
std::vector<int> extremesFold(const std::vector<MarkerObservation>& obs, const sim::DrivingVariable& v, double share);
/// The measurement that would separate confounded `effects` by their extrapolation: "data beyond the
/// ranges this data covers, where their predictions part: joint 4 torque outside -2.1..21.4 N m (e.g. a
/// heavier payload)"; "" when none of them has a driving variable.
std::string beyondRangeAdvice(const std::vector<sim::Effect>& effects, const sim::Arm& arm, const std::vector<MarkerObservation>& obs);

/// Two effects that claim one cause (a key in common: cyclic:2 and cyclic:2/6, compliance:3 and
/// compliance:3/3) cannot both be in a model.
bool sharesCause(const sim::Effect& a, const sim::Effect& b);
/// A group of held-out samples: those whose (*fold)[k] == value (a random fold; a variable's extremes).
struct HeldOutGroup {
  const std::vector<int>* fold = nullptr;
  int value = 0;
};

/// The normal equations of the whitened system of `m` at zero on its parameters `cols`, column c times
/// scale[c]: per group of `groups` the sums over its samples of A_k^T A_k (N) and A_k^T b_k (g), and over
/// all samples as the last entry; a block of samples at a time, never the stacked columns.
void groupNormals(const MeasurementModel& m, const std::vector<int>& cols, const Eigen::VectorXd& scale,
                  const std::vector<HeldOutGroup>& groups, std::vector<Eigen::MatrixXd>& N, std::vector<Eigen::VectorXd>& g);

/// The alternatives of the selection `selected` (Diagnosis::alternatives) from its kept confounded sets,
/// each fitted by `fit` (side by side).
std::vector<Alternative> alternativesOf(const std::vector<sim::Effect>& selected, const std::vector<ConfoundedSet>& confounded,
                                        const std::function<Fit(const std::vector<sim::Effect>&)>& fit);

}  // namespace orbcal::calib
