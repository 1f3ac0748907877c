#include "orbcal/calib/observability.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <stdexcept>

#include "stacked_system.hpp"
#include "orbcal/calib/estimators.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/identifiability.hpp"

namespace orbcal::calib {

ObservabilityIndex parseObservabilityIndex(const std::string& text, const std::string& what) {
  if (text.size() == 2 && (text[0] == 'O' || text[0] == 'o') && text[1] >= '1' && text[1] <= '5') {
    return static_cast<ObservabilityIndex>(text[1] - '1');
  }
  throw sim::InputError(what + ": expected an observability index O1, O2, O3, O4 or O5, got '" + text + "'");
}

std::string observabilityIndexName(ObservabilityIndex index) { return "O" + std::to_string(static_cast<int>(index) + 1); }

double ObservabilityIndices::value(ObservabilityIndex index) const {
  switch (index) {
    case ObservabilityIndex::kO1: return o1;
    case ObservabilityIndex::kO2: return o2;
    case ObservabilityIndex::kO3: return o3;
    case ObservabilityIndex::kO4: return o4;
    case ObservabilityIndex::kO5: return o5;
  }
  return 0.0;
}

std::string formatIndices(const ObservabilityIndices& r) {
  char line[256];
  std::snprintf(line, sizeof line, "O1 %.4g, O2 %.4g, O3 %.4g, O4 %.4g, O5 %.4g; rank %d of %d, %d samples", r.o1, r.o2, r.o3,
                r.o4, r.o5, r.rank, r.num_params, r.num_samples);
  return line;
}

ObservabilityIndices indicesFromSingularValues(const Eigen::VectorXd& sigma_in, int num_samples) {
  ObservabilityIndices r;
  r.num_params = static_cast<int>(sigma_in.size());
  r.num_samples = num_samples;
  if (sigma_in.size() == 0) return r;
  const Eigen::VectorXd sigma = sigma_in.cwiseMax(0.0);
  const double smin = sigma.minCoeff(), smax = sigma.maxCoeff();
  if (smax <= 0.0) return r;
  r.o2 = smin / smax;
  r.o3 = smin;
  r.o4 = smin * smin / smax;
  if (smin > 0.0) {
    // Geometric mean through logs: the product of 28 singular values over- or underflows easily.
    r.o1 = std::exp(sigma.array().log().mean()) / std::sqrt(static_cast<double>(std::max(1, num_samples)));
    r.o5 = 1.0 / sigma.cwiseInverse().sum();
  }
  return r;
}

ObservabilityIndices observabilityIndices(const Eigen::MatrixXd& A, int num_samples, double rank_tolerance) {
  const Eigen::BDCSVD<Eigen::MatrixXd> svd(A);
  Eigen::VectorXd sigma = Eigen::VectorXd::Zero(A.cols());  // a wide A has zero singular values too
  sigma.head(svd.singularValues().size()) = svd.singularValues();
  ObservabilityIndices r = indicesFromSingularValues(sigma, num_samples);
  r.rank = A.size() == 0 ? 0 : sim::scaledSvd(A, rank_tolerance, false).rank;
  return r;
}

std::vector<Eigen::MatrixXd> observabilityBlocks(const MeasurementModel& model, const Eigen::VectorXd& y,
                                                 const std::vector<int>& held) {
  const Eigen::MatrixXd W = whitenedJacobian(model, y);
  const Eigen::VectorXd typical = model.layout().typical();
  std::vector<int> keep;
  for (int p = 0; p < model.numParams(); ++p) {
    if (std::find(held.begin(), held.end(), p) == held.end()) keep.push_back(p);
  }
  std::vector<Eigen::MatrixXd> blocks;
  blocks.reserve(static_cast<std::size_t>(model.numSamples()));
  for (int k = 0, row = 0; k < model.numSamples(); ++k) {
    const int r = model.rows(k);
    Eigen::MatrixXd B(r, static_cast<Eigen::Index>(keep.size()));
    for (std::size_t c = 0; c < keep.size(); ++c) {
      B.col(static_cast<Eigen::Index>(c)) = W.block(row, keep[c], r, 1) * typical[keep[c]];
    }
    blocks.push_back(std::move(B));
    row += r;
  }
  return blocks;
}

Eigen::MatrixXd stackBlocks(const std::vector<Eigen::MatrixXd>& blocks, const std::vector<int>& subset) {
  std::vector<int> all;
  if (subset.empty()) {
    for (int k = 0; k < static_cast<int>(blocks.size()); ++k) all.push_back(k);
  }
  const std::vector<int>& which = subset.empty() ? all : subset;
  Eigen::Index rows = 0, cols = blocks.empty() ? 0 : blocks.front().cols();
  for (int k : which) rows += blocks.at(static_cast<std::size_t>(k)).rows();
  Eigen::MatrixXd A(rows, cols);
  Eigen::Index row = 0;
  for (int k : which) {
    const Eigen::MatrixXd& B = blocks[static_cast<std::size_t>(k)];
    A.middleRows(row, B.rows()) = B;
    row += B.rows();
  }
  return A;
}

ObservabilityIndices observability(const MeasurementModel& model, const Eigen::VectorXd& y, const std::vector<int>& held,
                                   double rank_tolerance) {
  return observability(whitenedRFactor(model, y), model, held, rank_tolerance);
}

ObservabilityIndices observability(const Eigen::MatrixXd& R, const MeasurementModel& model, const std::vector<int>& held,
                                   double rank_tolerance) {
  // The typical-scaled kept columns of the whitened Jacobian's R factor: the same singular values as the
  // stacked columns (observabilityBlocks), without them.
  const Eigen::VectorXd typical = model.layout().typical();
  std::vector<Eigen::Index> keep;
  for (int p = 0; p < model.numParams(); ++p) {
    if (std::find(held.begin(), held.end(), p) == held.end()) keep.push_back(p);
  }
  Eigen::MatrixXd A(R.rows(), static_cast<Eigen::Index>(keep.size()));
  for (std::size_t c = 0; c < keep.size(); ++c) A.col(static_cast<Eigen::Index>(c)) = R.col(keep[c]) * typical[keep[c]];
  return observabilityIndices(A, model.numSamples(), rank_tolerance);
}

MarkerPoseModel posePlanningModel(const sim::Arm& nominal, const std::vector<Eigen::VectorXd>& configs,
                                  PoseNoiseModel noise) {
  std::vector<PoseObservation> obs;
  obs.reserve(configs.size());
  for (const Eigen::VectorXd& q : configs) obs.push_back({q, sim::forwardKinematics(nominal, q)});
  noise.source = PoseNoiseModel::Source::kFixed;
  return poseModel(nominal, obs, noise);
}

namespace {

using Clock = std::chrono::steady_clock;

/// n distinct indices of [0, pool), uniformly (partial Fisher-Yates on the raw engine, so the draw is
/// the same on every standard library), ascending.
std::vector<int> drawSubset(int pool, int n, std::mt19937_64& rng) {
  std::vector<int> p(static_cast<std::size_t>(pool));
  for (int i = 0; i < pool; ++i) p[static_cast<std::size_t>(i)] = i;
  for (int i = 0; i < n; ++i) {
    const int j = i + static_cast<int>(rng() % static_cast<std::uint64_t>(pool - i));
    std::swap(p[static_cast<std::size_t>(i)], p[static_cast<std::size_t>(j)]);
  }
  p.resize(static_cast<std::size_t>(n));
  std::sort(p.begin(), p.end());
  return p;
}

/// Scores a set from its information matrix M = A^T A: first its rank, then (below full rank) log
/// det(M + delta I), which the greedy start raises fastest, or (at full rank) the chosen index, with
/// values within tie_tolerance of each other (relative) ordered by log det M. Compared lexicographically.
struct Score {
  int rank = -1;
  double value = -std::numeric_limits<double>::infinity();
  double log_det = -std::numeric_limits<double>::infinity();
  bool full = false;
};

class Scorer {
 public:
  Scorer(ObservabilityIndex index, int m, double rank_tolerance, double delta, double tie_tolerance)
      : index_(index), m_(m), tol2_(rank_tolerance * rank_tolerance), delta_(delta), tie_(tie_tolerance) {}
  Score operator()(const Eigen::MatrixXd& M, int num_samples) {
    es_.compute(M, Eigen::EigenvaluesOnly);
    const Eigen::VectorXd& lambda = es_.eigenvalues();  // ascending
    const double lmax = std::max(lambda[m_ - 1], 0.0);
    Score s;
    s.rank = static_cast<int>((lambda.array() > tol2_ * lmax).count());
    if (lmax <= 0.0) {
      s.rank = 0;
      s.value = m_ * std::log(delta_);
    } else if (s.rank < m_) {
      s.value = (lambda.array().max(0.0) + delta_).log().sum();
    } else {
      s.full = true;
      s.value = indicesFromSingularValues(lambda.cwiseMax(0.0).cwiseSqrt(), num_samples).value(index_);
      s.log_det = lambda.array().log().sum();
    }
    return s;
  }
  /// a better than b, by more than `gain` (relative) where it is a gain in the index.
  bool better(const Score& a, const Score& b, double gain = 0.0) const {
    if (a.rank != b.rank) return a.rank > b.rank;
    if (a.full && b.full && tie_ > 0.0 && std::abs(a.value - b.value) <= tie_ * std::max(std::abs(a.value), std::abs(b.value))) {
      return a.log_det > b.log_det + gain * std::abs(b.log_det);
    }
    return a.value > b.value + gain * std::abs(b.value);
  }

 private:
  ObservabilityIndex index_;
  int m_;
  double tol2_, delta_, tie_;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es_;
};

/// The candidate not `in` the set whose information added to M scores best for a set of `size` (ties:
/// the first in `order`), with its score; T is scratch space.
std::pair<int, Score> bestAddition(const std::vector<int>& order, const std::vector<char>& in, const std::vector<Eigen::MatrixXd>& G,
                                   const Eigen::MatrixXd& M, Eigen::MatrixXd& T, Scorer& score, int size) {
  int best = -1;
  Score best_s;
  for (int c : order) {
    if (in[static_cast<std::size_t>(c)]) continue;
    T = M + G[static_cast<std::size_t>(c)];
    const Score s = score(T, size);
    if (best < 0 || score.better(s, best_s)) {
      best = c;
      best_s = s;
    }
  }
  return {best, best_s};
}

/// 0..N-1 in a seeded order (Fisher-Yates): the order candidates are tried in.
std::vector<int> seededOrder(int N, std::uint64_t seed) {
  auto rng = sim::makeRng(seed, 1);
  std::vector<int> p(static_cast<std::size_t>(N));
  for (int i = 0; i < N; ++i) p[static_cast<std::size_t>(i)] = i;
  for (int i = N - 1; i > 0; --i) std::swap(p[static_cast<std::size_t>(i)], p[rng() % static_cast<std::uint64_t>(i + 1)]);
  return p;
}

}  // namespace

std::vector<int> randomSubset(int pool, int n, std::uint64_t seed) {
  auto rng = sim::makeRng(seed);
  return drawSubset(pool, n, rng);
}

Selection selectConfigurations(const std::vector<Eigen::MatrixXd>& blocks, int n, const SelectionOptions& o) {
  const auto t0 = Clock::now();
  const int N = static_cast<int>(blocks.size());
  if (n < 1 || n > N) {
    throw std::invalid_argument("selectConfigurations: n = " + std::to_string(n) + " not in [1, " + std::to_string(N) + "]");
  }
  const int m = static_cast<int>(blocks.front().cols());
  Selection sel;
  if (m == 0) {
    sel.chosen = randomSubset(N, n, o.seed);
    return sel;
  }
  // Information of each candidate, G_c = A_c^T A_c: every set's M is a sum of them.
  std::vector<Eigen::MatrixXd> G(static_cast<std::size_t>(N));
  double trace = 0.0;
  for (int c = 0; c < N; ++c) {
    G[static_cast<std::size_t>(c)] = blocks[static_cast<std::size_t>(c)].transpose() * blocks[static_cast<std::size_t>(c)];
    trace += G[static_cast<std::size_t>(c)].trace();
  }
  // delta: far below any eigenvalue of a useful set (the mean per-sample eigenvalue is trace / (N m)).
  Scorer score(o.index, m, o.rank_tolerance, std::max(1e-300, 1e-9 * trace / (static_cast<double>(N) * m)),
               o.tie_tolerance);
  const std::vector<int> order = seededOrder(N, o.seed);  // ties go to the first
  std::vector<char> in(static_cast<std::size_t>(N), 0);
  std::vector<int> chosen;
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(m, m), T(m, m);

  // 1. Greedy forward selection.
  Score current;
  for (int step = 0; step < n; ++step) {
    const auto [best, best_s] = bestAddition(order, in, G, M, T, score, step + 1);
    chosen.push_back(best);
    in[static_cast<std::size_t>(best)] = 1;
    M += G[static_cast<std::size_t>(best)];
    current = best_s;
  }
  sel.greedy_value = current.rank == m ? current.value : 0.0;

  // 2. DETMAX excursions: add the best candidate (n + 1), drop the member whose loss hurts least (n).
  constexpr double kGain = 1e-6;  // relative improvement that counts
  if (n < N) {
    for (int excursion = 0; excursion < 10 * N; ++excursion) {
      const int add = bestAddition(order, in, G, M, T, score, n + 1).first;
      const Eigen::MatrixXd M_plus = M + G[static_cast<std::size_t>(add)];
      int drop = -1;
      Score drop_s;
      for (std::size_t i = 0; i < chosen.size(); ++i) {
        T = M_plus - G[static_cast<std::size_t>(chosen[i])];
        const Score s = score(T, n);
        if (drop < 0 || score.better(s, drop_s)) {
          drop = static_cast<int>(i);
          drop_s = s;
        }
      }
      if (!score.better(drop_s, current, kGain)) break;  // the excursion would only return to where it started
      in[static_cast<std::size_t>(chosen[static_cast<std::size_t>(drop)])] = 0;
      in[static_cast<std::size_t>(add)] = 1;
      chosen[static_cast<std::size_t>(drop)] = add;
      M = Eigen::MatrixXd::Zero(m, m);
      for (int k : chosen) M += G[static_cast<std::size_t>(k)];  // re-summed: no drift from +- updates
      current = drop_s;
      ++sel.exchanges;
    }
  }

  // 3. Pair exchanges: for each member in turn, its best replacement, taken when it improves.
  for (int pass = 0; pass < o.max_exchange_passes && n < N; ++pass) {
    bool improved = false;
    for (std::size_t i = 0; i < chosen.size(); ++i) {
      const Eigen::MatrixXd M_minus = M - G[static_cast<std::size_t>(chosen[i])];
      int best = -1;
      Score best_s = current;
      for (int c : order) {
        if (in[static_cast<std::size_t>(c)]) continue;
        T = M_minus + G[static_cast<std::size_t>(c)];
        const Score s = score(T, n);
        if (score.better(s, best_s, kGain)) {
          best = c;
          best_s = s;
        }
      }
      if (best < 0) continue;
      in[static_cast<std::size_t>(chosen[i])] = 0;
      in[static_cast<std::size_t>(best)] = 1;
      chosen[i] = best;
      M = Eigen::MatrixXd::Zero(m, m);
      for (int k : chosen) M += G[static_cast<std::size_t>(k)];
      current = best_s;
      improved = true;
      ++sel.exchanges;
    }
    if (!improved) break;
  }

  std::sort(chosen.begin(), chosen.end());
  sel.chosen = chosen;
  sel.indices = observabilityIndices(stackBlocks(blocks, chosen), n, o.rank_tolerance);
  sel.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return sel;
}

double meanRandomIndex(const std::vector<Eigen::MatrixXd>& blocks, int n, ObservabilityIndex index, int subsets,
                       std::uint64_t seed) {
  auto rng = sim::makeRng(seed, 2);
  double sum = 0.0;
  for (int s = 0; s < subsets; ++s) {
    sum += observabilityIndices(stackBlocks(blocks, drawSubset(static_cast<int>(blocks.size()), n, rng)), n).value(index);
  }
  return subsets > 0 ? sum / subsets : 0.0;
}

}  // namespace orbcal::calib
