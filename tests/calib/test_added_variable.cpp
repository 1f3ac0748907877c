// calib::variableTests beside a model's own columns (the added-variable test): on a linear model it is
// the nested-model F test computed independently here from two least-squares fits; on the residuals of
// a model that holds it rejects at its nominal rate, where a plain regression of held-out residuals
// (each fold's estimation error is a smooth function of the configuration) rejects far more often; a
// variable the model lacks is found.
#include <catch2/catch.hpp>

#include <Eigen/QR>
#include <cmath>
#include <random>

#include "orbcal/calib/diagnose.hpp"
#include "orbcal/calib/lack_of_fit.hpp"

using namespace orbcal;

namespace {

/// A smooth design of p columns (polynomials and harmonics of two configuration variables u, v), as a
/// calibration model's Jacobian is a smooth function of the joint angles.
Eigen::MatrixXd smoothColumns(const Eigen::VectorXd& u, const Eigen::VectorXd& v, int p) {
  Eigen::MatrixXd J(u.size(), p);
  for (int k = 0; k < p; ++k) {
    const double h = 1 + k / 4;
    switch (k % 4) {
      case 0: J.col(k) = (h * u.array()).sin().matrix(); break;
      case 1: J.col(k) = (h * v.array()).cos().matrix(); break;
      case 2: J.col(k) = (u.array() * (h * v.array()).sin()).matrix(); break;
      default: J.col(k) = (v.array().pow(2 + k % 3) * u.array()).matrix(); break;
    }
  }
  return J;
}

Eigen::VectorXd leastSquaresResidual(const Eigen::MatrixXd& A, const Eigen::VectorXd& y) {
  return y - A * A.colPivHouseholderQr().solve(y);
}

struct World {
  Eigen::VectorXd u, v;
  Eigen::MatrixXd J;  ///< the model's columns (n x p), one residual component (m = 1)
};

World world(std::mt19937_64& rng, int n, int p) {
  std::uniform_real_distribution<double> angle(-2.5, 2.5);
  World w;
  w.u.resize(n);
  w.v.resize(n);
  for (int i = 0; i < n; ++i) {
    w.u[i] = angle(rng);
    w.v[i] = angle(rng);
  }
  w.J = smoothColumns(w.u, w.v, p);
  return w;
}

/// The single test of `var` (a test that finds nothing testable fails here, not by a crash).
calib::VariableTest only(const std::vector<calib::VariableTest>& t) {
  REQUIRE(t.size() == 1);
  return t.front();
}

/// Held-out residuals of y by 5-fold cross-validation of a least-squares fit of J (folds by index).
Eigen::VectorXd heldOut(const Eigen::MatrixXd& J, const Eigen::VectorXd& y, int folds) {
  const Eigen::Index n = y.size();
  Eigen::VectorXd r(n);
  for (int f = 0; f < folds; ++f) {
    std::vector<Eigen::Index> in, out;
    for (Eigen::Index i = 0; i < n; ++i) (i % folds == f ? out : in).push_back(i);
    const Eigen::VectorXd beta = J(in, Eigen::all).colPivHouseholderQr().solve(y(in));
    r(out) = y(out) - J(out, Eigen::all) * beta;
  }
  return r;
}

calib::EvidenceVariable variable(const std::string& name, const Eigen::MatrixXd& X) {
  return {name, X, Eigen::MatrixXd(), name, X.col(0)};
}

}  // namespace

TEST_CASE("added-variable test: on a linear model it is the nested-model F test", "[calib][lack_of_fit]") {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> n01;
  const int n = 600, p = 12;  // more rows than one block of the streamed columns
  const World w = world(rng, n, p);
  Eigen::VectorXd y(n);
  for (int i = 0; i < n; ++i) y[i] = 0.3 * std::cos(w.u[i]) * w.v[i] + n01(rng);
  Eigen::MatrixXd X(n, 2);
  X << (w.u.array().cos() * w.v.array()).matrix(), w.u.array().square().matrix();
  // Independently: the model with an intercept, with and without X, fitted by QR.
  Eigen::MatrixXd A0(n, p + 1), A1(n, p + 3);
  A0 << w.J, Eigen::VectorXd::Ones(n);
  A1 << A0, X;
  const double rss0 = leastSquaresResidual(A0, y).squaredNorm(), rss1 = leastSquaresResidual(A1, y).squaredNorm();
  const double f_expected = ((rss0 - rss1) / 2.0) / (rss1 / (n - (p + 1) - 2));
  const calib::ModelColumns model = calib::ModelColumns::of(w.J, 1);
  // The model's residual, and the same plus any combination of the model's columns, give that test.
  const Eigen::VectorXd r0 = leastSquaresResidual(A0, y);
  for (const Eigen::VectorXd& r : {r0, Eigen::VectorXd(r0 + w.J * Eigen::VectorXd::LinSpaced(p, -1.0, 2.0))}) {
    const std::vector<calib::VariableTest> t = calib::variableTests(r, {variable("cos(u) v, u^2", X)}, &model);
    REQUIRE(t.size() == 1);
    CHECK(t[0].dof == 2);
    CHECK(t[0].statistic == Approx(f_expected).epsilon(1e-8));
    CHECK(t[0].p_value == Approx(calib::fSurvival(f_expected, 2, n - (p + 1) - 2)).epsilon(1e-6));
  }
}

TEST_CASE("added-variable test: held-out residuals of a model that holds are not structure; a missing term is found",
          "[calib][lack_of_fit]") {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> n01;
  const int n = 150, p = 40, reps = 400;
  const World w = world(rng, n, p);
  // A variable the model's columns nearly take (what a fold's estimation error looks like) and one of
  // another shape.
  Eigen::MatrixXd X(n, 2);
  X << w.J.col(2) + 0.3 * w.J.col(7), (w.u.array().square() * w.v.array()).matrix();
  const calib::EvidenceVariable var = variable("products", X);
  const calib::ModelColumns model = calib::ModelColumns::of(w.J, 1);
  int rejected_added = 0, rejected_plain = 0;
  for (int r = 0; r < reps; ++r) {
    Eigen::VectorXd y(n);
    for (int i = 0; i < n; ++i) y[i] = n01(rng);
    rejected_added += only(calib::variableTests(leastSquaresResidual(w.J, y), {var}, &model)).p_value < 0.05 ? 1 : 0;
    rejected_plain += only(calib::variableTests(heldOut(w.J, y, 5), {var})).p_value < 0.05 ? 1 : 0;
  }
  const double rate_added = static_cast<double>(rejected_added) / reps, rate_plain = static_cast<double>(rejected_plain) / reps;
  CAPTURE(rate_added, rate_plain);
  // Binomial(400, 0.05): sd 0.011; the exact test stays within 3 sd of its level, the plain one does not.
  CHECK(rate_added < 0.05 + 3 * 0.011);
  CHECK(rate_added > 0.05 - 3 * 0.011);
  CHECK(rate_plain > 0.05 + 3 * 0.011);  // what diagnose tested before
  // A term of the second variable's shape, as large as the noise in RMS, is found.
  Eigen::VectorXd y(n);
  const Eigen::VectorXd term = X.col(1) * (1.0 / std::sqrt(X.col(1).squaredNorm() / n));
  for (int i = 0; i < n; ++i) y[i] = term[i] + n01(rng);
  CHECK(only(calib::variableTests(leastSquaresResidual(w.J, y), {var}, &model)).p_value < 1e-4);
}

TEST_CASE("added-variable test: nearly dependent model columns give one statistic whatever the rows' order",
          "[calib][lack_of_fit]") {
  // A flexible model's columns leave directions whose singular values lie a few 1e-6 of the largest
  // (squared: near the rank tolerance of 1e-12). Rounding must not decide a test there: the same rows in
  // another order (other sums, other rounding) give the same statistic. Through J^T J it moved by up to a
  // fifth on the real iiwa7; the model's span from the R factor of [J y] holds it to the fit's precision.
  std::mt19937_64 rng(23);
  std::normal_distribution<double> n01;
  const int n = 900, p = 30;
  World w = world(rng, n, p);
  Eigen::MatrixXd wiggle(n, 6);  // what separates six columns from combinations of the others
  for (Eigen::Index i = 0; i < wiggle.size(); ++i) wiggle(i) = n01(rng);
  for (int k = 0; k < 6; ++k) {
    const double size = (1.0 + k) * 1e-6 * w.J.col(k).norm() / std::sqrt(static_cast<double>(n));
    w.J.col(20 + k) = w.J.col(k) + 0.5 * w.J.col(k + 6) + size * wiggle.col(k);
  }
  Eigen::VectorXd y(n);
  for (int i = 0; i < n; ++i) y[i] = n01(rng) + 0.5 * std::sin(w.u[i] * w.v[i]);
  const Eigen::VectorXd r = leastSquaresResidual(w.J, y);
  // Variables along the nearly dependent directions (1e-2 of their length off the model's span: ten times
  // the test's own testability cut, so that the statistic is the data's, not a cut's), and one of another shape.
  const std::vector<calib::EvidenceVariable> vars = {
      variable("near the span", Eigen::MatrixXd(w.J.middleCols(20, 3) + 1e-2 * wiggle.leftCols(3))),
      variable("sin(u v)", Eigen::MatrixXd((w.u.array() * w.v.array()).sin().matrix()))};
  const calib::ModelColumns model = calib::ModelColumns::of(w.J, 1);
  const std::vector<calib::VariableTest> forward = calib::addedVariableTests(r, vars, model);
  // The rows reversed.
  const Eigen::VectorXd r_rev = r.reverse();
  std::vector<calib::EvidenceVariable> vars_rev = vars;
  for (calib::EvidenceVariable& v : vars_rev) v.X = Eigen::MatrixXd(v.X.colwise().reverse());
  const Eigen::MatrixXd J_rev = w.J.colwise().reverse();
  const std::vector<calib::VariableTest> reversed = calib::addedVariableTests(r_rev, vars_rev, calib::ModelColumns::of(J_rev, 1));
  REQUIRE(forward.size() == 2);
  REQUIRE(reversed.size() == 2);
  for (std::size_t v = 0; v < 2; ++v) {
    CAPTURE(v, forward[v].statistic, reversed[v].statistic);
    CHECK(forward[v].dof == reversed[v].dof);
    CHECK(forward[v].statistic == Approx(reversed[v].statistic).epsilon(1e-6));
  }
  CHECK(forward[1].p_value < 1e-4);  // the missing term is found
}
