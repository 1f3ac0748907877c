#include "streamed_lm.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <cmath>
#include <future>
#include <limits>

#include "orbcal/calib/dense_kernels.hpp"

namespace orbcal::calib {

namespace {

/// Ceres's Levenberg-Marquardt constants (Solver::Options' defaults; TrustRegionMinimizer's
/// initial_trust_region_radius as runLm sets it).
constexpr double kInitialRadius = 1e8, kMaxRadius = 1e16, kMinRadius = 1e-32;
constexpr double kMinDiagonal = 1e-6, kMaxDiagonal = 1e32, kMinRelativeDecrease = 1e-3;
constexpr double kGradientTolerance = 1e-14, kParameterTolerance = 1e-14;
/// A full step whose parabola puts the cost's minimum along it below this fraction of it is shortened
/// to that minimum; none shorter than kShortestStep (a step that bad is left to the trust region).
constexpr double kShortenBelow = 0.75, kShortestStep = 1e-3;
constexpr int kBlock = 128;      ///< samples per accumulated block
constexpr int kParallel = 64;    ///< fewer samples: one thread

/// The sums over samples at one point: 1/2 |f|^2 and, with the Jacobian, J^T J (lower triangle) and J^T f.
struct Sums {
  double cost = 0.0;
  Eigen::Index rows = 0;  ///< the samples' whitened rows (the prior's not counted)
  Eigen::MatrixXd JtJ;
  Eigen::VectorXd g;
  bool finite = true;
};

class Accumulator {
 public:
  Accumulator(const MeasurementModel& m, const std::vector<Eigen::MatrixXd>& W, const std::vector<int>& free, const StreamedLmOptions& o)
      : m_(m), W_(W), free_(free), o_(o), nf_(static_cast<Eigen::Index>(free.size())) {}

  /// The sums at x, the prior's rows included.
  Sums at(const Eigen::VectorXd& x, bool jacobian) const {
    Eigen::VectorXd y = Eigen::VectorXd::Zero(m_.numParams());
    for (Eigen::Index c = 0; c < nf_; ++c) y[free_[static_cast<std::size_t>(c)]] = x[c];
    const int n = m_.numSamples();
    Sums s;
    if (n < kParallel) {
      s = part(y, 0, n, jacobian, buffers_[0]);
    } else {
      auto upper = std::async(std::launch::async, [&] { return part(y, n / 2, n, jacobian, buffers_[1]); });
      s = part(y, 0, n / 2, jacobian, buffers_[0]);
      const Sums u = upper.get();
      s.cost += u.cost;
      s.rows += u.rows;
      s.finite = s.finite && u.finite;
      if (jacobian && s.finite) {
        s.JtJ += u.JtJ;
        s.g += u.g;
      }
    }
    return withPrior(std::move(s), x, jacobian);
  }

  /// The samples' sums `s` at x with the prior's rows added.
  Sums withPrior(Sums s, const Eigen::VectorXd& x, bool jacobian) const {
    if (o_.prior_information.size() == 0) return s;
    const Eigen::VectorXd d = x - o_.prior_mean;
    s.cost += 0.5 * d.cwiseProduct(d).dot(o_.prior_information);
    if (jacobian && s.finite) {
      s.JtJ.diagonal() += o_.prior_information;
      s.g += o_.prior_information.cwiseProduct(d);
    }
    return s;
  }

 private:
  /// One half's block of whitened rows, kept between evaluations: a block of a flexible model is a
  /// megabyte, which allocated afresh at every evaluation costs fresh pages (page faults) each time.
  struct Buffers {
    Eigen::MatrixXd J, WH;
    Eigen::VectorXd f;
  };

  Sums part(const Eigen::VectorXd& y, int k0, int k1, bool jacobian, Buffers& b) const {
    Sums s;
    if (jacobian) {
      s.JtJ = Eigen::MatrixXd::Zero(nf_, nf_);
      s.g = Eigen::VectorXd::Zero(nf_);
    }
    Eigen::MatrixXd& J = b.J;
    Eigen::VectorXd& f = b.f;
    for (int c0 = k0; c0 < k1; c0 += kBlock) {
      const int c1 = std::min(k1, c0 + kBlock);
      if (!jacobian) {
        for (int k = c0; k < c1; ++k) {
          const Eigen::VectorXd r = W_[static_cast<std::size_t>(k)] * m_.innovation(k, y);
          if (!r.allFinite()) return Sums{0.0, 0, {}, {}, false};
          s.cost += 0.5 * r.squaredNorm();
          s.rows += r.size();
        }
        continue;
      }
      Eigen::Index rows = 0;
      for (int k = c0; k < c1; ++k) rows += m_.rows(k);
      J.resize(rows, nf_);
      f.resize(rows);
      for (int k = c0, row = 0; k < c1; row += m_.rows(k), ++k) {
        const Linearization lin = m_.linearize(k, y);
        if (!lin.innovation.allFinite() || !lin.H.allFinite()) return Sums{0.0, 0, {}, {}, false};
        const Eigen::MatrixXd& Wk = W_[static_cast<std::size_t>(k)];
        f.segment(row, m_.rows(k)) = Wk * lin.innovation;
        // W H on all of H's columns (contiguous: a vectorized product), then its free columns into J's rows;
        // the product through the list of free columns had been a tenth of a small log's diagnosis.
        b.WH.noalias() = Wk.lazyProduct(lin.H);
        J.middleRows(row, m_.rows(k)) = -b.WH(Eigen::all, free_);
      }
      s.cost += 0.5 * f.squaredNorm();
      s.rows += rows;
      s.g.noalias() += J.transpose() * f;
      addGram(s.JtJ, J);
    }
    return s;
  }

  const MeasurementModel& m_;
  const std::vector<Eigen::MatrixXd>& W_;
  const std::vector<int>& free_;
  const StreamedLmOptions& o_;
  Eigen::Index nf_;
  mutable std::array<Buffers, 2> buffers_;  ///< per half of the samples (each evaluated on its own thread)
};

/// tr((N)^-1 (N - S)) = nf - sum_i S_i (N^-1)_ii, N the lower triangle of the normal matrix with the prior.
double hatTrace(const Eigen::MatrixXd& N_lower, const Eigen::VectorXd& prior_information) {
  const Eigen::Index nf = N_lower.rows();
  if (prior_information.size() == 0 || nf == 0) return static_cast<double>(nf);
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(Eigen::MatrixXd(N_lower.selfadjointView<Eigen::Lower>()));
  const Eigen::MatrixXd inverse = ldlt.solve(Eigen::MatrixXd::Identity(nf, nf));
  return static_cast<double>(nf) - prior_information.dot(inverse.diagonal());
}

/// The cost's unit for the stopping rule: 1 where the whitened residuals are at the noise they are
/// whitened with, their mean square 2 cost / (rows - parameters) where they are larger (a model that
/// misses structure: its parameters' spread grows by that factor's square root too).
double noiseUnit(const Sums& s, Eigen::Index nf) {
  const double dof = static_cast<double>(std::max<Eigen::Index>(1, s.rows - nf));
  return std::max(1.0, 2.0 * s.cost / dof);
}

/// The Gauss-Newton model's whole decrease of the cost from `now`, 1/2 g^T A^-1 g (A the scaled normal
/// matrix with the prior, g the scaled gradient); infinity where A is not positive definite.
double gaussNewtonDecrease(const Eigen::MatrixXd& A, const Eigen::VectorXd& g) {
  const Eigen::LLT<Eigen::MatrixXd> llt(A);
  if (llt.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
  return 0.5 * g.dot(llt.solve(g));
}

/// The step length t in (0, 1) at the minimum of the parabola through the cost at 0 (`now`, slope
/// `slope` = g . step) and at 1 (`full`) where the full step overshoots that minimum; 1 where it does not.
double parabolicStep(double now, double slope, double full) {
  const double curvature = 2.0 * (full - now - slope);
  if (!(curvature > 0.0) || !(slope < 0.0)) return 1.0;
  const double t = -slope / curvature;
  return t < kShortenBelow && t > kShortestStep ? t : 1.0;
}

}  // namespace

StreamedStart streamedStart(const Eigen::MatrixXd& R, const std::vector<int>& free, Eigen::Index rows) {
  const Eigen::Index n = R.cols() - 1;
  StreamedStart s;
  s.rows = rows;
  const Eigen::MatrixXd Rf = R.leftCols(n)(Eigen::all, free);
  s.JtJ = Rf.transpose() * Rf;
  s.g = -(Rf.transpose() * R.col(n));
  s.cost = 0.5 * R.col(n).squaredNorm();
  return s;
}

StreamedLmResult streamedLm(const MeasurementModel& m, const std::vector<Eigen::MatrixXd>& W, const std::vector<int>& free,
                            const StreamedLmOptions& o) {
  const auto nf = static_cast<Eigen::Index>(free.size());
  StreamedLmOptions opt = o;
  if (opt.prior_information.size() > 0 && opt.prior_mean.size() == 0) opt.prior_mean = Eigen::VectorXd::Zero(nf);
  const Accumulator acc(m, W, free, opt);
  StreamedLmResult r;
  r.x = o.start.size() == nf ? o.start : Eigen::VectorXd::Zero(nf);
  Sums now = o.start_sums ? acc.withPrior(Sums{o.start_sums->cost, o.start_sums->rows, o.start_sums->JtJ, o.start_sums->g, true}, r.x, true)
                          : acc.at(r.x, true);
  if (!now.finite) return r;
  // Ceres's Jacobi scaling: every column divided by 1 + its norm at the start.
  const Eigen::VectorXd scale = (1.0 + now.JtJ.diagonal().cwiseMax(0.0).array().sqrt()).inverse().matrix();
  double radius = kInitialRadius, decrease = 2.0;
  bool fresh = true;  // the sums are of a point not yet tested for convergence
  const auto gradientSmall = [&] { return nf == 0 || now.g.lpNorm<Eigen::Infinity>() <= kGradientTolerance; };
  if (gradientSmall()) {
    r.converged = true;
    r.effective = hatTrace(now.JtJ, opt.prior_information);
    return r;
  }
  const auto shrink = [&] {
    radius /= decrease;
    decrease *= 2.0;
    return radius >= kMinRadius;
  };
  for (int it = 0; it < o.max_iterations; ++it) {
    r.iterations = it + 1;
    const Eigen::MatrixXd A = scale.asDiagonal() * Eigen::MatrixXd(now.JtJ.selfadjointView<Eigen::Lower>()) * scale.asDiagonal();
    const Eigen::VectorXd gs = scale.cwiseProduct(now.g);
    if (fresh && gaussNewtonDecrease(A, gs) <= o.decrease_tolerance * noiseUnit(now, nf)) {
      r.converged = true;  // nothing left to gain that the noise would notice
      break;
    }
    fresh = false;
    const Eigen::VectorXd damping = A.diagonal().cwiseMax(kMinDiagonal).cwiseMin(kMaxDiagonal) / radius;
    Eigen::MatrixXd Ad = A;
    Ad.diagonal() += damping;
    const Eigen::LLT<Eigen::MatrixXd> llt(Ad);
    const Eigen::VectorXd z = llt.info() == Eigen::Success ? Eigen::VectorXd(-llt.solve(gs)) : Eigen::VectorXd();
    // The linearized model's decrease of the cost along the step: -(slope + curvature / 2).
    const bool solved = z.size() && z.allFinite();
    const double slope = solved ? gs.dot(z) : 0.0, curvature = solved ? z.dot(A * z) : 0.0;
    const double model_change = solved ? -(slope + 0.5 * curvature) : 0.0;
    if (!(model_change > 0.0)) {
      if (!shrink()) break;
      continue;
    }
    const Eigen::VectorXd delta = scale.cwiseProduct(z);
    if (delta.norm() <= (r.x.norm() + kParameterTolerance) * kParameterTolerance) {
      r.converged = true;
      break;
    }
    Eigen::VectorXd candidate = r.x + delta;
    const Sums trial = acc.at(candidate, false);
    double cost = trial.finite ? trial.cost : std::numeric_limits<double>::max();
    double change = model_change;
    // Where the cost's curvature along the step exceeds J^T J's (the terms f_i d2f_i it leaves out, large
    // along directions only a wide prior holds), the full step overshoots; its parabola's minimum does not.
    if (const double t = trial.finite ? parabolicStep(now.cost, slope, cost) : 1.0; t < 1.0) {
      const Sums shorter = acc.at(r.x + t * delta, false);
      if (shorter.finite && shorter.cost < cost) {
        candidate = r.x + t * delta;
        cost = shorter.cost;
        change = -(t * slope + 0.5 * t * t * curvature);
      }
    }
    if (std::abs(now.cost - cost) <= o.function_tolerance * now.cost) {
      r.converged = true;  // Ceres stops at the current point
      break;
    }
    const double rho = (now.cost - cost) / change;
    if (!(rho > kMinRelativeDecrease)) {
      if (!shrink()) break;
      continue;
    }
    Sums next = acc.at(candidate, true);
    if (!next.finite) break;  // Ceres: the Jacobian's evaluation failed
    r.x = candidate;
    now = std::move(next);
    radius = std::min(kMaxRadius, radius / std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * rho - 1.0, 3)));
    decrease = 2.0;
    fresh = true;
    if (gradientSmall()) {
      r.converged = true;
      break;
    }
  }
  if (now.finite && now.JtJ.size()) r.effective = hatTrace(now.JtJ, opt.prior_information);
  return r;
}

}  // namespace orbcal::calib
