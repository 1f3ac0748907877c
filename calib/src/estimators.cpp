#include "orbcal/calib/estimators.hpp"

#include <ceres/ceres.h>
#include <ceres/normal_prior.h>

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <future>
#include <memory>
#include <set>

#include "halves.hpp"
#include "orbcal/sim/identifiability.hpp"
#include "stacked_system.hpp"
#include "streamed_lm.hpp"

namespace orbcal::calib {

namespace {

using Clock = std::chrono::steady_clock;

std::vector<int> sortedUnique(std::vector<int> v) {
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
  return v;
}
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

/// Per-parameter sigmas: `angle` for angles, `length` for lengths, and the layout's typical magnitude
/// times `other_scale` for every other quantity (compliances, scale factors, ...).
Eigen::VectorXd diagonalSigmas(const MeasurementModel& m, double angle, double length, double other_scale) {
  Eigen::VectorXd s(m.numParams());
  for (int i = 0; i < m.numParams(); ++i) {
    const sim::ParamInfo& p = m.layout().param(i);
    s[i] = p.quantity == sim::Quantity::kAngle ? angle : p.quantity == sim::Quantity::kLength ? length : p.typical * other_scale;
  }
  return s;
}

/// Whitening of one block: W = L^-1 with R = L L^T.
Eigen::MatrixXd whitener(const Eigen::MatrixXd& R) {
  const Eigen::LLT<Eigen::MatrixXd> llt(R);
  if (llt.info() != Eigen::Success) throw std::runtime_error("measurement covariance is not positive definite");
  return llt.matrixL().solve(Eigen::MatrixXd::Identity(R.rows(), R.cols()));
}

/// Truncated-SVD solution of min |A dy - b| with the columns of A scaled to unit norm.
/// Returns dy, the rank, and the covariance (A^T A)^+ on the kept subspace.
struct TruncatedSolve {
  Eigen::VectorXd dy;
  Eigen::MatrixXd covariance;
  int rank = 0;
};
/// The same from A's scaled SVD (svd.U needed only for dy: without it, dy stays empty).
TruncatedSolve truncatedSolve(const sim::ScaledSvd& svd, const Eigen::VectorXd& b) {
  TruncatedSolve out;
  out.rank = svd.rank;
  // Keep the first `rank` singular triplets: dy = D V_r S_r^-1 U_r^T b, covariance D V_r S_r^-2 V_r^T D.
  const Eigen::MatrixXd VD = svd.scale.asDiagonal() * svd.V.leftCols(svd.rank);
  const Eigen::VectorXd inv = svd.singular_values.head(svd.rank).cwiseInverse();
  if (svd.U.size()) out.dy = VD * (inv.asDiagonal() * (svd.U.leftCols(svd.rank).transpose() * b));
  out.covariance = VD * inv.array().square().matrix().asDiagonal() * VD.transpose();
  return out;
}
TruncatedSolve truncatedSolve(const Eigen::MatrixXd& A, const Eigen::VectorXd& b) {
  return truncatedSolve(sim::scaledSvd(A, sim::kRankTolerance), b);
}

/// The stacked system at y, whitened when `weighted`, on the parameters `cols` alone (empty: all), each
/// column times scale[c] (empty: 1); filled sample by sample, without a copy of the whole linearization.
void stackedSystem(const MeasurementModel& m, const Eigen::VectorXd& y, bool weighted, const std::vector<int>& cols,
                   const Eigen::VectorXd& scale, Eigen::MatrixXd& A, Eigen::VectorXd& b) {
  int total = 0;
  for (int k = 0; k < m.numSamples(); ++k) total += m.rows(k);
  A.resize(total, cols.empty() ? m.numParams() : static_cast<Eigen::Index>(cols.size()));
  b.resize(total);
  for (int k = 0, row = 0; k < m.numSamples(); row += m.rows(k), ++k) {
    const Linearization lin = m.linearize(k, y);
    requireFinite(lin, k);
    const int r = m.rows(k);
    const Eigen::MatrixXd W = weighted ? whitener(lin.R) : Eigen::MatrixXd();
    const Eigen::MatrixXd H = weighted ? Eigen::MatrixXd(W * lin.H) : lin.H;
    b.segment(row, r) = weighted ? Eigen::VectorXd(W * lin.innovation) : lin.innovation;
    if (cols.empty() && scale.size() == 0) {
      A.middleRows(row, r) = H;
      continue;
    }
    for (Eigen::Index c = 0; c < A.cols(); ++c) {
      const int i = cols.empty() ? static_cast<int>(c) : cols[static_cast<std::size_t>(c)];
      A.block(row, c, r, 1) = H.col(i) * (scale.size() ? scale[c] : 1.0);
    }
  }
}

void stackedSystem(const MeasurementModel& m, const Eigen::VectorXd& y, bool weighted, Eigen::MatrixXd& A,
                   Eigen::VectorXd& b) {
  stackedSystem(m, y, weighted, {}, Eigen::VectorXd(), A, b);
}

/// A Gaussian prior as pseudo-observations: for every parameter with prior_sigma_i > 0 one row
/// e_i^T / sigma_i of A and (mean_i - y_i) / sigma_i of b (the innovation of "y_i = mean_i").
void appendPriorRows(const Eigen::VectorXd& sigma, const Eigen::VectorXd& mean, const Eigen::VectorXd& y, Eigen::MatrixXd& A,
                     Eigen::VectorXd& b) {
  std::vector<Eigen::Index> rows;
  for (Eigen::Index i = 0; i < sigma.size(); ++i) {
    if (sigma[i] > 0.0) rows.push_back(i);
  }
  if (rows.empty()) return;
  const Eigen::Index r0 = A.rows(), n = static_cast<Eigen::Index>(rows.size());
  A.conservativeResize(r0 + n, Eigen::NoChange);
  b.conservativeResize(r0 + n);
  A.bottomRows(n).setZero();
  for (Eigen::Index r = 0; r < n; ++r) {
    const Eigen::Index i = rows[static_cast<std::size_t>(r)];
    A(r0 + r, i) = 1.0 / sigma[i];
    b[r0 + r] = ((mean.size() ? mean[i] : 0.0) - y[i]) / sigma[i];
  }
}

/// The R factor (RFactor) of the rows add(k, r) gives r for the samples k = 0..n-1, on `cols` columns:
/// the two halves' factors (onHalves) combined.
template <class AddRows>
Eigen::MatrixXd rFactorOfSamples(int n, Eigen::Index cols, const AddRows& add) {
  const auto [lower, upper] = onHalves(n, [&](int k0, int k1) {
    RFactor r(cols);
    for (int k = k0; k < k1; ++k) add(k, r);
    return r.matrix();
  });
  RFactor r(cols);
  r.add(lower);
  r.add(upper);
  return r.matrix();
}

}  // namespace

EkfOptions EkfOptions::paperLiteral() {
  EkfOptions o;
  o.prior_sigma_angle_rad = 0.01 * sim::kDegToRad;
  o.prior_sigma_length_m = 0.01e-3;
  o.relinearize = false;
  return o;
}

void whitenedSystem(const MeasurementModel& m, const Eigen::VectorXd& y, Eigen::MatrixXd& A, Eigen::VectorXd& b) {
  stackedSystem(m, y, true, A, b);
}

void whitenedSystem(const MeasurementModel& m, const Eigen::VectorXd& y, const std::vector<int>& cols, const Eigen::VectorXd& scale,
                    Eigen::MatrixXd& A, Eigen::VectorXd& b) {
  stackedSystem(m, y, true, cols, scale, A, b);
}

Eigen::MatrixXd whitenedRFactor(const MeasurementModel& m, const Eigen::VectorXd& y, const std::vector<int>& zeroed) {
  const int n = m.numParams();
  // The columns at their typical magnitudes while the QR runs (J T = Q R_T, so J = Q R_T T^-1): a
  // Householder QR's error is relative to the largest column, and a whitened column in metres is
  // 10^4 times one in millimetres; scaledSvd's rank decision then sees round-off as directions.
  Eigen::VectorXd t = m.layout().typical();
  for (Eigen::Index i = 0; i < t.size(); ++i) t[i] = t[i] > 0.0 ? t[i] : 1.0;
  const Eigen::MatrixXd top = rFactorOfSamples(m.numSamples(), n, [&](int k, RFactor& r) {
    Eigen::MatrixXd H;
    Eigen::VectorXd b;
    whitenedRows(m, k, y, H, b);
    for (int p : zeroed) H.col(p).setZero();
    r.add(H * t.asDiagonal());
  });
  Eigen::MatrixXd R = Eigen::MatrixXd::Zero(n, n);
  R.topRows(std::min<Eigen::Index>(n, top.rows())) = top.topRows(std::min<Eigen::Index>(n, top.rows()));
  return R * t.cwiseInverse().asDiagonal();
}

void whitenedRows(const MeasurementModel& m, int k, const Eigen::VectorXd& y, Eigen::MatrixXd& H, Eigen::VectorXd& b) {
  const Linearization lin = m.linearize(k, y);
  requireFinite(lin, k);
  const Eigen::MatrixXd W = whitener(lin.R);
  H.noalias() = W * lin.H;
  b.noalias() = W * lin.innovation;
}

Eigen::MatrixXd whitenedJacobian(const MeasurementModel& m, const Eigen::VectorXd& y) {
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
  stackedSystem(m, y, true, A, b);
  return A;
}

double weightedCost(const MeasurementModel& m, const Eigen::VectorXd& y, std::vector<Eigen::VectorXd>* innovations) {
  const int n = m.numSamples();
  if (innovations) innovations->assign(static_cast<std::size_t>(n), Eigen::VectorXd());
  const auto part = [&](int k0, int k1) {
    double c = 0.0;
    for (int k = k0; k < k1; ++k) {
      Linearization lin = m.innovationAndCovariance(k, y);
      c += 0.5 * lin.innovation.dot(lin.R.ldlt().solve(lin.innovation));
      if (innovations) (*innovations)[static_cast<std::size_t>(k)] = std::move(lin.innovation);
    }
    return c;
  };
  const auto [lower, upper] = onHalves(n, part);
  return lower + upper;
}

Estimate runEkf(const MeasurementModel& m, const EkfOptions& o) {
  const auto t0 = Clock::now();
  const int n = m.numParams();
  Estimate e;
  e.method = "EKF";
  e.y = Eigen::VectorXd::Zero(n);
  e.held = sortedUnique(o.hold);
  // A held parameter has no prior and no process variance: its rows of P, and so of every gain, are zero.
  Eigen::VectorXd P0 = diagonalSigmas(m, o.prior_sigma_angle_rad, o.prior_sigma_length_m, 1.0).array().square();
  Eigen::VectorXd Q = diagonalSigmas(m, o.process_sigma_angle_rad, o.process_sigma_length_m, 0.0).array().square();
  for (Eigen::Index p = 0; p < o.prior_sigma.size(); ++p) {
    if (o.prior_sigma[p] <= 0.0) continue;
    P0[p] = o.prior_sigma[p] * o.prior_sigma[p];
    if (o.prior_mean.size()) e.y[p] = o.prior_mean[p];
  }
  for (int p : e.held) P0[p] = Q[p] = 0.0, e.y[p] = 0.0;
  Eigen::MatrixXd P = P0.asDiagonal();
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
  for (int k = 0; k < m.numSamples(); ++k) {
    P.diagonal() += Q;  // (12); (11) leaves y unchanged
    const Eigen::VectorXd y_prior = e.y;
    Eigen::VectorXd y_i = y_prior;
    Eigen::MatrixXd K, H;
    const int iterations = o.relinearize ? std::max(1, o.iterations_per_update) : 1;
    for (int it = 0; it < iterations; ++it) {
      const Linearization lin = m.linearize(k, o.relinearize ? y_i : zero);
      requireFinite(lin, k);
      H = lin.H;
      // (13): paper-literal h = Z - J y_prior with Z, J at nominal; re-linearized:
      // nu(y_i) - H (y_prior - y_i), which equals nu(y_prior) on the first iteration.
      const Eigen::VectorXd innovation =
          o.relinearize ? Eigen::VectorXd(lin.innovation - H * (y_prior - y_i)) : Eigen::VectorXd(lin.innovation - H * y_prior);
      const Eigen::MatrixXd PHt = P * H.transpose();
      const Eigen::MatrixXd S = H * PHt + lin.R;  // (14)
      K = S.ldlt().solve(PHt.transpose()).transpose();  // (15)
      y_i = y_prior + K * innovation;                 // (16)
      if (it + 1 == iterations) {
        // (17) in Joseph form, which stays symmetric positive definite: P = A P A^T + K R K^T with
        // A = I - K H, evaluated as AP = P - K (H P), AP A^T = AP - (AP H^T) K^T: O(n^2 m), not O(n^3).
        const Eigen::MatrixXd AP = P - K * PHt.transpose();
        P = AP - (AP * H.transpose()) * K.transpose() + K * lin.R * K.transpose();
      }
    }
    e.y = y_i;
    ++e.iterations;
  }
  e.seconds = since(t0);
  e.covariance = P;
  // Rank of the information the data added: eigenvalues of P0^-1/2 P P0^-1/2 well below 1, over the
  // free parameters (a held one has P0 = P = 0 and gained nothing).
  std::vector<int> free;
  for (int p = 0; p < n; ++p) {
    if (!std::binary_search(e.held.begin(), e.held.end(), p)) free.push_back(p);
  }
  Eigen::MatrixXd Pn(static_cast<Eigen::Index>(free.size()), static_cast<Eigen::Index>(free.size()));
  for (std::size_t r = 0; r < free.size(); ++r) {
    for (std::size_t c = 0; c < free.size(); ++c) {
      Pn(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c)) = P(free[r], free[c]) / std::sqrt(P0[free[r]] * P0[free[c]]);
    }
  }
  const Eigen::VectorXd ev = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(Pn).eigenvalues();
  e.rank = static_cast<int>((ev.array() < 0.5).count());
  e.converged = true;
  e.cost = weightedCost(m, e.y);
  return e;
}

Estimate runLse(const MeasurementModel& m, const LseOptions& o) {
  const auto t0 = Clock::now();
  Estimate e;
  e.method = o.weighted ? "LSE (weighted)" : "LSE (unweighted)";
  e.y = Eigen::VectorXd::Zero(m.numParams());
  e.held = o.fix_unidentifiable ? unidentifiableToFix(m, e.y, o.hold) : sortedUnique(o.hold);
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
  TruncatedSolve step;
  for (int it = 0; it < o.max_iterations; ++it) {
    stackedSystem(m, e.y, o.weighted, A, b);
    appendPriorRows(o.prior_sigma, o.prior_mean, e.y, A, b);
    for (int p : e.held) A.col(p).setZero();
    step = truncatedSolve(A, b);
    e.y += step.dy;
    ++e.iterations;
    if (step.dy.norm() < o.step_tolerance) {
      e.converged = true;
      break;
    }
  }
  e.rank = step.rank;
  if (o.weighted) {
    e.covariance = step.covariance;
  } else {
    // Unweighted: scale (A^T A)^+ by the residual variance.
    stackedSystem(m, e.y, false, A, b);
    const double dof = std::max<Eigen::Index>(1, b.size() - step.rank);
    e.covariance = step.covariance * (b.squaredNorm() / static_cast<double>(dof));
  }
  e.seconds = since(t0);
  e.cost = weightedCost(m, e.y);
  return e;
}

std::vector<int> unidentifiableToFix(const MeasurementModel& m, const Eigen::VectorXd& y, const std::vector<int>& held) {
  return unidentifiableToFix(m, linearizeAll(m, y), held);
}

std::vector<int> unidentifiableToFix(const MeasurementModel& m, const StackedLinearization& at, const std::vector<int>& held) {
  RFactor r(m.numParams());
  for (int k = 0, row = 0; k < m.numSamples(); row += m.rows(k), ++k) {
    r.add(whitener(at.R[static_cast<std::size_t>(k)]) * at.H.middleRows(row, m.rows(k)));
  }
  return sim::numericalRank(r.matrix(), m.layout().typical(), held).held;
}

namespace {

/// One sample's whitened residual W nu_k(y) and Jacobian -W H_k for Ceres (W fixed at the start), over
/// the free parameters alone (`free`; the held ones stay at zero): Ceres then solves the same problem
/// as with a SubsetManifold on all of y, without multiplying every Jacobian by the manifold's.
class SampleCost : public ceres::CostFunction {
 public:
  /// `W` whitens the sample's rows (from its covariance at the start).
  SampleCost(const MeasurementModel& m, int k, Eigen::MatrixXd W, const std::vector<int>& free)
      : m_(m), k_(k), W_(std::move(W)), free_(free) {
    set_num_residuals(m.rows(k));
    mutable_parameter_block_sizes()->push_back(static_cast<int>(free.size()));
  }
  bool Evaluate(double const* const* params, double* residuals, double** jacobians) const override {
    Eigen::VectorXd y = Eigen::VectorXd::Zero(m_.numParams());
    for (std::size_t c = 0; c < free_.size(); ++c) y[free_[c]] = params[0][c];
    // Ceres asks for the residual alone at every trial step: the prediction without its Jacobian.
    // A step to where the prediction is not finite is a failed evaluation (Ceres then shortens the
    // step), never a non-finite residual: Ceres would log it on the terminal.
    if (!jacobians || !jacobians[0]) {
      const Eigen::VectorXd r = W_ * m_.innovation(k_, y);
      if (!r.allFinite()) return false;
      Eigen::Map<Eigen::VectorXd>(residuals, m_.rows(k_)) = r;
      return true;
    }
    const Linearization lin = m_.linearize(k_, y);
    if (!lin.innovation.allFinite() || !lin.H.allFinite()) return false;
    Eigen::Map<Eigen::VectorXd>(residuals, m_.rows(k_)) = W_ * lin.innovation;
    const Eigen::MatrixXd WH = W_.lazyProduct(lin.H);  // 3 or 6 rows: no blocked GEMM
    Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> J(jacobians[0], m_.rows(k_),
                                                                                         static_cast<Eigen::Index>(free_.size()));
    for (std::size_t c = 0; c < free_.size(); ++c) J.col(static_cast<Eigen::Index>(c)) = -WH.col(free_[c]);
    return true;
  }

 private:
  const MeasurementModel& m_;
  int k_;
  Eigen::MatrixXd W_;
  const std::vector<int>& free_;
};

/// The samples [k0, k1) as one residual block (squared loss only: a robust loss needs its sample's
/// own block): each sample's rows as SampleCost gives them, the two halves of the block evaluated side
/// by side (each sample's rows written in place: the same values whichever thread computes them).
class SamplesCost : public ceres::CostFunction {
 public:
  SamplesCost(const MeasurementModel& m, int k0, int k1, const std::vector<Eigen::MatrixXd>& W, const std::vector<int>& free) {
    int rows = 0;
    for (int k = k0; k < k1; ++k) {
      samples_.push_back(std::make_unique<SampleCost>(m, k, W[static_cast<std::size_t>(k)], free));
      offsets_.push_back(rows);
      rows += m.rows(k);
    }
    set_num_residuals(rows);
    mutable_parameter_block_sizes()->push_back(static_cast<int>(free.size()));
  }
  bool Evaluate(double const* const* params, double* residuals, double** jacobians) const override {
    const auto part = [&](std::size_t a, std::size_t b) {
      const std::size_t cols = static_cast<std::size_t>(parameter_block_sizes()[0]);
      for (std::size_t i = a; i < b; ++i) {
        const auto row = static_cast<std::size_t>(offsets_[i]);
        double* J = jacobians && jacobians[0] ? jacobians[0] + row * cols : nullptr;
        if (!samples_[i]->Evaluate(params, residuals + row, J ? &J : nullptr)) return false;
      }
      return true;
    };
    const std::size_t n = samples_.size();
    if (n < kParallelSamples) return part(0, n);
    auto upper = std::async(std::launch::async, part, n / 2, n);
    const bool lower = part(0, n / 2);
    return upper.get() && lower;
  }
  static constexpr std::size_t kParallelSamples = 32;  ///< fewer: one thread (starting one costs more)
  static constexpr int kSamplesPerBlock = 256;

 private:
  std::vector<std::unique_ptr<SampleCost>> samples_;
  std::vector<int> offsets_;
};

/// LmOptions' Gaussian prior on the free parameters that have one, as one residual block
/// diag(1/sigma) (x - mean) (Ceres's NormalPrior) on the free-parameter vector x.
void addPrior(const LmOptions& o, const std::vector<int>& free, ceres::Problem& problem, double* x) {
  if (o.prior_sigma.size() == 0 || free.empty()) return;
  std::vector<Eigen::Index> rows;
  for (std::size_t c = 0; c < free.size(); ++c) {
    if (o.prior_sigma[free[c]] > 0.0) rows.push_back(static_cast<Eigen::Index>(c));
  }
  if (rows.empty()) return;
  const auto n = static_cast<Eigen::Index>(free.size());
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(rows.size()), n);
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(n);
  for (Eigen::Index c = 0; c < n; ++c) mean[c] = o.prior_mean.size() ? o.prior_mean[free[static_cast<std::size_t>(c)]] : 0.0;
  for (std::size_t r = 0; r < rows.size(); ++r) {
    A(static_cast<Eigen::Index>(r), rows[r]) = 1.0 / o.prior_sigma[free[static_cast<std::size_t>(rows[r])]];
  }
  problem.AddResidualBlock(new ceres::NormalPrior(A, mean), nullptr, x);
}

}  // namespace

namespace {

/// LmOptions' prior on the free parameters, as streamedLm takes it.
StreamedLmOptions streamedOptions(const LmOptions& o, const std::vector<int>& free) {
  StreamedLmOptions s;
  s.max_iterations = o.max_iterations;
  s.function_tolerance = o.function_tolerance;
  s.decrease_tolerance = o.decrease_tolerance;
  const auto nf = static_cast<Eigen::Index>(free.size());
  if (o.start.size() > 0) {
    s.start.resize(nf);
    for (Eigen::Index c = 0; c < nf; ++c) s.start[c] = o.start[free[static_cast<std::size_t>(c)]];
  }
  if (o.prior_sigma.size() == 0) return s;
  s.prior_information = Eigen::VectorXd::Zero(nf);
  s.prior_mean = Eigen::VectorXd::Zero(nf);
  for (Eigen::Index c = 0; c < nf; ++c) {
    const int i = free[static_cast<std::size_t>(c)];
    if (o.prior_sigma[i] > 0.0) s.prior_information[c] = 1.0 / (o.prior_sigma[i] * o.prior_sigma[i]);
    if (o.prior_mean.size()) s.prior_mean[c] = o.prior_mean[i];
  }
  return s;
}

/// The covariance (LmOptions::covariance, with e.held's columns zero), the time and the cost of an estimate e.y.
Estimate finishLm(const MeasurementModel& m, const LmOptions& o, Clock::time_point t0, Estimate e) {
  const int n = m.numParams();
  const std::vector<int>& fixed = e.held;
  if (o.covariance) {
    // Covariance from the whitened Jacobian at the solution, on the free parameters: from its R factor
    // (the same singular values and right vectors), never the stacked Jacobian.
    const TruncatedSolve ts = truncatedSolve(sim::scaledSvd(whitenedRFactor(m, e.y, fixed), sim::kRankTolerance, false), {});
    e.rank = ts.rank;
    e.covariance = ts.covariance;
  } else {
    e.rank = n - static_cast<int>(fixed.size());
  }
  e.seconds = since(t0);
  e.cost = weightedCost(m, e.y);
  return e;
}

}  // namespace

Estimate runLm(const MeasurementModel& m, const LmOptions& o) {
  const auto t0 = Clock::now();
  Estimate e;
  e.method = "LM (Ceres)";
  const int n = m.numParams();
  e.y = Eigen::VectorXd::Zero(n);
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  po.loss_function_ownership = ceres::TAKE_OWNERSHIP;
  po.manifold_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
  // One pass of linearizations at the start gives both the whiteners and the system the unidentifiable
  // parameters are found from (its R factor: no copy of the stacked Jacobian is kept). Where the
  // normal equations' LM starts there too, the R factor is of [W H, W f]: its first columns' R is the
  // Jacobian's, and R^T R holds the LM's first sums (streamedStart), so that it makes no pass of its own.
  std::vector<Eigen::MatrixXd> W(static_cast<std::size_t>(m.numSamples()));
  const bool streamed = o.normal_equations && o.loss == LmOptions::Loss::kNone;
  const bool with_f = streamed && o.fix_unidentifiable && o.start.size() == 0;
  const Eigen::MatrixXd R_aug = rFactorOfSamples(m.numSamples(), with_f ? n + 1 : n, [&](int k, RFactor& r) {
    const auto s = static_cast<std::size_t>(k);
    // Where no rank decision is asked for (a warm round holds the round before's), the whiteners alone: no Jacobian.
    const Linearization lin = o.fix_unidentifiable ? m.linearize(k, zero) : m.innovationAndCovariance(k, zero);
    requireFinite(lin, k);
    W[s] = whitener(lin.R);
    if (!o.fix_unidentifiable) return;
    if (!with_f) {
      r.add(W[s] * lin.H);
      return;
    }
    Eigen::MatrixXd rows(lin.H.rows(), n + 1);
    rows.leftCols(n).noalias() = W[s] * lin.H;
    rows.col(n).noalias() = W[s] * lin.innovation;
    r.add(rows);
  });
  const Eigen::MatrixXd R_start = R_aug.topLeftCorner(std::min<Eigen::Index>(R_aug.rows(), n), n);
  e.held = o.fix_unidentifiable ? sim::numericalRank(R_start, m.layout().typical(), o.hold).held : sortedUnique(o.hold);
  const std::vector<int>& fixed = e.held;
  std::vector<int> free;
  for (int p = 0; p < n; ++p) {
    if (!std::binary_search(fixed.begin(), fixed.end(), p)) free.push_back(p);
  }
  // Ceres works on the free parameters alone (x; y = x on them, 0 elsewhere).
  Eigen::VectorXd x = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(free.size()));
  for (std::size_t c = 0; c < free.size() && o.start.size() > 0; ++c) x[static_cast<Eigen::Index>(c)] = o.start[free[c]];
  if (streamed) {
    // The same iterations on the normal equations accumulated per block of samples: no stacked Jacobian.
    StreamedLmOptions so = streamedOptions(o, free);
    StreamedStart first;
    if (with_f) {
      int rows = 0;
      for (int k = 0; k < m.numSamples(); ++k) rows += m.rows(k);
      first = streamedStart(R_aug, free, rows);
      so.start_sums = &first;
    }
    const StreamedLmResult s = streamedLm(m, W, free, so);
    for (std::size_t c = 0; c < free.size(); ++c) e.y[free[c]] = s.x[static_cast<Eigen::Index>(c)];
    e.iterations = s.iterations;
    e.converged = s.converged;
    e.effective_parameters = s.effective;
    return finishLm(m, o, t0, std::move(e));
  }
  for (int k = 0; k < m.numSamples() && !free.empty();) {
    if (o.loss == LmOptions::Loss::kNone) {  // blocks of samples, each evaluated on two threads
      const int k1 = std::min(m.numSamples(), k + SamplesCost::kSamplesPerBlock);
      problem.AddResidualBlock(new SamplesCost(m, k, k1, W, free), nullptr, x.data());
      k = k1;
      continue;
    }
    ceres::LossFunction* loss = nullptr;
    if (o.loss == LmOptions::Loss::kHuber) loss = new ceres::HuberLoss(o.loss_scale);
    if (o.loss == LmOptions::Loss::kCauchy) loss = new ceres::CauchyLoss(o.loss_scale);
    problem.AddResidualBlock(new SampleCost(m, k, W[static_cast<std::size_t>(k)], free), loss, x.data());
    ++k;
  }
  addPrior(o, free, problem, x.data());
  ceres::Solver::Options so;
  so.linear_solver_type = o.normal_equations ? ceres::DENSE_NORMAL_CHOLESKY : ceres::DENSE_QR;
  so.max_num_iterations = o.max_iterations;
  so.function_tolerance = o.function_tolerance;
  so.initial_trust_region_radius = 1e8;
  so.gradient_tolerance = 1e-14;
  so.parameter_tolerance = 1e-14;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;  // no solver log lines on the terminal; the summary is read below
  ceres::Solver::Summary summary;
  if (!free.empty()) {
    ceres::Solve(so, &problem, &summary);
    for (std::size_t c = 0; c < free.size(); ++c) e.y[free[c]] = x[static_cast<Eigen::Index>(c)];
  }
  // Nothing free: converged where it started (as Ceres says of a problem with no free parameter).
  e.iterations = free.empty() ? 0 : static_cast<int>(summary.iterations.size()) - 1;
  e.converged = free.empty() || summary.termination_type == ceres::CONVERGENCE;
  return finishLm(m, o, t0, std::move(e));
}

}  // namespace orbcal::calib
