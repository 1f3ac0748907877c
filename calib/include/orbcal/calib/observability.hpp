#pragma once
// Observability indices of a configuration set and pose selection (O3: Liu et al. 2012's criterion).
//
// The indices are functions of the singular values sigma_1 >= ... >= sigma_m of the stacked
// identification Jacobian, m the number of parameters analysed (the held, unidentifiable ones left
// out), n_s the number of samples (configurations). All are "larger is better":
//   O1 = (sigma_1 ... sigma_m)^(1/m) / sqrt(n_s)   Borm & Menq 1991 (IJRR 10(1)), D-optimality
//   O2 = sigma_min / sigma_max                     the inverse condition number; Driels & Pathre 1990
//                                                  (IEEE TRA 6(5)) minimise sigma_max / sigma_min
//   O3 = sigma_min                                 Nahvi, Hollerbach & Hayward 1994 (ICRA), E-optimality
//   O4 = sigma_min^2 / sigma_max                   Nahvi & Hollerbach 1996 (ICRA), the noise
//                                                  amplification index: sigma_max over the condition number
//   O5 = 1 / (1/sigma_1 + ... + 1/sigma_m)         Sun & Hollerbach 2008 (ICRA), related to A-optimality
// (the text attributes sigma_min^2 / sigma_max to O5 as well; we follow Sun & Hollerbach's
// numbering, where O4 is the noise amplification index and O5 the harmonic-sum index).
//
// Rows: whitened, R_k^-1/2 H_k (calib::whitenedJacobian), so each row is in units of its own noise sigma
// and position and orientation rows compare. Columns: scaled by the layout's typical magnitudes
// (sim::ParamLayout::typical(); for DH errors kTypicalAngle and kTypicalLength), so a column is "noise
// sigmas produced by a typical error of that parameter". We use this rather than unit-norm columns
// because (a) it is physically meaningful for mixed units (rad, m, and the effects' own units), and
// (b) it does not depend on the configurations: unit-norm scaling rescales every column with the set,
// so two candidate sets would be measured in different units, which defeats comparing them and rules
// out rank-one updates of the information matrix during selection. Numerical rank is still decided
// by sim::scaledSvd (unit-norm columns), the one place that decides it.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "orbcal/calib/marker_model.hpp"
#include "orbcal/calib/model.hpp"
#include "orbcal/sim/identifiability.hpp"

namespace orbcal::calib {

enum class ObservabilityIndex { kO1, kO2, kO3, kO4, kO5 };
/// "O1" .. "O5" (case-insensitive); throws sim::InputError naming `what` otherwise.
ObservabilityIndex parseObservabilityIndex(const std::string& text, const std::string& what = "--select");
std::string observabilityIndexName(ObservabilityIndex index);

struct ObservabilityIndices {
  double o1 = 0, o2 = 0, o3 = 0, o4 = 0, o5 = 0;
  int rank = 0;         ///< numerical rank (sim::scaledSvd); from the eigenvalues during selection
  int num_params = 0;   ///< m: columns analysed
  int num_samples = 0;  ///< n_s
  double value(ObservabilityIndex index) const;
};

/// One line: "O1 .., O2 .., O3 .., O4 .., O5 ..; rank r of m, n_s samples".
std::string formatIndices(const ObservabilityIndices& indices);

/// The indices from the singular values (any order, negative ones read as 0) of a scaled Jacobian.
/// `rank` is left to the caller.
ObservabilityIndices indicesFromSingularValues(const Eigen::VectorXd& sigma, int num_samples);

/// The indices of a stacked Jacobian A (whitened rows, scaled columns, as above) over num_samples
/// samples; the rank from sim::scaledSvd(A, rank_tolerance).
ObservabilityIndices observabilityIndices(const Eigen::MatrixXd& A, int num_samples, double rank_tolerance = sim::kRankTolerance);

/// Per-sample blocks of the model at y: R_k^-1/2 H_k with the `held` columns left out and the others
/// multiplied by their typical magnitudes. The input of observabilityIndices (stacked) and selection.
std::vector<Eigen::MatrixXd> observabilityBlocks(const MeasurementModel& model, const Eigen::VectorXd& y,
                                                 const std::vector<int>& held);
/// Stacks blocks (all, or those listed in `subset`).
Eigen::MatrixXd stackBlocks(const std::vector<Eigen::MatrixXd>& blocks, const std::vector<int>& subset = {});

/// The indices of `model` at y with `held` left out (observabilityBlocks, stacked).
ObservabilityIndices observability(const MeasurementModel& model, const Eigen::VectorXd& y, const std::vector<int>& held,
                                   double rank_tolerance = sim::kRankTolerance);

/// A pose model for planning, before anything is measured: one sample per configuration, its
/// observation the nominal flange pose (the innovation is zero at y = 0 and never used), the noise
/// from `noise` (Source::kFixed: the observations carry no covariance of their own).
MarkerPoseModel posePlanningModel(const sim::Arm& nominal, const std::vector<Eigen::VectorXd>& configs,
                                  PoseNoiseModel noise);

struct SelectionOptions {
  ObservabilityIndex index = ObservabilityIndex::kO3;
  std::uint64_t seed = 1;       ///< the order candidates are tried in, which breaks ties
  int max_exchange_passes = 5;  ///< pair-exchange passes after DETMAX (each: n x pool evaluations)
  /// Full rank during the greedy start: every eigenvalue of A^T A above (rank_tolerance sigma_max)^2.
  double rank_tolerance = sim::kRankTolerance;
  /// Sets whose index values lie within this relative distance count as tied and are ordered by log
  /// det(A^T A) (O1's ordering). This matters for the extreme-value indices O2, O3, O4: on the SSRMS
  /// with joint noise in R, sigma_min has a ceiling that many sets reach (O3 = 1.59 for 15 of 300 in
  /// every pool tried), and pure O3 is then indifferent between a good set and a poor one. 0: pure index.
  double tie_tolerance = 1e-3;
};

struct Selection {
  std::vector<int> chosen;        ///< indices into the pool, ascending
  ObservabilityIndices indices;   ///< of the chosen set (observabilityIndices of its stacked blocks)
  double greedy_value = 0.0;      ///< the chosen index after the greedy start, before the exchanges
  int exchanges = 0;              ///< accepted DETMAX excursions and pair exchanges
  double seconds = 0.0;
};

/// Chooses n of the pool's samples (blocks from observabilityBlocks) to maximise options.index:
///  1. greedy forward selection: the candidate that raises the rank of the information matrix
///     M = sum A_k^T A_k most, ties (and the steps before full rank) by log det(M + delta I), then,
///     once the rank is full, the candidate that maximises the index (ties: options.tie_tolerance);
///  2. DETMAX excursions (Mitchell 1974): add the best candidate, remove the member whose loss hurts
///     least, while that improves the index;
///  3. pair exchanges (Fedorov 1972): the best swap of a member for a candidate, while it improves.
/// Every evaluation is a rank-k update of the m x m information matrix and its eigenvalues
/// (sigma_i^2), never an SVD of a tall matrix. Deterministic for a seed.
/// Throws std::invalid_argument if n is not in [1, pool size].
Selection selectConfigurations(const std::vector<Eigen::MatrixXd>& blocks, int n, const SelectionOptions& options = {});

/// The index averaged over `subsets` random subsets of n of the pool (seeded), for comparison.
double meanRandomIndex(const std::vector<Eigen::MatrixXd>& blocks, int n, ObservabilityIndex index, int subsets,
                       std::uint64_t seed);
/// n distinct indices of [0, pool) drawn uniformly (seeded), ascending.
std::vector<int> randomSubset(int pool, int n, std::uint64_t seed);

}  // namespace orbcal::calib
