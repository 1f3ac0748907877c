#pragma once
// Liu et al. 2012's simulation protocol (sections 4.2-4.5) as one call: a laser ranger on the flange
// measures the range to a plane; the configurations of each case are chosen from a candidate pool by
// O3 = sigma_min (observability.hpp), the errors identified by weighted Gauss-Newton least squares on
// the identifiable columns (runLse, the unidentifiable ones held), and the result validated on
// independent configurations per base-frame axis (Table 5). `orbcal experiment --preset liu2012`
// repeats it over seeds and writes the report.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "orbcal/calib/estimators.hpp"
#include "orbcal/calib/observability.hpp"
#include "orbcal/calib/relative_models.hpp"
#include "orbcal/calib/validation.hpp"
#include "orbcal/sim/arm.hpp"

namespace orbcal::calib {

struct RangeExperimentSettings {
  LaserBeam beam;                    ///< Liu et al. 2012: from O6 along +Z6 (the flange frame)
  Plane plane = Plane::seed004();    ///< the nominal plane and its identified coefficients
  double sigma_m = 0.2e-3;           ///< one reading's noise
  int repeats = 10;                  ///< readings averaged per configuration
  int candidates = 101;              ///< the pool the cases are chosen from
  std::vector<int> case_sizes{50, 100};
  int validation = 20;               ///< independent configurations, anywhere in the workspace
  RangeConfigurationSettings configurations;  ///< which candidates are kept (beam_must_hit is set)
};

/// One case: `size` configurations of the pool.
struct RangeCaseResult {
  int size = 0;
  std::string selection;               ///< how they were chosen
  std::vector<int> chosen;             ///< indices into the candidates, ascending
  ObservabilityIndices indices;        ///< of the chosen set (whitened rows, typical-magnitude columns)
  double random_o3 = 0;                ///< mean O3 of 20 random subsets of the same size, for comparison
  Estimate estimate;                   ///< weighted LSE; y in the PlaneRangeModel's layout
  Eigen::VectorXd plane_estimate;      ///< the identified plane coefficients' changes (y's plane block)
  /// Range residuals z - h at the chosen configurations: before (the nominal model and plane) and
  /// after identification; RMS and largest |.|.
  double residual_rms_before_m = 0, residual_max_before_m = 0, residual_rms_after_m = 0, residual_max_after_m = 0;
  PoseErrors validation_errors;        ///< the identified arm against the true one, per configuration
  AxisErrorSummary validation;         ///< their summary per axis
};

struct RangeExperimentResult {
  std::vector<std::string> names;      ///< the PlaneRangeModel's parameter names
  std::vector<int> held;               ///< unidentifiable over the whole pool at the nominal model
  int rank = 0;                        ///< of the pool's whitened Jacobian
  ObservabilityIndices pool_indices;   ///< of the whole pool
  PoseErrors nominal_errors;           ///< the nominal arm against the true one, per validation configuration
  AxisErrorSummary nominal_validation; ///< their summary per axis
  std::vector<RangeCaseResult> cases;
  double seconds = 0;
};

/// One run: candidates and validation configurations drawn on the nominal model (seeded), ranges of
/// the plant p_true (the PlaneRangeModel's layout: kinematic errors, then the plane coefficients'
/// changes), each case chosen by O3 (a case of candidates - 1 or more by trying every subset, the
/// paper's "all of them"; smaller ones by selectConfigurations' greedy + DETMAX + exchange search),
/// identified and validated. Throws std::invalid_argument on inconsistent sizes.
RangeExperimentResult runRangeExperiment(const sim::Arm& nominal, const Eigen::VectorXd& p_true,
                                         const RangeExperimentSettings& settings, std::uint64_t seed);

}  // namespace orbcal::calib
