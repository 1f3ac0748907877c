// Added-variable (score) F tests of the evidence family beside a model's own columns (lack_of_fit.hpp,
// variableTests), the columns streamed a block of rows at a time: what is kept is J^T J, J^T y and each
// variable's S^T J, never the (n m) x p columns (10^5 samples of a 200-parameter flexible model would
// be 1 GB).
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <functional>
#include <future>

#include "orbcal/calib/diagnose.hpp"
#include "orbcal/calib/lack_of_fit.hpp"

namespace orbcal::calib {

namespace {

constexpr int kBlockRows = 256;

/// Pseudo-inverse of a symmetric positive semi-definite A, scaled to unit diagonal first (columns of
/// very different units), eigenvalues below rel_tol of the largest (at least 1) dropped; `rank` gets the
/// kept count.
Eigen::MatrixXd scaledPseudoInverse(const Eigen::MatrixXd& A, double rel_tol, int* rank) {
  const Eigen::VectorXd d = A.diagonal().cwiseMax(0.0).cwiseSqrt();
  const Eigen::VectorXd s = (d.array() > 0).select(d.cwiseInverse(), 0.0);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(s.asDiagonal() * A * s.asDiagonal());
  const Eigen::VectorXd& l = es.eigenvalues();
  const double top = l.size() ? std::max(1.0, l.maxCoeff()) : 1.0;
  Eigen::VectorXd inv = Eigen::VectorXd::Zero(l.size());
  *rank = 0;
  for (Eigen::Index k = 0; k < l.size(); ++k) {
    if (l[k] > rel_tol * top) {
      inv[k] = 1.0 / l[k];
      ++*rank;
    }
  }
  return s.asDiagonal() * es.eigenvectors() * inv.asDiagonal() * es.eigenvectors().transpose() * s.asDiagonal();
}

/// What the tests need of the model's columns J (one intercept per residual component appended):
/// (J^T J)^+, J^T y, the rank, the rows, y^T (I - P_J) y.
struct ModelSpan {
  Eigen::MatrixXd A_pinv;
  Eigen::VectorXd Jy;
  int rank = 0;
  Eigen::Index rows = 0;
  double residual_ss = 0.0;
};

/// The rows first .. first + count - 1 of the variable's regressors against a block of the model's
/// columns: S_block^T J_block, for stacked regressors ((n m) x d) or pooled ones (X n x d as X kron I_m:
/// column a m + c is X's column a in component c's rows).
Eigen::MatrixXd crossBlock(const EvidenceVariable& v, const Eigen::MatrixXd& Jb, int first, int count, int m) {
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
  const Eigen::MatrixXd CA = SJ * span.A_pinv;
  const Eigen::MatrixXd G = SS - CA * SJ.transpose();
  const Eigen::VectorXd b = Sy - CA * span.Jy;
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

/// What the tests keep of rows [first0, last): J^T J (lower triangle), J^T y and each variable's S^T J.
struct StreamedProducts {
  Eigen::MatrixXd A;
  Eigen::VectorXd Jy;
  std::vector<Eigen::MatrixXd> SJ;
};

StreamedProducts streamProducts(const Eigen::VectorXd& y, const std::vector<EvidenceVariable>& vars, const ModelColumns& model,
                                int first0, int last, int m) {
  const Eigen::Index p = model.params + m;  // the model's columns and one intercept per component
  StreamedProducts s{Eigen::MatrixXd::Zero(p, p), Eigen::VectorXd::Zero(p), std::vector<Eigen::MatrixXd>(vars.size())};
  Eigen::MatrixXd Jm, Jb;
  for (int first = first0; first < last; first += kBlockRows) {
    const int count = std::min(kBlockRows, last - first);
    model.fill(first, count, Jm);
    Jb.setZero(static_cast<Eigen::Index>(count) * m, p);
    Jb.leftCols(model.params) = Jm;
    for (Eigen::Index r = 0; r < Jb.rows(); ++r) Jb(r, model.params + r % m) = 1.0;
    s.A.selfadjointView<Eigen::Lower>().rankUpdate(Jb.transpose());
    s.Jy += Jb.transpose() * y.segment(static_cast<Eigen::Index>(first) * m, Jb.rows());
    for (std::size_t v = 0; v < vars.size(); ++v) {
      if (vars[v].stacked.size() > 0 && vars[v].stacked.rows() != y.size()) continue;
      const Eigen::MatrixXd block = crossBlock(vars[v], Jb, first, count, m);
      if (s.SJ[v].size() == 0) s.SJ[v] = block;
      else s.SJ[v] += block;
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
  // The two halves of the rows side by side (the columns' evaluation is most of the time), added in a
  // fixed order: the same sums on any machine.
  const int half = n >= 2 * kBlockRows ? (n / 2 / kBlockRows) * kBlockRows : n;
  auto upper = std::async(std::launch::async, streamProducts, std::cref(y), std::cref(vars), std::cref(model), half, n, m);
  StreamedProducts s = streamProducts(y, vars, model, 0, half, m);
  const StreamedProducts u = upper.get();
  Eigen::MatrixXd A = s.A + u.A;
  const Eigen::VectorXd Jy = s.Jy + u.Jy;
  std::vector<Eigen::MatrixXd>& SJ = s.SJ;
  for (std::size_t v = 0; v < vars.size(); ++v) {
    if (SJ[v].size() == 0) SJ[v] = u.SJ[v];
    else if (u.SJ[v].size() > 0) SJ[v] += u.SJ[v];
  }
  A = A.selfadjointView<Eigen::Lower>();
  ModelSpan span;
  span.A_pinv = scaledPseudoInverse(A, 1e-12, &span.rank);
  span.Jy = Jy;
  span.rows = y.size();
  span.residual_ss = std::max(0.0, y.squaredNorm() - Jy.dot(span.A_pinv * Jy));
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
