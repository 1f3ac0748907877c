#pragma once
// Is a fit consistent with its noise model? (A calibration never silently makes an arm worse.)
// Every sample's normalized squared residual d_k = nu_k^T R_k^-1 nu_k at the estimate is tested against
// chi-square with rows(k) degrees of freedom, and their sum against chi-square with (rows - free
// parameters) degrees of freedom. A sample is an outlier when its p-value is below alpha / N (Bonferroni
// over the N samples); the fit is consistent when the overall p-value is at least alpha and no sample is
// an outlier. (Each d_k is slightly smaller than chi-square(rows(k)) because the fit absorbs part of
// every residual, by the sample's leverage; with many more rows than parameters that is a small
// conservative bias, and it errs towards calling a fit consistent.)
#include <Eigen/Core>
#include <string>
#include <vector>

#include "orbcal/calib/model.hpp"

namespace orbcal::calib {

struct SampleConsistency {
  int sample = 0;     ///< index in the model
  double chi2 = 0.0;  ///< nu^T R^-1 nu at the estimate
  int rows = 0;
  double p = 1.0;     ///< P(chi-square(rows) > chi2)
};

struct Consistency {
  double chi2 = 0.0;  ///< sum over the samples
  int dof = 0;        ///< rows - free parameters (at least 1)
  double p = 1.0;     ///< P(chi-square(dof) > chi2)
  double alpha = 1e-3;
  std::vector<SampleConsistency> samples;  ///< per sample, in the model's order
  std::vector<int> outliers;               ///< samples with p < alpha / N, worst first
  bool consistent() const { return p >= alpha && outliers.empty(); }
  /// chi2 / dof: about 1 for a fit whose noise model is right.
  double ratio() const { return dof > 0 ? chi2 / dof : 0.0; }
};

/// The test at the estimate y of a fit that freed `free_params` parameters.
Consistency consistencyTest(const MeasurementModel& model, const Eigen::VectorXd& y, int free_params, double alpha = 1e-3);

/// One line: "chi-square 301.2 for 268 degrees of freedom (1.12 per degree, p = 0.08); 0 of 49 samples
/// inconsistent".
std::string formatConsistency(const Consistency& c);

}  // namespace orbcal::calib
