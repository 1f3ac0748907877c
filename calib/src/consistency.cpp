#include "orbcal/calib/consistency.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cstdio>

#include "orbcal/calib/diagnose.hpp"

namespace orbcal::calib {

Consistency consistencyTest(const MeasurementModel& model, const Eigen::VectorXd& y, int free_params, double alpha) {
  Consistency c;
  c.alpha = alpha;
  int rows = 0;
  const int n = model.numSamples();
  for (int k = 0; k < n; ++k) {
    const Linearization lin = model.linearize(k, y);
    SampleConsistency s;
    s.sample = k;
    s.rows = static_cast<int>(lin.innovation.size());
    s.chi2 = lin.innovation.dot(lin.R.ldlt().solve(lin.innovation));
    s.p = chiSquareSurvival(s.chi2, s.rows);
    c.chi2 += s.chi2;
    rows += s.rows;
    c.samples.push_back(s);
    if (s.p < alpha / std::max(1, n)) c.outliers.push_back(k);
  }
  std::sort(c.outliers.begin(), c.outliers.end(), [&](int a, int b) {
    return c.samples[static_cast<std::size_t>(a)].chi2 / c.samples[static_cast<std::size_t>(a)].rows >
           c.samples[static_cast<std::size_t>(b)].chi2 / c.samples[static_cast<std::size_t>(b)].rows;
  });
  c.dof = std::max(1, rows - free_params);
  c.p = chiSquareSurvival(c.chi2, c.dof);
  return c;
}

std::string formatConsistency(const Consistency& c) {
  char line[256];
  std::snprintf(line, sizeof line, "chi-square %.1f for %d degrees of freedom (%.2f per degree, p = %.3g); %d of %d samples inconsistent",
                c.chi2, c.dof, c.ratio(), c.p, static_cast<int>(c.outliers.size()), static_cast<int>(c.samples.size()));
  return line;
}

}  // namespace orbcal::calib
