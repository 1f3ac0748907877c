#pragma once
// The one check of an analytic Jacobian against central differences that every model's test calls
// (the kinematic model's pose, the measurement models' innovations, the corner model's pixels).
//
// Columns are compared scaled by each parameter's typical magnitude, so that every entry is the change
// of the function that a typical value of the parameter causes. Central differences with a step of
// `relative_step` x typical: truncation ~ relative_step^2 relative (the functions are smooth on the
// scale of a typical value), round-off ~ 1e-16 x |f| / (relative_step x typical). A tolerance of
// `relative` x the column's largest numeric entry plus `absolute` is far above both, and far below what
// a wrong lever arm, sign, frame or missing right Jacobian gives (errors of 1e-3 relative and more: a
// 1 deg rotation vector changes Jr by 0.9%).
#include <catch2/catch.hpp>

#include <Eigen/Core>
#include <algorithm>
#include <functional>
#include <string>

namespace orbcal::test {

struct JacobianTolerance {
  double relative_step = 1e-3;  ///< the difference step, in units of the parameter's typical value
  double relative = 1e-5;       ///< of the column's largest numeric entry
  double absolute = 1e-11;      ///< in the function's units (covers exactly zero columns too)
};

/// Requires every column c of `analytic` (d f / d x at x) to match (f(x + h e_c) - f(x - h e_c)) / 2h,
/// h = tol.relative_step x typical[c], both scaled by typical[c]. `f` gives the function in a chart
/// where differences are meaningful (e.g. poseMinus of a pose against a fixed reference); `name(c)`
/// labels a failing column. Returns the largest scaled numeric entry, which callers require to be
/// well above zero: the check must not be comparing zeros.
inline double requireJacobianMatches(const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& f,
                                     const Eigen::MatrixXd& analytic, const Eigen::VectorXd& x, const Eigen::VectorXd& typical,
                                     const std::function<std::string(int)>& name, const JacobianTolerance& tol = {}) {
  REQUIRE(analytic.cols() == x.size());
  REQUIRE(typical.size() == x.size());
  double largest = 0.0;
  for (Eigen::Index c = 0; c < x.size(); ++c) {
    const double h = tol.relative_step * typical[c];
    Eigen::VectorXd xp = x, xm = x;
    xp[c] += h;
    xm[c] -= h;
    const Eigen::VectorXd num = (f(xp) - f(xm)) / (2.0 * h) * typical[c];
    REQUIRE(num.size() == analytic.rows());
    const Eigen::VectorXd ana = analytic.col(c) * typical[c];
    largest = std::max(largest, num.cwiseAbs().maxCoeff());
    Eigen::Index r = 0;
    const double err = (ana - num).cwiseAbs().maxCoeff(&r);
    CAPTURE(name(static_cast<int>(c)), r, ana[r], num[r]);
    REQUIRE(err <= tol.relative * num.cwiseAbs().maxCoeff() + tol.absolute);
  }
  return largest;
}

}  // namespace orbcal::test
