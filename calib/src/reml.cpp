#include "reml.hpp"

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <future>
#include <limits>
#include <optional>

#include "orbcal/calib/dense_kernels.hpp"

namespace orbcal::calib {

namespace {

/// Fisher scoring stops when every variance component moves by less than this share of its standard deviation.
constexpr double kRemlTolerance = 1e-3;

/// A sample's 3 or 6 square matrices (its covariance's components, W_k): no heap, no product kernel's blocking.
using SampleMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 6, 6>;

/// W_k = R_k^-1 of a sample's covariance R_k = sum_c theta_c V_kc.
SampleMatrix sampleWeight(const std::array<SampleMatrix, 3>& Vk, const Eigen::Vector3d& theta) {
  const SampleMatrix R = theta[0] * Vk[0] + theta[1] * Vk[1] + theta[2] * Vk[2];
  return Eigen::LDLT<SampleMatrix>(R).solve(SampleMatrix::Identity(R.rows(), R.cols()));
}

/// tr(X Y) of two small square matrices, without their product.
double traceOfProduct(const SampleMatrix& X, const SampleMatrix& Y) { return X.cwiseProduct(Y.transpose()).sum(); }

/// tr(P V_c P V_d) of REML's information (Koch 1999, ch. 3.6), P = W - W A N^-1 A^T W, with W = R^-1
/// block diagonal per sample, A the free columns of the Jacobian and N = A^T W A + S (S the prior):
/// sum_k tr(W V_c W V_d) - 2 tr(N^-1 C_cd) + tr(N^-1 B_c N^-1 B_d), B_c = sum_k A_k^T W V_c W A_k,
/// C_cd = sum_k A_k^T W V_c W V_d W A_k: what the fitted parameters take of each component is not
/// counted as its noise (joint noise above all: the joint corrections' columns lie along J_q).
/// tr(N^-1 C_cd) = sum_k tr(V_c W V_d H_k) with H_k = W A_k N^-1 A_k^T W (3 or 6 square): no p x p
/// matrix per pair. The samples go in chunks, stacked (one BLAS product per chunk, not one per sample;
/// B_3's whole, not its lower triangle: BLAS's general product is faster than Eigen's triangular one),
/// the two halves of the samples side by side, summed in a fixed order (the same sums on one machine;
/// OpenBLAS picks its kernels for the processor, so another may round them differently).
/// A^T W A itself is sum_c theta_c B_c (W R W = W), and B_1, B_2 are sums over the position and the
/// rotation rows alone: two products of the stacked rows per pass where there were four. `W` gets each
/// sample's W_k = R_k^-1 (3 or 6 square) as a matrix, formed in the first pass: both passes, and the
/// caller's gradient and score, multiply by it (a product of 6 columns, where a factor's solve takes four
/// sweeps). A sample's own products (3 or 6 rows) are lazy, on matrices of fixed capacity (no heap
/// allocation per sample). `n_out`: N's factorization.
Eigen::Matrix3d remlInformation(const std::vector<Eigen::MatrixXd>& A, const std::vector<std::array<SampleMatrix, 3>>& V,
                                const Eigen::Vector3d& theta, const Eigen::VectorXd& prior, std::vector<SampleMatrix>& W,
                                Eigen::LDLT<Eigen::MatrixXd>* n_out = nullptr) {
  const Eigen::Index p = prior.size();
  constexpr std::size_t kChunk = 128;
  W.resize(A.size());
  // The samples [k0, k1) stacked: W A_k.
  const auto stack = [&](std::size_t k0, std::size_t k1, Eigen::MatrixXd& WA) {
    Eigen::Index rows = 0;
    for (std::size_t k = k0; k < k1; ++k) rows += A[k].rows();
    WA.resize(rows, p);
    for (std::size_t k = k0, row = 0; k < k1; row += static_cast<std::size_t>(A[k].rows()), ++k) {
      WA.middleRows(static_cast<Eigen::Index>(row), A[k].rows()).noalias() = W[k].lazyProduct(A[k]);
    }
  };
  struct Sums {
    std::array<Eigen::MatrixXd, 3> B;  ///< lower triangles
    Eigen::Matrix3d F = Eigen::Matrix3d::Zero();
  };
  // First pass over [k0, k1): B_c and sum_k tr(W V_c W V_d). V_1 and V_2 select a sample's position and
  // rotation rows, so B_1 and B_2 are the products of those rows of W A alone; A^T W A = sum_c theta_c B_c
  // (W R W = W), no product of its own.
  const auto first = [&](std::size_t k0, std::size_t k1) {
    Sums s;
    for (auto& b : s.B) b = Eigen::MatrixXd::Zero(p, p);
    Eigen::MatrixXd WA, part, VWA;
    for (std::size_t c0 = k0; c0 < k1; c0 += kChunk) {
      const std::size_t c1 = std::min(k1, c0 + kChunk);
      bool poses = false;
      for (std::size_t k = c0; k < c1; ++k) {
        W[k] = sampleWeight(V[k], theta);
        poses = poses || A[k].rows() == 6;
      }
      stack(c0, c1, WA);
      if (!poses) {
        addGram(s.B[0], WA);  // position rows alone
      } else {
        for (std::size_t c = 0; c < 2; ++c) {  // the position rows, then the rotation rows
          Eigen::Index rows = 0;
          for (std::size_t k = c0; k < c1; ++k) rows += c == 0 || A[k].rows() == 6 ? 3 : 0;
          part.resize(rows, p);
          for (std::size_t k = c0, row = 0, out = 0; k < c1; row += static_cast<std::size_t>(A[k].rows()), ++k) {
            if (c == 1 && A[k].rows() != 6) continue;
            part.middleRows(static_cast<Eigen::Index>(out), 3) = WA.middleRows(static_cast<Eigen::Index>(row + 3 * c), 3);
            out += 3;
          }
          addGram(s.B[c], part);
        }
      }
      VWA.resize(WA.rows(), p);
      for (std::size_t k = c0, row = 0; k < c1; row += static_cast<std::size_t>(A[k].rows()), ++k) {
        const auto r = static_cast<Eigen::Index>(row);
        VWA.middleRows(r, A[k].rows()).noalias() = V[k][2].lazyProduct(WA.middleRows(r, A[k].rows()));
      }
      addCrossProduct(s.B[2], WA, VWA);
      for (std::size_t k = c0; k < c1; ++k) {
        std::array<SampleMatrix, 3> WV;
        for (std::size_t c = 0; c < 3; ++c) WV[c].noalias() = W[k].lazyProduct(V[k][c]);
        for (std::size_t c = 0; c < 3; ++c) {
          for (std::size_t d = c; d < 3; ++d) s.F(static_cast<Eigen::Index>(c), static_cast<Eigen::Index>(d)) += traceOfProduct(WV[c], WV[d]);
        }
      }
    }
    return s;
  };
  const std::size_t half = A.size() / 2;
  auto upper = std::async(std::launch::async, first, half, A.size());
  Sums s = first(0, half);
  const Sums s2 = upper.get();
  for (std::size_t c = 0; c < 3; ++c) s.B[c] = (s.B[c] + s2.B[c]).selfadjointView<Eigen::Lower>();
  Eigen::MatrixXd N = theta[0] * s.B[0] + theta[1] * s.B[1] + theta[2] * s.B[2];
  N.diagonal() += prior;
  Eigen::Matrix3d F = s.F + s2.F;
  // Second pass: H_k = Y_k^T D^-1 Y_k with N = P^T L D L^T P and Y = L^-1 P A^T W.
  const Eigen::LDLT<Eigen::MatrixXd> Ninv(N);
  if (n_out) *n_out = Ninv;
  Eigen::VectorXd Dinv = Ninv.vectorD();
  for (Eigen::Index i = 0; i < p; ++i) Dinv[i] = std::abs(Dinv[i]) > std::numeric_limits<double>::min() ? 1.0 / Dinv[i] : 0.0;
  const auto second = [&](std::size_t k0, std::size_t k1) {
    Eigen::Matrix3d G = Eigen::Matrix3d::Zero();
    Eigen::MatrixXd WA, Y, DY;
    for (std::size_t c0 = k0; c0 < k1; c0 += kChunk) {
      const std::size_t c1 = std::min(k1, c0 + kChunk);
      stack(c0, c1, WA);
      Y = Ninv.transpositionsP() * WA.transpose();
      solveUnitLowerInPlace(Ninv.matrixLDLT(), Y);
      DY.noalias() = Dinv.asDiagonal() * Y;
      for (std::size_t k = c0, row = 0; k < c1; row += static_cast<std::size_t>(A[k].rows()), ++k) {
        const auto cols = Eigen::seqN(static_cast<Eigen::Index>(row), A[k].rows());
        const SampleMatrix H = Y(Eigen::all, cols).transpose().lazyProduct(DY(Eigen::all, cols));
        for (std::size_t c = 0; c < 3; ++c) {
          const SampleMatrix VcW = V[k][c].lazyProduct(W[k]);
          for (std::size_t d = c; d < 3; ++d) {
            const SampleMatrix VcWVd = VcW.lazyProduct(V[k][d]);
            G(static_cast<Eigen::Index>(c), static_cast<Eigen::Index>(d)) -= 2.0 * traceOfProduct(VcWVd, H);
          }
        }
      }
    }
    return G;
  };
  auto upper2 = std::async(std::launch::async, second, half, A.size());
  F += second(0, half);
  F += upper2.get();
  std::array<Eigen::MatrixXd, 3> NB;
  for (int c = 0; c < 3; ++c) NB[static_cast<std::size_t>(c)] = Ninv.solve(s.B[static_cast<std::size_t>(c)]);
  for (int c = 0; c < 3; ++c) {
    for (int d = c; d < 3; ++d) {
      F(c, d) += (NB[static_cast<std::size_t>(c)] * NB[static_cast<std::size_t>(d)]).trace();
      F(d, c) = F(c, d);
    }
  }
  return F;
}

/// Fisher scoring here converges linearly: where the last two plain steps (in deviations) point the
/// same way and shrink by one steady ratio lambda < 0.9, the fixed point lies about lambda / (1 -
/// lambda) of the last step further on (Aitken's extrapolation). That multiple; none otherwise.
std::optional<double> aitkenAhead(const Eigen::VectorXd& step, const Eigen::VectorXd& before) {
  if (before.size() != step.size() || before.squaredNorm() == 0.0) return std::nullopt;
  const double lambda = step.dot(before) / before.squaredNorm();
  if (!(lambda > 0.0 && lambda < 0.9) || (step - lambda * before).norm() > 0.2 * step.norm()) return std::nullopt;
  return lambda / (1.0 - lambda);
}

/// g = sum_k A_k^T W_k r_k (p entries), W_k = (sum_c theta_c V_kc)^-1 (remlInformation's).
Eigen::VectorXd whitenedGradient(const std::vector<Eigen::MatrixXd>& A, const std::vector<SampleMatrix>& W,
                                 const std::vector<Eigen::VectorXd>& r, Eigen::Index p) {
  Eigen::VectorXd g = Eigen::VectorXd::Zero(p);
  for (std::size_t k = 0; k < A.size(); ++k) {
    g.noalias() += A[k].transpose() * W[k].lazyProduct(r[k]);
  }
  return g;
}

}  // namespace

MarkerNoise estimateNoiseComponents(const MarkerPoseModel& m, const Eigen::VectorXd& y, const MarkerNoise& noise,
                                    const std::array<bool, 3>& free, const std::vector<int>& held, const Eigen::VectorXd& prior_sigma,
                                    NoiseComponents* components) {
  const int n = m.numSamples();
  std::vector<int> cols;
  for (int i = 0; i < m.numParams(); ++i) {
    if (!std::binary_search(held.begin(), held.end(), i)) cols.push_back(i);
  }
  Eigen::VectorXd prior = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(cols.size()));
  for (std::size_t c = 0; c < cols.size(); ++c) {
    const double s = prior_sigma.size() > cols[c] ? prior_sigma[cols[c]] : 0.0;
    prior[static_cast<Eigen::Index>(c)] = s > 0.0 ? 1.0 / (s * s) : 0.0;
  }
  // Per sample: the residual, the free Jacobian columns and V_k1..3 (fixed over the iterations).
  std::vector<Eigen::VectorXd> r(static_cast<std::size_t>(n));
  std::vector<Eigen::MatrixXd> A(static_cast<std::size_t>(n));
  std::vector<std::array<SampleMatrix, 3>> V(static_cast<std::size_t>(n));
  const auto setUp = [&](int k0, int k1) {  // each sample's own entries: the two halves side by side
    for (int k = k0; k < k1; ++k) {
      const auto i = static_cast<std::size_t>(k);
      Eigen::MatrixXd H;
      const Eigen::MatrixXd Jq = m.jointJacobian(k, y, &r[i], &H);  // one prediction for r, H and J_q
      A[i].resize(H.rows(), static_cast<Eigen::Index>(cols.size()));
      for (std::size_t c = 0; c < cols.size(); ++c) A[i].col(static_cast<Eigen::Index>(c)) = H.col(cols[c]);
      const Eigen::Index rows = r[i].size();
      V[i][0] = SampleMatrix::Zero(rows, rows);
      V[i][0].topLeftCorner(3, 3).setIdentity();
      V[i][1] = SampleMatrix::Zero(rows, rows);
      if (rows == 6) V[i][1].bottomRightCorner(3, 3).setIdentity();
      V[i][2].noalias() = Jq.lazyProduct(Jq.transpose());
    }
  };
  auto upper = std::async(std::launch::async, setUp, n / 2, n);
  setUp(0, n / 2);
  upper.get();
  // P y at a trial noise: the residuals refitted to it by one Gauss-Newton step from the fit's point,
  // delta = N^-1 (g(theta) - g(theta_fit)): the fit stopped where its gradient (g and the prior's share)
  // vanished at its own noise, theta_fit, where the iterations start.
  Eigen::VectorXd g_fit;
  Eigen::Vector3d theta(noise.sigma_position_m * noise.sigma_position_m, noise.sigma_rotation_rad * noise.sigma_rotation_rad,
                        noise.joint_noise_sigma_rad * noise.joint_noise_sigma_rad);
  std::vector<int> f;
  for (int c = 0; c < 3; ++c) {
    if (free[static_cast<std::size_t>(c)]) f.push_back(c);
  }
  const auto nf = static_cast<Eigen::Index>(f.size());
  const auto floorOf = [](int c) { return c == 2 ? 0.0 : 1e-18; };  // variances >= 0 (sigmas of position and rotation >= 1e-9)
  Eigen::MatrixXd F_last;
  std::vector<SampleMatrix> W;  // each sample's R_k^-1 at the current theta (remlInformation)
  Eigen::VectorXd before;  // the plain step before this one (empty after a jump)
  for (int iteration = 0; iteration < 50 && nf > 0; ++iteration) {
    Eigen::LDLT<Eigen::MatrixXd> Nl;
    const Eigen::Matrix3d I = remlInformation(A, V, theta, prior, W, &Nl);
    const Eigen::VectorXd g = whitenedGradient(A, W, r, prior.size());
    if (g_fit.size() == 0) g_fit = g;
    const Eigen::VectorXd delta = Nl.solve(g - g_fit);
    Eigen::MatrixXd F(nf, nf);
    Eigen::VectorXd u = Eigen::VectorXd::Zero(nf);
    for (int k = 0; k < n; ++k) {
      const std::array<SampleMatrix, 3>& Vk = V[static_cast<std::size_t>(k)];
      const Eigen::VectorXd Wr = W[static_cast<std::size_t>(k)].lazyProduct(r[static_cast<std::size_t>(k)] - A[static_cast<std::size_t>(k)] * delta);
      for (Eigen::Index a = 0; a < nf; ++a) u[a] += Wr.dot(Vk[static_cast<std::size_t>(f[static_cast<std::size_t>(a)])] * Wr);
    }
    for (Eigen::Index a = 0; a < nf; ++a) {
      const int ca = f[static_cast<std::size_t>(a)];
      for (int c = 0; c < 3; ++c) {  // the fixed components' share moved to the right-hand side
        if (!free[static_cast<std::size_t>(c)]) u[a] -= theta[c] * I(ca, c);
      }
      for (Eigen::Index b = 0; b < nf; ++b) F(a, b) = I(ca, f[static_cast<std::size_t>(b)]);
    }
    F_last = F;
    const Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(F);
    const Eigen::VectorXd next = cod.solve(u);
    // Converged when no component moves by more than kRemlTolerance of its own standard deviation
    // (sqrt of 2 F^-1's diagonal; further digits lie far inside what the data determine) or by more than
    // kRemlTolerance^2 of its value (the criterion before, which also holds where F gives no deviation).
    const Eigen::VectorXd sd = (2.0 * cod.pseudoInverse()).diagonal().cwiseMax(0.0).cwiseSqrt();
    double change = 0.0;
    Eigen::VectorXd step(nf), unit(nf);  // this step, in each component's unit (its deviation)
    for (Eigen::Index a = 0; a < nf; ++a) {
      const int c = f[static_cast<std::size_t>(a)];
      const double v = std::max(floorOf(c), next[a]);
      unit[a] = std::max({sd[a], kRemlTolerance * v, 1e-300});
      step[a] = (v - theta[c]) / unit[a];
      change = std::max(change, std::abs(step[a]));
      theta[c] = v;
    }
    if (change < kRemlTolerance) break;
    if (const std::optional<double> ahead = aitkenAhead(step, before)) {
      for (Eigen::Index a = 0; a < nf; ++a) {
        const int c = f[static_cast<std::size_t>(a)];
        theta[c] = std::max(floorOf(c), theta[c] + *ahead * step[a] * unit[a]);
      }
      before.resize(0);  // the next step tests the point jumped to; two plain steps before another jump
    } else {
      before = step;
    }
  }
  if (components && nf > 0) {
    // The variances' covariance: 2 F^-1 (the information of a Gaussian's covariance parameters is
    // tr(P V_c P V_d) / 2).
    const Eigen::MatrixXd C = 2.0 * F_last.completeOrthogonalDecomposition().pseudoInverse();
    *components = NoiseComponents{};
    for (Eigen::Index a = 0; a < nf; ++a) {
      const auto ca = static_cast<std::size_t>(f[static_cast<std::size_t>(a)]);
      components->estimated[ca] = true;
      for (Eigen::Index b = 0; b < nf; ++b) components->covariance(static_cast<Eigen::Index>(ca), f[static_cast<std::size_t>(b)]) = C(a, b);
    }
    components->variance = theta;
  }
  MarkerNoise out = noise;
  if (free[0]) out.sigma_position_m = std::max(1e-9, std::sqrt(theta[0]));
  if (free[1]) out.sigma_rotation_rad = std::max(1e-9, std::sqrt(theta[1]));
  if (free[2]) out.joint_noise_sigma_rad = std::sqrt(theta[2]);
  return out;
}

}  // namespace orbcal::calib
