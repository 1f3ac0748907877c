// The shrinkage of a prior on an estimate: its effective number of parameters and posterior variances.
#include <Eigen/QR>
#include <algorithm>

#include "orbcal/calib/estimators.hpp"

namespace orbcal::calib {

Shrinkage shrinkage(const MeasurementModel& m, const Eigen::VectorXd& y, const std::vector<int>& held,
                    const Eigen::VectorXd& prior_sigma, const std::vector<int>& subset) {
  const int n = m.numParams();
  std::vector<int> free;
  for (int p = 0; p < n; ++p) {
    if (!std::binary_search(held.begin(), held.end(), p)) free.push_back(p);
  }
  Shrinkage out;
  out.posterior_diagonal = Eigen::VectorXd::Zero(n);
  if (free.empty()) return out;
  const Eigen::MatrixXd J = whitenedJacobian(m, y);
  const auto nf = static_cast<Eigen::Index>(free.size());
  // In typical-magnitude units (Jacobi scaling), so that the decomposition's tolerance means the same
  // for every column: D A D and D P D, with D = diag(typical).
  const Eigen::VectorXd typical = m.layout().typical();
  Eigen::MatrixXd Jf(J.rows(), nf);
  Eigen::VectorXd Pf = Eigen::VectorXd::Zero(nf), d(nf);
  for (Eigen::Index c = 0; c < nf; ++c) {
    const int i = free[static_cast<std::size_t>(c)];
    d[c] = typical[i];
    Jf.col(c) = J.col(i) * d[c];
    if (prior_sigma.size() && prior_sigma[i] > 0.0) Pf[c] = d[c] * d[c] / (prior_sigma[i] * prior_sigma[i]);
  }
  const Eigen::MatrixXd A = Jf.transpose() * Jf;
  Eigen::MatrixXd N = A;
  N.diagonal() += Pf;
  const Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(N);
  const Eigen::MatrixXd S = cod.pseudoInverse();  // (A + P)^-1 in scaled units; the pseudo-inverse where P leaves A singular
  const Eigen::MatrixXd SA = S * A;
  for (Eigen::Index c = 0; c < nf; ++c) {
    const int i = free[static_cast<std::size_t>(c)];
    out.effective += SA(c, c);
    out.posterior_diagonal[i] = S(c, c) * d[c] * d[c];
    if (std::find(subset.begin(), subset.end(), i) != subset.end()) out.gamma += SA(c, c);
  }
  return out;
}

}  // namespace orbcal::calib
