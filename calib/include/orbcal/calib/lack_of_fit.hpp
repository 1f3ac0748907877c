#pragma once
// Lack of fit of a diagnosed model (`orbcal diagnose`): do its cross-validated held-out residuals
// exceed what the measurement noise alone gives, and against which variables are they structured?
//
//  1. The noise, in this order: (a) stated (the description's `noise:` or DiagnoseOptions' sigmas, or
//     each observation's own covariance), (b) pure error of repeated measurements of one configuration
//     (same session, same joint readings: the replicate groups the folds keep together), (c) the
//     residuals themselves (then nothing can be tested against it, and the verdict says so).
//  2. What the noise gives on held-out data: the 3-D position mean square trace(R_pos) averaged over
//     the samples (3 sigma^2 for isotropic tracker noise, plus sigma_q^2 |J_pos|_F^2 of the joint
//     noise through the position rows of predictMarkerPose's J_e_q), and, on top of it, the variance of
//     a prediction by parameters estimated from the other folds (K/(K-1) times the all-data leverage).
//  3. The test: (a) chi-square of the held-out position rows whitened by the stated noise, against its
//     expectation under the noise + estimation variance; (b) the classical lack-of-fit F test (e.g.
//     Draper and Smith 1998, ch. 2.1): the held-out residual's group means against the within-group
//     scatter (pure error). The held-out prediction of a group is one number (the group stays in one
//     fold), so the within-group scatter of the held-out residuals is the pure error exactly.
//  4. Evidence: the model's own residuals regressed on each variable of an extended family (harmonics
//     1-2 and 3-6 of every joint angle, products of joint-angle pairs, torques with powers up to 3,
//     workspace position with quadratic terms, time, temperature, ...) beside the model's own columns:
//     added-variable (score) F tests (e.g. Cook and Weisberg 1982), Holm-adjusted.
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "orbcal/calib/heldout.hpp"
#include "orbcal/calib/measured_fit.hpp"

namespace orbcal::calib {

/// One row of the evidence table: residuals against one variable.
struct VariableTest {
  std::string variable;   ///< e.g. "joint 2 angle (harmonics 1, 2)", "joint 4 torque", "temperature"
  double statistic = 0;   ///< F statistic
  int dof = 0;            ///< the F's numerator degrees of freedom: regressors (beside a model's columns, the directions it cannot take)
  double p_value = 1, p_adjusted = 1;  ///< Holm-adjusted over the family
};

/// One variable of the evidence family: its regressors (n x d) and, for figures, one scalar axis that
/// shows it (e.g. the joint angle in deg for its harmonics).
struct EvidenceVariable {
  std::string name;
  Eigen::MatrixXd X;            ///< n x d, one regression per residual component (pooled)
  /// (n m) x d, row i m + c for sample i, component c (scaled as Y): regressors that differ per
  /// component (an angle error carried by the arm's lever arms); used instead of X when not empty.
  Eigen::MatrixXd stacked;
  std::string axis_label;       ///< "joint 2 angle (deg)"
  Eigen::VectorXd axis_values;  ///< display units, one per sample
};

/// The family of variables the held-out residuals are tested against. `extended` adds harmonics 3-6,
/// joint-angle pair products, torque powers and quadratic workspace terms. model, p: where the workspace
/// position is predicted. With `whitened_jq` (per sample, W_k d(residual)/d(q), W_k the residual's
/// whitening), the harmonics 3-6 of a joint are an error of that joint's angle as the whitened residual
/// sees it: W_k J_j sin(h q_j), ... (stacked): an angle error moves the marker along a direction that
/// turns with the other joints, which no function of q_j alone follows; without it, plain harmonics.
std::vector<EvidenceVariable> evidenceVariables(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs,
                                                const sim::KinematicModel& model, const Eigen::VectorXd& p, bool extended,
                                                const std::vector<Eigen::MatrixXd>* whitened_jq = nullptr);

/// Whitened held-out residuals W_k r_k (n x m), W_k = L_k^-1 with R_k = L_k L_k^T as every fit whitens
/// (tracker or own covariance, plus the joint noise through the joint Jacobian, at `fit`): joint noise
/// lies along the joint Jacobian's columns, so only fully whitened residuals are i.i.d. against
/// regressors built from them. `whitened_jq` gets W_k d(residual)/d(q).
Eigen::MatrixXd whitenedResiduals(const Fit& fit, const std::vector<MarkerObservation>& obs, const MarkerNoise& noise,
                                  const std::vector<Eigen::VectorXd>& residual, std::vector<Eigen::MatrixXd>* whitened_jq);

/// A model's whitened columns given a block of rows at a time, so that no (n m) x p matrix is kept:
/// fill(first, count, J) sets J ((count m) x params) to rows first .. first + count - 1, row r m + c
/// for row r's component c, as Y's rows.
struct ModelColumns {
  int rows = 0, components = 0, params = 0;
  std::function<void(int first, int count, Eigen::MatrixXd& J)> fill;
  /// Of a matrix held whole ((rows m) x params).
  static ModelColumns of(const Eigen::MatrixXd& J, int components);
};
/// W_k times `fit`'s Jacobian of its free parameters (all but Estimate::held) at the fit, per sample in
/// its order, or (group_means) averaged over each replicate group in configurationGroups' order.
ModelColumns whitenedModelColumns(const Fit& fit, const std::vector<MarkerObservation>& obs, const MarkerNoise& noise,
                                  bool group_means);

/// F test of each variable's regression of Y (n x m: residual components, each scaled to its noise),
/// pooled over the components (or one regression of the stacked components); Holm-adjusted over the
/// family. Empty with fewer than 10 rows.
/// With `model` (rows as Y's) each test is the added-variable
/// (score) test of the variable beside the tested model's own columns and one intercept per component:
/// only the part of a variable the model cannot take is tested, against the part of Y the model cannot
/// take; for Y the fit's own (in-sample) residuals it is exact under a linear model that holds. Held-out
/// residuals are not tested this way: they carry each fold fit's own estimation error J (p_fold - p), a
/// smooth function of the configuration that differs by fold, which a regression mistakes for
/// structure (it flagged joint-angle products on iiwa7 worlds whose only unmodelled part was noise).
/// Without model columns: plain regressions on centred Y (the candidate search's base family).
std::vector<VariableTest> variableTests(const Eigen::MatrixXd& Y, const std::vector<EvidenceVariable>& vars,
                                        const ModelColumns* model = nullptr);
/// The added-variable tests alone (not Holm-adjusted), the model's columns streamed a block at a time.
std::vector<VariableTest> addedVariableTests(const Eigen::MatrixXd& Y, const std::vector<EvidenceVariable>& vars,
                                             const ModelColumns& model);

/// Residual components (position, then rotation) scaled by the noise sigmas: the Y of variableTests.
Eigen::MatrixXd scaledResiduals(const std::vector<Eigen::VectorXd>& residual, const MarkerNoise& noise);

/// Means over the replicate groups (configurationGroups, in its order) of each row block of `rows_per`
/// rows: n x d -> G x d (rows_per 1), or stacked (n m) x d -> (G m) x d. With replicates the evidence is
/// tested on the groups' means: copies of one configuration share its held-out prediction, so they are
/// not independent rows.
Eigen::MatrixXd groupMeans(const Eigen::MatrixXd& A, const std::vector<MarkerObservation>& obs, int rows_per = 1);

/// Pure error of the position residuals: within-group scatter over replicate groups.
struct PureError {
  int groups = 0;            ///< all groups (singletons included)
  int replicated = 0;        ///< groups with two or more members
  int dof = 0;               ///< 3 sum (n_g - 1)
  double ss = 0.0;           ///< sum |r_i - mean_g r|^2 (m^2)
  double ss_group_means = 0.0;  ///< sum n_g |mean_g r|^2 (m^2): the lack-of-fit sum of squares
};
PureError pureError(const std::vector<MarkerObservation>& obs, const std::vector<Eigen::VectorXd>& residual);

/// What the noise alone gives on the held-out position residuals of a model fitted with `noise`.
struct HeldoutNoise {
  double position_ms_m2 = 0.0;      ///< mean over samples of trace(R_pos): the pure noise (m^2)
  /// Mean over samples of trace(H_pos Cov H_pos^T) times K/(K-1): the variance of a prediction by
  /// parameters estimated from the other K-1 folds (m^2).
  double estimation_ms_m2 = 0.0;
  double whitened_estimation = 0.0;  ///< the same, summed over samples, each whitened by R_pos
  double chi2 = 0.0;                 ///< sum r_pos^T R_pos^-1 r_pos of the held-out residuals
  double residual_ms_m2 = 0.0;       ///< mean over samples of |r_pos|^2 of the held-out residuals (m^2)
  /// The variance of that mean under the noise alone, each sample's r_pos ~ N(0, R_pos + its prediction's
  /// covariance): sum 2 tr(S^2) / N^2 (m^4).
  double residual_ms_var_m4 = 0.0;
};
HeldoutNoise heldoutNoise(const Fit& fit, const std::vector<MarkerObservation>& obs, const MarkerNoise& noise,
                          const std::vector<Eigen::VectorXd>& residual, int folds);
/// heldoutNoise for each of `noises`, in their order: one pass over the samples (each sample's H once).
std::vector<HeldoutNoise> heldoutNoises(const Fit& fit, const std::vector<MarkerObservation>& obs, const std::vector<MarkerNoise>& noises,
                                        const std::vector<Eigen::VectorXd>& residual, int folds);

enum class NoiseSource { kStated, kPureError, kResiduals };
const char* noiseSourceName(NoiseSource s);  ///< "stated", "pure_error", "residuals"

struct LackOfFit {
  NoiseSource source = NoiseSource::kResiduals;
  double noise_position_rms_m = 0.0;  ///< 3-D position RMS the noise alone gives (no estimation variance)
  /// Expected held-out mean square over the pure noise's, from the parameters estimated on other folds.
  double estimation_factor = 1.0;
  double position_rms_m = 0.0;         ///< held-out 3-D position RMS of the model tested
  double excess_rms_m = 0.0;           ///< sqrt(max(0, rms^2 - noise_rms^2))
  double excess_share = 0.0;           ///< (rms^2 - noise_rms^2) / rms^2, at least 0
  bool tested = false;                 ///< (a) or (b): a noise independent of the fit
  double statistic = 0.0, dof1 = 0.0, dof2 = 0.0;  ///< chi-square (dof2 = 0) or F
  double p_value = 1.0;
  double level = 0.01;                 ///< the significance level each route of the verdict uses
  bool significant = false;            ///< the test rejects
  PureError pure;
  std::vector<VariableTest> evidence;     ///< the model's own residuals beside its columns, extended family
  std::vector<VariableTest> unexplained;  ///< the significant ones, most significant first
  std::string axis_label;                 ///< of the most significant unexplained variable, for figures
  Eigen::VectorXd axis_values;
  /// Left in the model: the test rejects or some variable is significant.
  bool left() const { return significant || !unexplained.empty(); }
};

/// Everything above for the model `fit` (fitted on all the data with `noise`) and its held-out
/// residuals. stated: the noise is given (not estimated from these residuals). Each of the verdict's
/// two routes (the global test, the variable family) is taken at alpha / 2 (Bonferroni) when the
/// global test can be run, at alpha otherwise.
LackOfFit lackOfFit(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs, const Fit& fit,
                    const MarkerNoise& noise, const std::vector<Eigen::VectorXd>& residual, bool stated, int folds,
                    double alpha);

/// "joint 3 angle (harmonics 3-6) (p = 1e-12)", "joint 2 torque (p = 3e-05) and time (p = 0.002)".
std::string describeUnexplained(const std::vector<VariableTest>& unexplained, std::size_t at_most = 3);

}  // namespace orbcal::calib
