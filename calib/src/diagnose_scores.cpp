#include "diagnose_scores.hpp"

#include <algorithm>
#include <cmath>
#include <future>

#include "stacked_system.hpp"
#include "orbcal/sim/identifiability.hpp"

namespace orbcal::calib {

namespace {

constexpr int kBlock = 128;    ///< samples per accumulated block
constexpr int kParallel = 64;  ///< fewer samples: one thread

/// The sums over samples [k0, k1).
struct ScoreSums {
  Eigen::MatrixXd R;                 ///< R factor of [Af b] (nf + 1 columns; rows: at most nf + 1)
  Eigen::MatrixXd AtB;               ///< Af^T B, B every candidate's columns side by side
  Eigen::VectorXd Btb;               ///< B^T b
  std::vector<Eigen::MatrixXd> BtB;  ///< each candidate's B_c^T B_c
  Eigen::Index rows = 0;
};

ScoreSums sums(const std::vector<MarkerPoseModel>& layers, const std::vector<int>& free, const std::vector<CandidateColumns>& cands,
               const std::vector<Eigen::Index>& offset, int k0, int k1) {
  const auto nf = static_cast<Eigen::Index>(free.size());
  const Eigen::Index nb = offset.back();
  RFactor rf(nf + 1);
  ScoreSums s;
  s.AtB = Eigen::MatrixXd::Zero(nf, nb);
  s.Btb = Eigen::VectorXd::Zero(nb);
  for (const CandidateColumns& c : cands) s.BtB.push_back(Eigen::MatrixXd::Zero(c.scale.size(), c.scale.size()));
  std::vector<Eigen::VectorXd> zero;
  for (const MarkerPoseModel& m : layers) zero.push_back(Eigen::VectorXd::Zero(m.numParams()));
  std::vector<Eigen::MatrixXd> H(layers.size());
  Eigen::VectorXd b;
  Eigen::MatrixXd M, B;
  const MarkerPoseModel& last = layers.back();
  for (int c0 = k0; c0 < k1; c0 += kBlock) {
    const int c1 = std::min(k1, c0 + kBlock);
    Eigen::Index rows = 0;
    for (int k = c0; k < c1; ++k) rows += last.rows(k);
    M.resize(rows, nf + 1);
    B.resize(rows, nb);
    for (int k = c0, row = 0; k < c1; row += last.rows(k), ++k) {
      const int r = last.rows(k);
      for (std::size_t l = 0; l < layers.size(); ++l) whitenedRows(layers[l], k, zero[l], H[l], b);  // b: the last layer's
      for (Eigen::Index c = 0; c < nf; ++c) M.block(row, c, r, 1) = H.back().col(free[static_cast<std::size_t>(c)]);
      M.block(row, nf, r, 1) = b;
      for (std::size_t i = 0; i < cands.size(); ++i) {
        const CandidateColumns& cc = cands[i];
        for (Eigen::Index j = 0; j < cc.scale.size(); ++j) {
          B.block(row, offset[i] + j, r, 1) = H[cc.layer].col(cc.cols[static_cast<std::size_t>(j)]) * cc.scale[j];
        }
      }
    }
    rf.add(M);
    s.AtB.noalias() += M.leftCols(nf).transpose() * B;
    s.Btb.noalias() += B.transpose() * M.col(nf);
    for (std::size_t i = 0; i < cands.size(); ++i) {
      const auto Bi = B.middleCols(offset[i], offset[i + 1] - offset[i]);
      s.BtB[i].noalias() += Bi.transpose() * Bi;
    }
    s.rows += rows;
  }
  s.R = rf.matrix();
  return s;
}

/// The sums over all samples: two halves side by side, added in a fixed order.
ScoreSums allSums(const std::vector<MarkerPoseModel>& layers, const std::vector<int>& free, const std::vector<CandidateColumns>& cands,
                  const std::vector<Eigen::Index>& offset) {
  const int n = layers.back().numSamples();
  if (n < kParallel) return sums(layers, free, cands, offset, 0, n);
  auto upper = std::async(std::launch::async, [&] { return sums(layers, free, cands, offset, n / 2, n); });
  ScoreSums s = sums(layers, free, cands, offset, 0, n / 2);
  const ScoreSums u = upper.get();
  RFactor rf(static_cast<Eigen::Index>(free.size()) + 1);
  rf.add(s.R);
  rf.add(u.R);
  s.R = rf.matrix();
  s.AtB += u.AtB;
  s.Btb += u.Btb;
  for (std::size_t i = 0; i < s.BtB.size(); ++i) s.BtB[i] += u.BtB[i];
  s.rows += u.rows;
  return s;
}

}  // namespace

ScoreStatistics scoreStatistics(const std::vector<MarkerPoseModel>& layers, const std::vector<int>& free,
                                const std::vector<CandidateColumns>& candidates) {
  std::vector<Eigen::Index> offset{0};
  for (const CandidateColumns& c : candidates) offset.push_back(offset.back() + c.scale.size());
  const ScoreSums s = allSums(layers, free, candidates, offset);
  const auto nf = static_cast<Eigen::Index>(free.size());
  Eigen::MatrixXd R = Eigen::MatrixXd::Zero(nf + 1, nf + 1);
  R.topRows(std::min(nf + 1, s.R.rows())) = s.R.topRows(std::min(nf + 1, s.R.rows()));
  const Eigen::VectorXd r1 = R.col(nf).head(nf);
  // Af = Q1 R11 and R11 D = U S V^T: Af's left singular vectors Q = Q1 U, whose first `rank` span the
  // model's columns; Q^T b = U^T r1 and Q^T B = S^-1 V^T D Af^T B.
  const sim::ScaledSvd svd = sim::scaledSvd(R.topLeftCorner(nf, nf), sim::kRankTolerance);
  const int rank = svd.rank;
  const Eigen::VectorXd Qb = svd.U.leftCols(rank).transpose() * r1;
  const Eigen::MatrixXd QB = svd.singular_values.head(rank).cwiseInverse().asDiagonal() *
                             (svd.V.leftCols(rank).transpose() * (svd.scale.asDiagonal() * s.AtB));
  ScoreStatistics out;
  out.dof = std::max(1.0, static_cast<double>(s.rows - rank));
  const double ee = std::max(0.0, r1.squaredNorm() + R(nf, nf) * R(nf, nf) - Qb.squaredNorm());  // |e|^2
  const double s2 = ee / out.dof;  // residual variance in whitened units (1 when the noise is right)
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const Eigen::Index off = offset[i], nc = offset[i + 1] - offset[i];
    const auto T = QB.middleCols(off, nc);
    const Eigen::MatrixXd& G = s.BtB[i];
    ScoreStatistic st;
    const double bb = G.trace();
    st.absorbed = bb > 0.0 ? 1.0 - std::sqrt(std::max(0.0, bb - T.squaredNorm())) / std::sqrt(bb) : 1.0;
    // What this data can see of it: the directions beyond the current model along which an effect of
    // typical size moves the whitened data by at least one noise sigma in all (singular values of the
    // typical-scaled projected columns above 1, eigenvalues of Bp^T Bp above 1).
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(G - T.transpose() * T);
    const Eigen::VectorXd Bte = s.Btb.segment(off, nc) - T.transpose() * Qb;  // Bp^T e = B^T e
    double proj2 = 0.0;
    for (Eigen::Index j = 0; j < nc; ++j) {
      const double lambda = es.eigenvalues()[j];
      if (!(lambda > 1.0)) continue;
      ++st.rank;
      proj2 += std::pow(es.eigenvectors().col(j).dot(Bte), 2) / lambda;
    }
    st.score = st.rank > 0 ? proj2 / s2 : 0.0;
    out.candidates.push_back(st);
  }
  return out;
}

}  // namespace orbcal::calib
