#pragma once
// The score tests' statistics (Diagnoser::scoreTests) from sums over the samples, a block of samples at
// a time: the R factor of the current model's free columns and the residual, and the cross products of
// every candidate's columns; never the stacked columns (a long log's are gigabytes).
#include <Eigen/Dense>
#include <vector>

#include "orbcal/calib/marker_model.hpp"

namespace orbcal::calib {

/// One candidate's columns: of the model of its layer, each times its typical magnitude.
struct CandidateColumns {
  std::size_t layer = 0;
  std::vector<int> cols;
  Eigen::VectorXd scale;
};

/// One candidate's score test against the current model's fit.
struct ScoreStatistic {
  int rank = 0;           ///< directions beyond the current model that move the whitened data by > 1 sigma
  double score = 0.0;     ///< the residual's squared projection on them / the residual variance
  double absorbed = 1.0;  ///< share of the columns' norm the current model absorbs
};

struct ScoreStatistics {
  std::vector<ScoreStatistic> candidates;
  double dof = 1.0;  ///< of the residual variance (rows - rank of the current model)
};

/// The whitened system of `layers` (one model per layer of compatible candidates, each the current
/// model's parameters first, all at zero), the current model's columns `free` and residual from the
/// last layer: Q an orthonormal basis of the free columns' span (their SVD with unit-norm columns,
/// truncated at sim::kRankTolerance), e = b - Q Q^T b, s2 = |e|^2 / dof; per candidate B_c, its
/// projection Bp = B_c - Q Q^T B_c, the singular directions of Bp above 1 and e's squared projection on
/// them over s2. In exact arithmetic the statistics of the stacked system; here from its R factor and
/// cross products.
ScoreStatistics scoreStatistics(const std::vector<MarkerPoseModel>& layers, const std::vector<int>& free,
                                const std::vector<CandidateColumns>& candidates);

}  // namespace orbcal::calib
