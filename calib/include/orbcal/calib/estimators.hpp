#pragma once
// The estimators of the parameter errors y, all over a MeasurementModel (model.hpp):
//  - the EKF of Wang et al. 2023 eqs. (11)-(17), paper-literal (linear: J at the nominal parameters,
//    innovation Z_k - J_k y_hat) or re-linearized at the current estimate (extended), optionally
//    iterated within each update (IEKF);
//  - LSE, Wang et al. 2023's baseline: Gauss-Newton with a truncated-SVD pseudo-inverse, unweighted (as in the
//    paper: residuals in m and rad added as they are) or weighted by R^-1;
//  - Levenberg-Marquardt through Ceres with the analytic Jacobian and an optional robust loss.
// Each returns the estimate, its covariance, iterations, the rank used and the wall time.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "orbcal/calib/model.hpp"

namespace orbcal::calib {

struct Estimate {
  std::string method;
  Eigen::VectorXd y;           ///< estimated parameter errors (SI, the model's order)
  Eigen::MatrixXd covariance;  ///< of y (pseudo-inverse on the identifiable part for LSE and LM)
  int iterations = 0;          ///< Gauss-Newton/LM iterations; EKF: updates
  int rank = 0;                ///< rank used (LSE/LM: of the stacked Jacobian; EKF: of the information gained)
  double seconds = 0.0;        ///< wall time of the estimation
  bool converged = false;
  std::vector<int> held;       ///< parameters held at zero: the options' hold, and (LSE, LM) the unidentifiable ones
  double cost = 0.0;           ///< 0.5 sum nu^T R^-1 nu at the estimate (all methods, for comparison)
  /// With a prior whose strength was estimated (FitControls::scaled_prior): its scale tau (the prior
  /// sigma over the given typical sizes) and the estimate's effective number of parameters
  /// (shrinkage()); LM on the normal equations (LmOptions::normal_equations) sets the effective number
  /// from its own final normal matrix whatever the prior; 0 otherwise.
  double prior_scale = 0.0;
  double effective_parameters = 0.0;
};

struct EkfOptions {
  /// P0 = diag(sigma^2): angles (the layout's Quantity::kAngle) get prior_sigma_angle_rad, lengths
  /// prior_sigma_length_m, every other parameter its typical magnitude (sim::ParamInfo::typical).
  double prior_sigma_angle_rad = 1.0 * sim::kDegToRad;
  double prior_sigma_length_m = 5e-3;
  /// Q = diag(sigma^2) added at every step (eq. 12); 0 as in the paper.
  double process_sigma_angle_rad = 0.0;
  double process_sigma_length_m = 0.0;
  bool relinearize = true;       ///< true: extended KF (J and innovation at the estimate); false: paper-literal
  int iterations_per_update = 1; ///< > 1: iterated EKF (re-linearizes within each update)
  /// Parameters held at zero whatever the data says: their prior and process variances are zero, so
  /// no gain ever reaches them (Estimate::held lists them, sorted).
  std::vector<int> hold;
  /// A Gaussian prior y_i ~ N(prior_mean_i, prior_sigma_i^2) where prior_sigma_i > 0 (empty: none):
  /// it replaces those parameters' P0 and starts the state at its mean, as LmOptions' and LseOptions'
  /// prior enters theirs.
  Eigen::VectorXd prior_sigma, prior_mean;
  /// Wang et al. 2023 as written: P0 sigma 0.01 deg / 0.01 mm, Q = 0, J at the nominal parameters.
  static EkfOptions paperLiteral();
};

struct LseOptions {
  bool weighted = false;        ///< false: the paper's unweighted LSE
  int max_iterations = 50;
  double step_tolerance = 1e-12;  ///< stop when |dy| (scaled: rad and m) falls below this
  // Each step's truncation and the held set: sim::numericalRank's decision at sim::kRankTolerance.
  /// Hold the parameters that are unidentifiable at the nominal model (see LmOptions). Off, the
  /// truncation alone decides, and the rank found can change between iterations: with Table 3's
  /// alpha errors the d3/d4/d5 axes are slightly non-parallel at the estimate, so a weak direction
  /// appears and Gauss-Newton oscillates along it.
  bool fix_unidentifiable = true;
  std::vector<int> hold;        ///< parameters held at zero whatever the data says
  /// A Gaussian prior as LmOptions' (empty: none): pseudo-observations y_i = prior_mean_i with variance
  /// prior_sigma_i^2, one whitened row each beside the measurements' (weighted or not).
  Eigen::VectorXd prior_sigma, prior_mean;
};

struct LmOptions {
  enum class Loss { kNone, kHuber, kCauchy };
  Loss loss = Loss::kNone;
  double loss_scale = 3.0;      ///< in whitened units (sigmas)
  int max_iterations = 100;
  /// Stop when an iteration changes the cost by less than this share of it. 1e-10 of a whitened
  /// cost of n samples (about 3n at the noise) is a change of 1e-10 * 3n in chi-square units: far below
  /// what any test or cross-validated gain resolves (their decisions turn on changes of order 1),
  /// while the last digits of a tighter tolerance cost iterations of round-off-sized steps.
  double function_tolerance = 1e-10;
  /// Hold one parameter of each unidentifiable group at zero (the group's observable combination is
  /// then carried by the others), found from the SVD at the start; otherwise LM's damping alone
  /// picks a point on the unidentifiable manifold.
  bool fix_unidentifiable = true;
  std::vector<int> hold;        ///< parameters held at zero whatever the data says
  /// The covariance of the estimate (an SVD of the whitened Jacobian at the solution); without it
  /// Estimate::covariance stays empty and Estimate::rank is that of the start's.
  bool covariance = true;
  /// Solve each step from the normal equations (Cholesky of J^T J) instead of a QR of the tall J:
  /// several times cheaper; the condition number is squared, which the Jacobi scaling of the columns
  /// and the held unidentifiable parameters keep well below round-off for the marker fits. With the
  /// squared loss, J^T J and J^T f are summed a block of samples at a time (calib/src/streamed_lm.hpp,
  /// Ceres's Levenberg-Marquardt strategy), never the stacked J: a 10^5-sample log's is gigabytes.
  /// That LM also shortens a step that overshoots the cost's minimum along it (where the cost curves
  /// more than J^T J says), and stops once the Gauss-Newton model's whole remaining decrease is below
  /// decrease_tolerance in the noise's units, where Ceres would go on with steps the noise cannot see.
  bool normal_equations = false;
  /// With normal_equations: StreamedLmOptions::decrease_tolerance (1e-6: within about 0.0014 standard
  /// deviations of the minimum).
  double decrease_tolerance = 1e-6;
  /// A Gaussian prior y_i ~ N(prior_mean_i, prior_sigma_i^2) on the parameters whose prior_sigma_i is
  /// positive (empty: none, the least-squares estimate): the maximum a-posteriori estimate, with the
  /// prior's residuals (y_i - prior_mean_i) / prior_sigma_i beside the whitened measurements.
  /// Estimate::cost stays the measurements' cost alone.
  Eigen::VectorXd prior_sigma;
  Eigen::VectorXd prior_mean;  ///< empty: zero
  /// The iterations start at y = start (empty: 0); the whiteners, the held parameters and the prior
  /// stay those of y = 0 (a warm start of the same problem: the same minimum, fewer iterations).
  Eigen::VectorXd start;
};

Estimate runEkf(const MeasurementModel& model, const EkfOptions& options);
Estimate runLse(const MeasurementModel& model, const LseOptions& options);
Estimate runLm(const MeasurementModel& model, const LmOptions& options);

/// The stacked Jacobian H over all samples at y, each sample's rows whitened by its R_k^-1/2
/// (dimensionless rows, the input of identifiability analyses).
Eigen::MatrixXd whitenedJacobian(const MeasurementModel& model, const Eigen::VectorXd& y);
/// The same with the whitened stacked innovation b = W nu(y).
void whitenedSystem(const MeasurementModel& model, const Eigen::VectorXd& y, Eigen::MatrixXd& A, Eigen::VectorXd& b);

/// 0.5 sum_k nu_k(y)^T R_k^-1 nu_k(y); `innovations` (if given) gets every nu_k(y), from the same
/// predictions.
double weightedCost(const MeasurementModel& model, const Eigen::VectorXd& y, std::vector<Eigen::VectorXd>* innovations = nullptr);

/// How much an estimate at y uses its free parameters (all but `held`): with A = H^T R^-1 H of the free
/// parameters (the whitened Jacobian's normal matrix) and P = diag(1/prior_sigma^2) (0 where a
/// parameter has no prior; `prior_sigma` empty: none), the effective number of parameters is
/// tr((A + P)^-1 A), the trace of the hat matrix, the sum of the eigen-shrinkage factors (Hastie,
/// Tibshirani and Friedman 2009, sec. 3.4.1): the free count without a prior, less with one. `gamma` is
/// the same sum over the parameters in `subset` (MacKay 1992's number of well-determined parameters
/// among those a prior's strength is estimated for), `posterior_diagonal` the diagonal of (A + P)^-1.
struct Shrinkage {
  double effective = 0.0;
  double gamma = 0.0;
  Eigen::VectorXd posterior_diagonal;
};
Shrinkage shrinkage(const MeasurementModel& model, const Eigen::VectorXd& y, const std::vector<int>& held,
                    const Eigen::VectorXd& prior_sigma, const std::vector<int>& subset = {});

/// Parameters to hold so that the rest are identifiable: sim::numericalRank of the whitened Jacobian
/// at y with the layout's typical magnitudes, the `held` parameters left out (they are in the result,
/// sorted).
std::vector<int> unidentifiableToFix(const MeasurementModel& model, const Eigen::VectorXd& y, const std::vector<int>& held = {});
/// The same from a linearization of `model` already at hand (linearizeAll), saving its Jacobians.
std::vector<int> unidentifiableToFix(const MeasurementModel& model, const StackedLinearization& at,
                                     const std::vector<int>& held = {});

}  // namespace orbcal::calib
