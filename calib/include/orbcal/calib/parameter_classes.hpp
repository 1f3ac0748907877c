#pragma once
// Identifiability classes of every parameter of a measurement model over a configuration set,
// from the column space of the stacked Jacobian:
//  - ineffective: its column is zero (the measurement does not see it at all, e.g. a rigid motion of
//    the whole chain under a distance or rotation-angle measurement);
//  - relative: it shares unidentifiable directions with others (its group, sim::Redundancy), and only
//    the group's observable combinations are determined (e.g. d3 + d4 + d5 of the SSRMS);
//  - independent: identifiable on its own.
// The minimal identifiable set is what remains after holding the ineffective parameters and one
// parameter per lost direction of each group (sim::numericalRank's choice, which LSE and LM hold).
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
  /// Markdown: a table of every parameter (its class; for a relative one, its group's observable
  /// combinations), then the minimal identifiable set.
  std::string table() const;
};

/// J: stacked Jacobian (rows whitened where their units differ), columns the parameters `names` in
/// their own units. A column is ineffective when |J_c| typical_c <= sim::kIneffectiveTolerance max
/// |J_c'| typical_c' (sim::ineffectiveColumns; typical empty: 1), i.e. zero up to round-off; the others
/// are analysed by sim::analyzeJacobian at sim::kRankTolerance (columns scaled to unit norm), so groups
/// and their observable combinations are in the parameters' own units, as sim::formatIdentifiability
/// prints them. The held set is sim::numericalRank's, the one the estimators hold.
ParameterClasses classifyParameters(const Eigen::MatrixXd& J, const std::vector<std::string>& names,
                                    const Eigen::VectorXd& typical = {});

/// The classes of a model's parameters at y: its whitened Jacobian with the layout's typical magnitudes.
ParameterClasses classifyParameters(const MeasurementModel& model, const Eigen::VectorXd& y);

}  // namespace orbcal::calib
