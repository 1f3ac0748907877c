// Added-variable (score) F tests of the evidence family beside a model's own columns (lack_of_fit.hpp,
// variableTests), the columns streamed a block of rows at a time: what is kept is the R factor of
// [J y] and each variable's S^T J, never the (n m) x p columns (10^5 samples of a 200-parameter
// flexible model would be 1 GB).
#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <functional>
#include <future>

#include "orbcal/calib/diagnose.hpp"
#include "orbcal/calib/lack_of_fit.hpp"
#include "stacked_system.hpp"

namespace orbcal::calib {

namespace {

constexpr int kBlockRows = 256;

/// What the tests need of the model's columns J (one intercept per residual component appended), from
/// the R factor of [J y] (QR, never J^T J: a flexible model's columns leave directions whose squared
/// singular values lie near the rank tolerance, where the normal equations' rounding moved a test's
/// statistic by a fifth): J scaled to unit columns, D^-1, and its thin SVD U S V^T kept on the singular
/// values above sqrt(1e-12) of the largest (at least 1); `M` = D^-1 V S^-1, so that a variable's S^T J M
/// is its part along the model's span, and `Uz` = U^T Q^T y, the data's. The residual sum of squares
/// y^T (I - P_J) y, the rank, the rows.
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
    const Eigen::VectorXd d = R.colwise().norm().transpose();
    const Eigen::VectorXd s = (d.array() > 0).select(d.cwiseInverse(), 0.0);
    const Eigen::BDCSVD<Eigen::MatrixXd> svd(R * s.asDiagonal(), Eigen::ComputeThinU | Eigen::ComputeThinV);
    const Eigen::VectorXd& sv = svd.singularValues();
    const double top = sv.size() ? std::max(1.0, sv[0] * sv[0]) : 1.0;
    ModelSpan span;
    while (span.rank < sv.size() && sv[span.rank] * sv[span.rank] > 1e-12 * top) ++span.rank;
    const Eigen::MatrixXd U = svd.matrixU().leftCols(span.rank);
    span.M = s.asDiagonal() * svd.matrixV().leftCols(span.rank) * sv.head(span.rank).cwiseInverse().asDiagonal();
    span.Uz = U.transpose() * z;
    span.rows = rows;
    span.residual_ss = tail * tail + (z - U * span.Uz).squaredNorm();
    return span;
  }
};

/// The rows first .. first + count - 1 of the variable's regressors against a block of the model's
/// columns: S_block^T J_block, for stacked regressors ((n m) x d) or pooled ones (X n x d as X kron I_m:
/// column a m + c is X's column a in component c's rows).
Eigen::MatrixXd crossBlock(const EvidenceVariable& v, const Eigen::Ref<const Eigen::MatrixXd>& Jb, int first, int count, int m) {
  if (v.stacked.size() > 0) return v.stacked.middleRows(static_cast<Eigen::Index>(first) * m, static_cast<Eigen::Index>(count) * m).transpose() * Jb;
  const Eigen::Index d = v.X.cols(), p = Jb.cols();
  Eigen::MatrixXd SJ(d * m, p);
  using Strided = Eigen::Map<const Eigen::MatrixXd, 0, Eigen::Stride<Eigen::Dynamic, Eigen::Dynamic>>;
  for (Eigen::Index c = 0; c < m; ++c) {
    const Strided Jc(Jb.data() + c, count, p, Eigen::Stride<Eigen::Dynamic, Eigen::Dynamic>(Jb.outerStride(), m));
    const Eigen::MatrixXd XJ = v.X.middleRows(first, count).transpose() * Jc;
    for (Eigen::Index a = 0; a < d; ++a) SJ.row(a * m + c) = XJ.row(a);
  }
  return SJ;
}

/// S^T S and S^T y of the variable (whole: S is small beside J).
void ownProducts(const EvidenceVariable& v, const Eigen::MatrixXd& Y, const Eigen::VectorXd& y, Eigen::MatrixXd& SS,
                 Eigen::VectorXd& Sy) {
  if (v.stacked.size() > 0) {
    SS = v.stacked.transpose() * v.stacked;
    Sy = v.stacked.transpose() * y;
    return;
  }
  const Eigen::Index d = v.X.cols(), m = Y.cols();
  const Eigen::MatrixXd XX = v.X.transpose() * v.X, XY = v.X.transpose() * Y;
  SS.setZero(d * m, d * m);
  Sy.resize(d * m);
  for (Eigen::Index c = 0; c < m; ++c) {
    for (Eigen::Index a = 0; a < d; ++a) {
      Sy[a * m + c] = XY(a, c);
      for (Eigen::Index b = 0; b < d; ++b) SS(a * m + c, b * m + c) = XX(a, b);
    }
  }
}

/// The added-variable F test of regressors S (S^T S, S^T J, S^T y given) on y beside the model's columns:
/// the part of S the model cannot take, S~ = (I - P_J) S, against (I - P_J) y: the classical score test
/// of the variable, exact for the fit's own residuals under a linear model that holds.
bool addedVariableTest(const Eigen::MatrixXd& SS, const Eigen::MatrixXd& SJ, const Eigen::VectorXd& Sy, const ModelSpan& span,
                       VariableTest* t) {
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

/// What the tests keep of rows [first0, last): the R factor of [J y] and each variable's S^T J.
struct StreamedProducts {
  Eigen::MatrixXd R;
  std::vector<Eigen::MatrixXd> SJ;
};

StreamedProducts streamProducts(const Eigen::VectorXd& y, const std::vector<EvidenceVariable>& vars, const ModelColumns& model,
                                int first0, int last, int m) {
  const Eigen::Index p = model.params + m;  // the model's columns and one intercept per component
  StreamedProducts s{Eigen::MatrixXd(), std::vector<Eigen::MatrixXd>(vars.size())};
  RFactor r(p + 1);
  Eigen::MatrixXd Jm, Jb;
  for (int first = first0; first < last; first += kBlockRows) {
    const int count = std::min(kBlockRows, last - first);
    model.fill(first, count, Jm);
    Jb.setZero(static_cast<Eigen::Index>(count) * m, p + 1);
    Jb.leftCols(model.params) = Jm;
    for (Eigen::Index row = 0; row < Jb.rows(); ++row) Jb(row, model.params + row % m) = 1.0;
    Jb.col(p) = y.segment(static_cast<Eigen::Index>(first) * m, Jb.rows());
    r.add(Jb);
    for (std::size_t v = 0; v < vars.size(); ++v) {
      if (vars[v].stacked.size() > 0 && vars[v].stacked.rows() != y.size()) continue;
      const Eigen::MatrixXd block = crossBlock(vars[v], Jb.leftCols(p), first, count, m);
      if (s.SJ[v].size() == 0) s.SJ[v] = block;
      else s.SJ[v] += block;
    }
  }
  s.R = r.matrix();
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
    Eigen::MatrixXd SS;
    Eigen::VectorXd Sy;
    ownProducts(vars[v], Y, y, SS, Sy);
    VariableTest t;
    t.variable = vars[v].name;
    if (addedVariableTest(SS, SJ[v], Sy, span, &t)) out.push_back(t);
  }
  return out;
}

}  // namespace orbcal::calib
