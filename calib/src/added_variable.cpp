// Added-variable (score) F tests of the evidence family beside a model's own columns (lack_of_fit.hpp,
// variableTests), the columns streamed a block of rows at a time: what is kept is the R factor of
// [J y] and each variable's S^T J, never the (n m) x p columns (10^5 samples of a 200-parameter
// flexible model would be 1 GB).
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <functional>
#include <future>

#include "orbcal/calib/dense_kernels.hpp"
#include "orbcal/calib/diagnose.hpp"
#include "orbcal/calib/lack_of_fit.hpp"
#include "orbcal/sim/identifiability.hpp"
#include "stacked_system.hpp"

namespace orbcal::calib {

namespace {

constexpr int kBlockRows = 256;

/// What the tests need of the model's columns J (one intercept per residual component appended), from
/// the R factor of [J y] (QR, never J^T J: a flexible model's columns leave directions whose squared
/// singular values lie near the rank tolerance, where the normal equations' rounding moved a test's
/// statistic by a fifth): the thin SVD U S V^T of R D (D scales its columns to unit norm; sim::scaledSvd),
/// kept on the singular values above kRankTolerance of the largest; `M` = D V S^-1, so that a variable's
/// S^T J M is its part along the model's span, and `Uz` = U^T Q^T y, the data's. The residual sum of
/// squares y^T (I - P_J) y, the rank, the rows.
struct ModelSpan {
  Eigen::MatrixXd M;
  Eigen::VectorXd Uz;
  int rank = 0;
  Eigen::Index rows = 0;
  double residual_ss = 0.0;

  static ModelSpan of(const Eigen::MatrixXd& R_aug, Eigen::Index rows) {
    const Eigen::Index p = R_aug.cols() - 1, k = std::min(R_aug.rows(), p);
    const Eigen::MatrixXd R = R_aug.topLeftCorner(k, p);
    const Eigen::VectorXd z = R_aug.col(p).head(k);
    const double tail = R_aug.rows() > p ? R_aug(p, p) : 0.0;
    // Divide and conquer: the span's directions and their singular values are read relative to the largest.
    const sim::ScaledSvd svd = sim::scaledSvd(R, sim::kRankTolerance, true, sim::SvdMethod::kDivideAndConquer);
    ModelSpan span;
    span.rank = svd.rank;
    const Eigen::MatrixXd U = svd.U.leftCols(span.rank);
    span.M = svd.scale.asDiagonal() * svd.V.leftCols(span.rank) * svd.singular_values.head(span.rank).cwiseInverse().asDiagonal();
    span.Uz = U.transpose() * z;
    span.rows = rows;
    span.residual_ss = tail * tail + (z - U * span.Uz).squaredNorm();
    return span;
  }
};

/// S^T S of the variable (whole: S is small beside J), for `m` residual components.
Eigen::MatrixXd ownGram(const EvidenceVariable& v, Eigen::Index m) {
  if (v.stacked.size() > 0) return v.stacked.transpose() * v.stacked;
  const Eigen::Index d = v.X.cols();
  const Eigen::MatrixXd XX = v.X.transpose() * v.X;
  Eigen::MatrixXd SS = Eigen::MatrixXd::Zero(d * m, d * m);
  for (Eigen::Index c = 0; c < m; ++c) {
    for (Eigen::Index a = 0; a < d; ++a) {
      for (Eigen::Index b = 0; b < d; ++b) SS(a * m + c, b * m + c) = XX(a, b);
    }
  }
  return SS;
}

/// The added-variable F test of regressors S (S^T S, S^T J, S^T y given) on y beside the model's columns:
/// the part of S the model cannot take, S~ = (I - P_J) S, against (I - P_J) y: the classical score test
/// of the variable, exact for the fit's own residuals under a linear model that holds.
bool addedVariableTest(const Eigen::MatrixXd& SS, const Eigen::Ref<const Eigen::MatrixXd>& SJ, const Eigen::Ref<const Eigen::VectorXd>& Sy,
                       const ModelSpan& span, VariableTest* t) {
  const Eigen::MatrixXd W = SJ * span.M;
  const Eigen::MatrixXd G = SS - W * W.transpose();
  const Eigen::VectorXd b = Sy - W * span.Uz;
  // Directions of S of which the model's columns take all but 1e-3 of the length are not testable.
  const Eigen::VectorXd dS = SS.diagonal().cwiseMax(0.0).cwiseSqrt();
  const Eigen::VectorXd sc = (dS.array() > 0).select(dS.cwiseInverse(), 0.0);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(sc.asDiagonal() * G * sc.asDiagonal());
  const Eigen::VectorXd proj = es.eigenvectors().transpose() * (sc.asDiagonal() * b);
  double explained = 0.0;
  int d = 0;
  for (Eigen::Index k = 0; k < proj.size(); ++k) {
    if (es.eigenvalues()[k] <= 1e-6) continue;
    explained += proj[k] * proj[k] / es.eigenvalues()[k];
    ++d;
  }
  const double dof2 = static_cast<double>(span.rows) - span.rank - d;
  if (d == 0 || dof2 <= 0) return false;
  t->dof = d;
  t->statistic = (explained / d) / (std::max(1e-300, span.residual_ss - explained) / dof2);
  t->p_value = fSurvival(t->statistic, d, dof2);
  return true;
}

}  // namespace

ModelColumns ModelColumns::of(const Eigen::MatrixXd& J, int components) {
  ModelColumns c;
  c.rows = components > 0 ? static_cast<int>(J.rows() / components) : 0;
  c.components = components;
  c.params = static_cast<int>(J.cols());
  c.fill = [J, components](int first, int count, Eigen::MatrixXd& out) {
    out = J.middleRows(static_cast<Eigen::Index>(first) * components, static_cast<Eigen::Index>(count) * components);
  };
  return c;
}

namespace {

/// What the tests keep of rows [first0, last): the R factor of [J y] and each variable's S^T [J y].
struct StreamedProducts {
  Eigen::MatrixXd R;
  std::vector<Eigen::MatrixXd> SJ;
};

/// Where each variable's regressors sit among all the variables' side by side: the pooled ones (X, n
/// rows) and the stacked ones ((n m) rows) each form one matrix, so that a block of rows meets the
/// model's columns in one BLAS product per kind (per component for the pooled), not one small product
/// per variable (those were most of a long log's lack-of-fit test).
struct GatheredColumns {
  std::vector<Eigen::Index> offset;  ///< per variable, its first column among its kind's; -1: not tested
  Eigen::Index pooled = 0, stacked = 0;

  GatheredColumns(const std::vector<EvidenceVariable>& vars, Eigen::Index stacked_rows) : offset(vars.size(), -1) {
    for (std::size_t v = 0; v < vars.size(); ++v) {
      if (vars[v].stacked.size() > 0) {
        if (vars[v].stacked.rows() != stacked_rows) continue;
        offset[v] = stacked;
        stacked += vars[v].stacked.cols();
      } else {
        offset[v] = pooled;
        pooled += vars[v].X.cols();
      }
    }
  }
};

StreamedProducts streamProducts(const Eigen::VectorXd& y, const std::vector<EvidenceVariable>& vars, const ModelColumns& model,
                                int first0, int last, int m) {
  const Eigen::Index p = model.params + m;  // the model's columns and one intercept per component
  const GatheredColumns g(vars, y.size());
  RFactor r(p + 1);
  Eigen::MatrixXd Jm, Jb, Jc, Xb, Sb;
  // X^T [J y]_c per component c (pooled) and S^T [J y] (stacked).
  std::vector<Eigen::MatrixXd> XJ(static_cast<std::size_t>(m), Eigen::MatrixXd::Zero(g.pooled, p + 1));
  Eigen::MatrixXd SJ = Eigen::MatrixXd::Zero(g.stacked, p + 1);
  for (int first = first0; first < last; first += kBlockRows) {
    const int count = std::min(kBlockRows, last - first);
    const Eigen::Index rows = static_cast<Eigen::Index>(count) * m;
    model.fill(first, count, Jm);
    Jb.setZero(rows, p + 1);
    Jb.leftCols(model.params) = Jm;
    for (Eigen::Index row = 0; row < rows; ++row) Jb(row, model.params + row % m) = 1.0;
    Jb.col(p) = y.segment(static_cast<Eigen::Index>(first) * m, rows);
    r.add(Jb);
    Xb.resize(count, g.pooled);
    Sb.resize(rows, g.stacked);
    for (std::size_t v = 0; v < vars.size(); ++v) {
      if (g.offset[v] < 0) continue;
      if (vars[v].stacked.size() > 0) {
        Sb.middleCols(g.offset[v], vars[v].stacked.cols()) = vars[v].stacked.middleRows(static_cast<Eigen::Index>(first) * m, rows);
      } else {
        Xb.middleCols(g.offset[v], vars[v].X.cols()) = vars[v].X.middleRows(first, count);
      }
    }
    if (g.stacked > 0) addCrossProduct(SJ, Sb, Jb);
    for (Eigen::Index c = 0; c < m && g.pooled > 0; ++c) {
      Jc = Eigen::Map<const Eigen::MatrixXd, 0, Eigen::Stride<Eigen::Dynamic, Eigen::Dynamic>>(
          Jb.data() + c, count, p + 1, Eigen::Stride<Eigen::Dynamic, Eigen::Dynamic>(Jb.outerStride(), m));
      addCrossProduct(XJ[static_cast<std::size_t>(c)], Xb, Jc);
    }
  }
  // Each variable's S^T [J y]: a pooled one's row a m + c is X's column a against component c's rows.
  StreamedProducts s{r.matrix(), std::vector<Eigen::MatrixXd>(vars.size())};
  for (std::size_t v = 0; v < vars.size(); ++v) {
    if (g.offset[v] < 0 || first0 >= last) continue;
    if (vars[v].stacked.size() > 0) {
      s.SJ[v] = SJ.middleRows(g.offset[v], vars[v].stacked.cols());
      continue;
    }
    const Eigen::Index d = vars[v].X.cols();
    s.SJ[v].resize(d * m, p + 1);
    for (Eigen::Index a = 0; a < d; ++a) {
      for (Eigen::Index c = 0; c < m; ++c) s.SJ[v].row(a * m + c) = XJ[static_cast<std::size_t>(c)].row(g.offset[v] + a);
    }
  }
  return s;
}

}  // namespace

std::vector<VariableTest> addedVariableTests(const Eigen::MatrixXd& Y, const std::vector<EvidenceVariable>& vars,
                                             const ModelColumns& model) {
  const int n = static_cast<int>(Y.rows()), m = static_cast<int>(Y.cols());
  if (model.rows != n || model.components != m || !model.fill) return {};
  Eigen::VectorXd y(static_cast<Eigen::Index>(n) * m);
  for (int i = 0; i < n; ++i) y.segment(static_cast<Eigen::Index>(i) * m, m) = Y.row(i).transpose();
  // The two halves of the rows side by side (the columns' evaluation is most of the time), joined in a
  // fixed order: the same R factor and sums on one machine (OpenBLAS's kernels depend on the processor).
  const int half = n >= 2 * kBlockRows ? (n / 2 / kBlockRows) * kBlockRows : n;
  auto upper = std::async(std::launch::async, streamProducts, std::cref(y), std::cref(vars), std::cref(model), half, n, m);
  StreamedProducts s = streamProducts(y, vars, model, 0, half, m);
  const StreamedProducts u = upper.get();
  RFactor both(s.R.cols());
  both.add(s.R);
  both.add(u.R);
  std::vector<Eigen::MatrixXd>& SJ = s.SJ;
  for (std::size_t v = 0; v < vars.size(); ++v) {
    if (SJ[v].size() == 0) SJ[v] = u.SJ[v];
    else if (u.SJ[v].size() > 0) SJ[v] += u.SJ[v];
  }
  const ModelSpan span = ModelSpan::of(both.matrix(), y.size());
  std::vector<VariableTest> out;
  for (std::size_t v = 0; v < vars.size(); ++v) {
    if (SJ[v].size() == 0) continue;
    const Eigen::Index p = SJ[v].cols() - 1;  // S^T [J y]: S^T J, then S^T y
    VariableTest t;
    t.variable = vars[v].name;
    if (addedVariableTest(ownGram(vars[v], m), SJ[v].leftCols(p), SJ[v].col(p), span, &t)) out.push_back(t);
  }
  return out;
}

}  // namespace orbcal::calib
