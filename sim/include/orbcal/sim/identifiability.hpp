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

/// The relative tolerance of every numerical rank orbcal decides (the estimators' held sets and
/// truncations, the reports' identifiability classes, diagnose's projections): a singular value of a
/// Jacobian with unit-norm columns below kRankTolerance times the largest counts as zero. Such a
/// direction is determined a million times worse than the best-determined one, so the data say
/// nothing about it that a parameter's typical magnitude does not; kept, it is what the LSE step and
/// the LM's normal equations (condition number squared: 1e12, leaving about four of the sixteen
/// digits of a double) amplify noise and round-off along. The exact redundancies of a chain (parallel
/// axes, a frame seen only up to a rigid motion) fall to round-off, far below it.
constexpr double kRankTolerance = 1e-6;

/// A column this far below the largest is round-off of an exactly zero one (1e-16 relative, e.g. a rigid
/// motion of the whole chain under a frame-invariant measurement), not a weak parameter: a weak one
/// whose typical error moves the measurement by 1e-10 of the strongest's is beyond any data anyway.
constexpr double kIneffectiveTolerance = 1e-10;

/// SVD of J with its columns scaled to unit norm (zero columns stay zero): J D = U S V^T, D = diag(scale).
/// The one place where orbcal decides numerical rank (at kRankTolerance everywhere outside tests);
/// numericalRank, identifiability, LSE, LM and diagnose all use it.
struct ScaledSvd {
  Eigen::VectorXd scale;            ///< D: 1 / column norm (1 for a zero column)
  Eigen::VectorXd singular_values;  ///< descending
  Eigen::MatrixXd U;                ///< thin (empty when not asked for)
  Eigen::MatrixXd V;                ///< full (cols x cols)
  int rank = 0;                     ///< singular values above rank_tolerance * sigma_max
  /// Physical null-space directions D V_null (J n = 0), one per column.
  Eigen::MatrixXd nullSpace() const;
};
/// The algorithm of scaledSvd: Jacobi's (the most accurate small singular values and vectors), or
/// divide and conquer (Eigen's BDCSVD: ten times as fast on a flexible model's 200 columns, its singular
/// values as accurate relative to the largest, which is all a rank decision at kRankTolerance and a
/// projection onto the kept directions read).
enum class SvdMethod { kJacobi, kDivideAndConquer };

/// The SVD of J D (D scales J's columns to unit norm). Without `with_u` (the rank, singular values and V
/// alone) a tall J is first reduced to the R factor of its QR decomposition, whose singular values and
/// right vectors are J's: several times cheaper for the stacked Jacobians of hundreds of samples.
ScaledSvd scaledSvd(const Eigen::MatrixXd& J, double rank_tolerance, bool with_u = true, SvdMethod method = SvdMethod::kJacobi);

/// Columns of A that are zero up to round-off: |A_c| typical_c <= zero_tolerance max_c' |A_c'| typical_c'
/// (typical empty: 1). With A whitened and `typical` the layout's, |A_c| typical_c is the measurement
/// change, in sigmas, of a typical error of parameter c, so the columns compare.
std::vector<int> ineffectiveColumns(const Eigen::MatrixXd& A, const Eigen::VectorXd& typical,
                                    double zero_tolerance = kIneffectiveTolerance);

/// What a stacked (whitened) Jacobian determines: the parameters to hold so that the rest are
/// identifiable, and the rank of the rest.
struct NumericalRank {
  int rank = 0;           ///< of the free columns (A's columns less `held`), which is their number
  std::vector<int> held;  ///< sorted: the given ones, the ineffective ones, one per lost direction
};
/// The one decision of numerical rank and of what to hold, at kRankTolerance. With the `held`
/// parameters left out: the ineffective columns (ineffectiveColumns with `typical`; typical empty: 1),
/// then, greedily, the parameter most involved in the remaining null space of the unit-norm-column SVD
/// (the last one on ties) until the free columns have full rank. LSE, LM, the identifiability classes
/// of the reports and the planners all hold this set.
NumericalRank numericalRank(const Eigen::MatrixXd& A, const Eigen::VectorXd& typical = {}, const std::vector<int>& held = {});

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
                                             double rank_tolerance = kRankTolerance, ErrorFrame frame = ErrorFrame::kTool);

/// The same analysis of any stacked (and, where rows have different units, whitened) Jacobian whose
/// columns are the parameters `names`; `num_configs` is for the report only.
IdentifiabilityReport analyzeJacobian(const Eigen::MatrixXd& J, const std::vector<std::string>& names, int num_configs,
                                      double rank_tolerance = kRankTolerance);

/// Human-readable report (what the main job prints).
std::string formatIdentifiability(const IdentifiabilityReport& report);

}  // namespace orbcal::sim
