#pragma once
// Levenberg-Marquardt on the normal equations accumulated a block of samples at a time (runLm's
// LmOptions::normal_equations with the squared loss): J^T J and J^T f of the whitened samples, never
// the stacked Jacobian (Ceres's dense Jacobian of a 10^5-sample log is half a gigabyte).
#include <Eigen/Core>
#include <vector>

#include "orbcal/calib/model.hpp"

namespace orbcal::calib {

/// The samples' sums at the first iterate, where the caller has them already (runLm's R factor of the
/// whitened rows there): 1/2 |f|^2, the whitened rows, J^T J on the free parameters and J^T f (J = d f /
/// d x); the prior's terms not included.
struct StreamedStart {
  double cost = 0.0;
  Eigen::Index rows = 0;
  Eigen::MatrixXd JtJ;
  Eigen::VectorXd g;
};

/// The sums at y = 0 from the R factor R of the whitened rows [A, b] there (A = W H on every parameter,
/// b = W nu; n + 1 columns): A^T A = R11^T R11, A^T b = R11^T r12, |b|^2 = |[r12; r22]|^2; the LM's
/// J = -A on the `free` columns, f = b; `rows` the whitened rows.
StreamedStart streamedStart(const Eigen::MatrixXd& R, const std::vector<int>& free, Eigen::Index rows);

struct StreamedLmOptions {
  int max_iterations = 100;
  double function_tolerance = 1e-10;
  /// Converged where the Gauss-Newton model's whole remaining decrease of the cost is below this, in
  /// units of the noise (a step of one standard deviation along any parameter direction changes the
  /// cost by 1/2): 1e-6 puts the estimate within about 0.0014 standard deviations of the model's minimum.
  double decrease_tolerance = 1e-6;
  Eigen::VectorXd prior_information;  ///< per free parameter, 1/sigma^2 (0: no prior); empty: none
  Eigen::VectorXd prior_mean;         ///< per free parameter (with prior_information)
  Eigen::VectorXd start;              ///< per free parameter, the first iterate (empty: 0)
  const StreamedStart* start_sums = nullptr;  ///< the sums at the first iterate, where known: no pass over the samples for them
};

struct StreamedLmResult {
  Eigen::VectorXd x;  ///< the free parameters
  int iterations = 0;
  bool converged = false;
  /// The parameters the estimate effectively uses: tr((J^T J + S)^-1 J^T J) at x, S the prior's
  /// information (the free count without a prior).
  double effective = 0.0;
};

/// min 1/2 sum_k |W_k nu_k(y)|^2 + 1/2 |prior rows|^2 over the free parameters x (y = x on `free`, 0
/// elsewhere), from x = 0 (or StreamedLmOptions::start), with the trust-region strategy of Ceres's
/// Levenberg-Marquardt (Jacobi-scaled columns, the damping diag(J^T J) / radius, the radius grown or
/// shrunk by the step's relative decrease, convergence when a step changes the cost by less than
/// function_tolerance of it), and two changes for costs whose curvature J^T J misses (a flexible
/// model's directions that only a wide prior holds: there the Gauss-Newton step overshoots, the
/// iterations converge linearly and a step that lands as far beyond the minimum as it started before
/// it changes the cost by nothing, which Ceres's test takes for convergence):
/// - a step whose parabola (the cost at both ends, the slope at the start) puts the minimum along it
///   below 3/4 of it is shortened to that minimum, where this lowers the cost;
/// - converged where the Gauss-Newton model's whole remaining decrease is below decrease_tolerance.
/// The samples are evaluated in two halves side by side, their sums added in a fixed order (the same
/// result whatever the machine's number of cores; J^T J rounds as OpenBLAS's kernels for its processor do).
StreamedLmResult streamedLm(const MeasurementModel& m, const std::vector<Eigen::MatrixXd>& W, const std::vector<int>& free,
                            const StreamedLmOptions& o);

}  // namespace orbcal::calib
