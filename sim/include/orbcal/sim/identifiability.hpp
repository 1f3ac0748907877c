#pragma once
// Identifiability of the parameter errors from a configuration set: SVD of the identification
// Jacobian stacked over the configurations, with its columns scaled to unit norm (so that angles and
// lengths, rad and m, compare), the numerical rank, the condition number, and the unidentifiable
// directions named in parameter terms.
//
// A redundancy is a group of parameters that share null-space directions. For the SSRMS (joints 3, 4,
// 5 parallel, fixed base and tool frames) it is {d3, d4, d5}: two null directions, so only their sum
// d3 + d4 + d5 is observable. The report names both what is lost and what stays observable.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "orbcal/sim/arm.hpp"
#include "orbcal/sim/jacobian.hpp"

namespace orbcal::sim {

/// The stacked Jacobian (6 n_configs x arm.numParams()) over a configuration set.
Eigen::MatrixXd stackedJacobian(const Arm& arm, const std::vector<Eigen::VectorXd>& configs,
                                ErrorFrame frame = ErrorFrame::kTool);

/// SVD of J with its columns scaled to unit norm (zero columns stay zero): J D = U S V^T, D = diag(scale).
/// The one place where orbcal decides numerical rank; identifiability, LSE and LM all use it.
struct ScaledSvd {
  Eigen::VectorXd scale;            ///< D: 1 / column norm (1 for a zero column)
  Eigen::VectorXd singular_values;  ///< descending
  Eigen::MatrixXd U;                ///< thin (empty when not asked for)
  Eigen::MatrixXd V;                ///< full (cols x cols)
  int rank = 0;                     ///< singular values above rank_tolerance * sigma_max
  /// Physical null-space directions D V_null (J n = 0), one per column.
  Eigen::MatrixXd nullSpace() const;
};
/// The SVD of J D (D scales J's columns to unit norm). Without `with_u` (the rank, singular values and V
/// alone) a tall J is first reduced to the R factor of its QR decomposition, whose singular values and
/// right vectors are J's: several times cheaper for the stacked Jacobians of hundreds of samples.
ScaledSvd scaledSvd(const Eigen::MatrixXd& J, double rank_tolerance, bool with_u = true);

struct Redundancy {
  std::vector<int> params;        ///< parameter indices of the group
  std::vector<std::string> names; ///< their names
  int lost = 0;                   ///< null-space dimension within the group
  /// Observable combinations within the group, one per row (coefficients over `params`, largest = 1).
  Eigen::MatrixXd observable;
  std::string describe() const;   ///< e.g. "d3, d4, d5: 2 directions lost; observable: d3 + d4 + d5"
};

struct IdentifiabilityReport {
  int num_params = 0;
  int num_configs = 0;
  int num_rows = 0;                 ///< rows of the stacked Jacobian
  int rank = 0;
  double condition_number = 0.0;    ///< sigma_max / sigma_min over the identifiable part (rank)
  Eigen::VectorXd singular_values;  ///< of the column-scaled stacked Jacobian, descending
  Eigen::MatrixXd null_space;       ///< physical null-space directions (num_params x (num_params - rank))
  std::vector<Redundancy> redundancies;
  double rank_tolerance = 0.0;      ///< relative to sigma_max
};

/// rank_tolerance: singular values below rank_tolerance * sigma_max count as zero.
IdentifiabilityReport analyzeIdentifiability(const Arm& arm, const std::vector<Eigen::VectorXd>& configs,
                                             double rank_tolerance = 1e-9, ErrorFrame frame = ErrorFrame::kTool);

/// The same analysis of any stacked (and, where rows have different units, whitened) Jacobian whose
/// columns are the parameters `names`; `num_configs` is for the report only.
IdentifiabilityReport analyzeJacobian(const Eigen::MatrixXd& J, const std::vector<std::string>& names, int num_configs,
                                      double rank_tolerance = 1e-9);

/// Human-readable report (what the main job prints).
std::string formatIdentifiability(const IdentifiabilityReport& report);

}  // namespace orbcal::sim
