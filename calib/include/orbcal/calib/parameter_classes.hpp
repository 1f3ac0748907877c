#pragma once
// Identifiability classes of every parameter of a measurement model over a configuration set (issue 10
// item 3), from the column space of the stacked Jacobian:
//  - ineffective: its column is zero (the measurement does not see it at all, e.g. a rigid motion of
//    the whole chain under a distance or rotation-angle measurement);
//  - relative: it shares unidentifiable directions with others (its group, sim::Redundancy), and only
//    the group's observable combinations are determined (e.g. d3 + d4 + d5 of the SSRMS);
//  - independent: identifiable on its own.
// The minimal identifiable set is what remains after holding the ineffective parameters and one
// parameter per lost direction of each group (unidentifiableToFix's choice, which LSE and LM hold).
#include <Eigen/Core>
#include <string>
#include <vector>

#include "orbcal/calib/estimators.hpp"
#include "orbcal/calib/model.hpp"
#include "orbcal/sim/identifiability.hpp"

namespace orbcal::calib {

enum class ParamClass { kIndependent, kRelative, kIneffective };
const char* paramClassName(ParamClass c);  ///< "independent", "relative", "ineffective"

struct ParameterClasses {
  std::vector<std::string> names;
  std::vector<ParamClass> classes;         ///< per parameter
  std::vector<int> group;                  ///< per parameter: its index in `groups` if relative, else -1
  std::vector<sim::Redundancy> groups;     ///< the relative groups, with their observable combinations
  std::vector<int> ineffective, relative, independent;  ///< parameter indices by class, ascending
  std::vector<int> held;                   ///< ineffective + one per lost direction of each group
  std::vector<int> minimal;                ///< the minimal identifiable set: every parameter not held
  int rank = 0;                            ///< of the stacked Jacobian
  std::string describe() const;            ///< one line per class and per group
};

/// J: stacked Jacobian whose columns compare (whitened rows, columns times the typical magnitudes, as
/// classifyParameters(model, ...) builds it). A column is ineffective when its norm is at most
/// zero_tolerance times the largest; the rest are analysed by sim::analyzeJacobian at rank_tolerance.
ParameterClasses classifyParameters(const Eigen::MatrixXd& J, const std::vector<std::string>& names,
                                    double rank_tolerance = 1e-9, double zero_tolerance = kIneffectiveTolerance);

/// The classes of a model's parameters at y: its whitened Jacobian with columns times the layout's
/// typical magnitudes (the measurement change, in sigmas, of a typical error).
ParameterClasses classifyParameters(const MeasurementModel& model, const Eigen::VectorXd& y,
                                    double rank_tolerance = 1e-9);

}  // namespace orbcal::calib
