// The distributions behind diagnose's and the held-out tests' p-values, from Boost.Math (declared in
// calib/diagnose.hpp). Arguments outside a distribution's domain give "no evidence" (p = 1) rather
// than an exception or a NaN that would reach a report.
#include <algorithm>
#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/fisher_f.hpp>
#include <boost/math/distributions/students_t.hpp>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <vector>

#include "orbcal/calib/diagnose.hpp"

namespace orbcal::calib {

double chiSquareSurvival(double x, double k) {
  if (!(k > 0.0) || std::isnan(x) || x <= 0.0) return 1.0;
  if (std::isinf(x)) return 0.0;
  return boost::math::cdf(boost::math::complement(boost::math::chi_squared_distribution<double>(k), x));
}

double fSurvival(double f, double d1, double d2) {
  if (!(d1 > 0.0) || !(d2 > 0.0) || std::isnan(f) || f <= 0.0) return 1.0;
  if (std::isinf(f)) return 0.0;
  return boost::math::cdf(boost::math::complement(boost::math::fisher_f_distribution<double>(d1, d2), f));
}

double studentTCritical(double two_sided_alpha, double dof) {
  if (!(two_sided_alpha > 0.0 && two_sided_alpha < 1.0) || !(dof > 0.0)) {
    throw std::invalid_argument("studentTCritical: needs 0 < alpha < 1 and dof > 0");
  }
  return boost::math::quantile(boost::math::complement(boost::math::students_t_distribution<double>(dof), 0.5 * two_sided_alpha));
}

std::vector<double> holmAdjust(const std::vector<double>& p) {
  const std::size_t n = p.size();
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return p[a] < p[b]; });
  std::vector<double> adj(n);
  double running = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    running = std::max(running, std::min(1.0, static_cast<double>(n - i) * p[order[i]]));
    adj[order[i]] = running;
  }
  return adj;
}

}  // namespace orbcal::calib
