#pragma once
// REML variance components of a marker fit's residuals (calib/src/reml.cpp): the position, rotation and
// joint-reading noise, with the fitted parameters and their prior accounted for.
#include <Eigen/Core>
#include <array>
#include <vector>

#include "orbcal/calib/marker_model.hpp"
#include "orbcal/calib/measured_fit.hpp"

namespace orbcal::calib {

/// Variance components of the residuals r_k of `m` at y (REML Fisher scoring; Koch, Parameter
/// Estimation and Hypothesis Testing in Linear Models, 1999, ch. 3.6): R_k = sum_c theta_c V_kc with
/// V_k1 = the position rows, V_k2 = the rotation rows, V_k3 = Jq_k Jq_k^T (joint noise through the
/// residual's joint Jacobian). The components `free` are estimated, the others kept at `noise`'s
/// values; each step solves sum tr(P V_c P V_d) theta_d = y^T P V_c P y (remlInformation; the
/// parameters not in `held` are the fitted ones, `prior` their prior's information; P y = W (r - A
/// delta), the residuals r at y refitted to the step's noise by one Gauss-Newton step delta, so that the
/// estimate does not lean on the noise the fit at y was whitened with), until a step moves
/// no free variance by more than 1e-3 of its standard deviation (Aitken's extrapolation of the linearly
/// converging steps on the way: fewer steps to the same point). Variances are kept >= 0 (sigmas of
/// position and rotation >= 1e-9).
MarkerNoise estimateNoiseComponents(const MarkerPoseModel& m, const Eigen::VectorXd& y, const MarkerNoise& noise,
                                    const std::array<bool, 3>& free, const std::vector<int>& held, const Eigen::VectorXd& prior_sigma,
                                    NoiseComponents* components);

}  // namespace orbcal::calib
