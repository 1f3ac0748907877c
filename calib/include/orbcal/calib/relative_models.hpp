#pragma once
// Measurement models beside the absolute pose, each a MeasurementModel over a
// sim::KinematicModel (geometry + registration + effects), so that every estimator and the
// identifiability analysis work on them unchanged. (Position-only absolute data needs no new model:
// MarkerPoseModel with MarkerObservation::has_rotation = false.)
//
//  - RelativePoseModel (Jia et al. 2019; docs/methods.md): the distance L_ab = |p_b - p_a| between the
//    marker positions of two configurations a and b, and the rotation angle phi_ab = angle(R_a^T R_b)
//    between their orientations. Both are invariant to a rigid motion of the whole chain (the
//    measuring system's frame, a drifting board), so no measurement-frame transform is needed: with
//    an unknown world_T_base its parameters have zero columns (they are ineffective).
//  - PlaneRangeModel (Liu et al. 2012): the range along a laser beam fixed to the marker
//    (flange) frame to a plane in the base frame whose coefficients are identified too.
//
// Both follow model.hpp's convention: nu_k(y) = z_k - h_k(p0 + y), H_k = d h_k / d y, R_k = cov(nu_k);
// y is the change from p0 (zero: the starting model). Lengths in m, angles in rad.
#include <random>
#include <vector>

#include "orbcal/calib/marker_model.hpp"
#include "orbcal/calib/model.hpp"
#include "orbcal/sim/model.hpp"

namespace orbcal::calib {

// ---- Distance and rotation between pairs of configurations --------------------------------------

/// One pair (a, b): the measured distance between the two marker positions and the rotation angle
/// between the two marker orientations.
struct RelativeObservation {
  sim::JointSample a, b;
  double distance_m = 0.0;  ///< |p_b - p_a|, measured
  double angle_rad = 0.0;   ///< angle(R_a^T R_b) in [0, pi], measured
  bool has_distance = true;
  bool has_rotation = true;  ///< false where the angle is too close to 0 or pi (see relativePairs)
  double sigma_distance_m = 0.1e-3;
  double sigma_angle_rad = 0.01 * sim::kDegToRad;
};

/// Which rows each pair contributes.
enum class RelativeRows { kDistance, kRotation, kBoth };

/// How pairs are formed from a sequence of measured poses: each against one reference pose (seed
/// 001's hemisphere around a reference), or each with the next.
enum class Pairing { kReference, kConsecutive };

/// Pairs below these sizes lose a row: the axis of R_a^T R_b (and with it d phi / d y) is undefined
/// at phi = 0, and phi = angle(.) has a kink at pi (|log| folds back), so a rotation row is formed only
/// for min_angle_rad <= phi <= pi - min_angle_rad; the direction u = (p_b - p_a) / L is undefined at
/// L = 0, so a distance row needs L >= min_distance_m. Near the guard the second-order term of phi in
/// a rotation error delta perpendicular to the axis is |delta|^2 / (2 phi): at phi = 1 deg, a 0.1 deg
/// error leaves 0.005 deg (5% of it) to the iterations; larger phi, proportionally less.
struct RelativeGuard {
  double min_angle_rad = 1.0 * sim::kDegToRad;
  double min_distance_m = 1e-3;
};

/// Pairs of the measured poses (world_T_marker of each observation, rotations ignored where
/// has_rotation is false): kReference: (reference, j) for every j != reference; kConsecutive: (j, j + 1).
/// Sigmas from the pose noise: sigma_L = sqrt(2) sigma_position, sigma_phi = sqrt(2) sigma_rotation
/// (each pose's noise projected on u or k; the correlation between pairs sharing a pose, e.g. every
/// pair of kReference, is not modelled). Pairs that keep no row under the guard are left out.
std::vector<RelativeObservation> relativePairs(const std::vector<MarkerObservation>& poses, Pairing pairing,
                                               int reference = 0, const MarkerNoise& noise = {},
                                               const RelativeGuard& guard = {});

/// nu = [L_meas - L(p); phi_meas - phi(p)] (the rows kept). With J_a, J_b the Jacobians of the right
/// perturbations [rho; omega] of world_T_marker in the marker frame at a and b (sim::predictMarkerPose):
///   dL   = u^T (R_b rho_b - R_a rho_a),                       u = (p_b - p_a) / L (world frame)
///   dphi = k^T (omega_b - R_ab^T omega_a) = k^T (omega_b - omega_a),  k the axis of R_ab = R_a^T R_b
/// (R_a^T R_b -> (I - [omega_a]) R_ab (I + [omega_b]) = R_ab Exp(omega_b - R_ab^T omega_a), the angle of
/// R Exp(delta) changes by k^T delta, and R_ab k = k). Rows follow `rows` intersected with each
/// observation's own has_distance / has_rotation; observations left with no row are dropped.
class RelativePoseModel : public MeasurementModel {
 public:
  RelativePoseModel(sim::KinematicModel model, std::vector<RelativeObservation> observations,
                    RelativeRows rows = RelativeRows::kBoth, Eigen::VectorXd p0 = {});
  int numSamples() const override { return static_cast<int>(observations_.size()); }
  int rows(int k) const override;
  const sim::ParamLayout& layout() const override { return model_.layout; }
  Linearization linearize(int k, const Eigen::VectorXd& y) const override;

  const sim::KinematicModel& model() const { return model_; }
  const std::vector<RelativeObservation>& observations() const { return observations_; }
  const Eigen::VectorXd& p0() const { return p0_; }

 private:
  sim::KinematicModel model_;
  std::vector<RelativeObservation> observations_;
  Eigen::VectorXd p0_;
};

/// The errors of a relative model's pairs at y (measured minus predicted), over the pairs that keep
/// each row: how well a model predicts frame-free quantities, e.g. on held-out pairs.
struct RelativeErrors {
  int distance_pairs = 0, angle_pairs = 0;
  double distance_rms_m = 0.0, distance_max_m = 0.0;
  double angle_rms_rad = 0.0, angle_max_rad = 0.0;
};
RelativeErrors relativeErrors(const RelativePoseModel& model, const Eigen::VectorXd& y);
/// Adds the joint noise of both configurations (independent, joint_sigma_rad per joint) to each pair's
/// sigmas, mapped through the rows above with the joint Jacobians J_e_q of sim::predictMarkerPose at p:
/// sigma_L^2 += sigma_q^2 (|dL/dq_a|^2 + |dL/dq_b|^2), the same for phi where the pair has a rotation row.
/// (relativePairs' sigmas hold the pose noise only; an encoder's 0.01 deg on a 10 m arm moves the flange
/// by ~2 mm, far more than a camera's 0.1-0.3 mm, and weighs distance against rotation rows.)
void addRelativeJointNoise(const sim::KinematicModel& model, const Eigen::VectorXd& p, double joint_sigma_rad,
                           std::vector<RelativeObservation>& pairs);

/// [L(p); phi(p)] of a pair at parameters p (both, whatever the observation keeps).
Eigen::Vector2d predictRelative(const sim::KinematicModel& model, const Eigen::VectorXd& p,
                                const sim::JointSample& a, const sim::JointSample& b);

// ---- Laser range to a plane ---------------------------------------------------------------------

/// A plane n . x + f = 0 in the base frame of the KinematicModel (world_T_base's "base"; with known
/// frames, the arm's base) and which of its coefficients [n_x, n_y, n_z, f] are identified. The
/// coefficients need not be normalized (h is invariant to scaling (n, f) together), so one of them must
/// stay fixed. Liu et al. 2012's faithful choice: y + c z + f0 = 0 with c = n_z identified,
/// n = (0, 1, c), f = f0 fixed: Plane::seed004(c, f0).
struct Plane {
  Eigen::Vector3d n = Eigen::Vector3d::UnitZ();  ///< nominal normal (not necessarily unit)
  double f = 0.0;                                ///< nominal offset (m, times |n|)
  std::vector<int> identified;                   ///< indices into [n_x, n_y, n_z, f]; each a parameter
  /// Typical magnitude of an identified coefficient's error: n components (dimensionless; Liu et al. 2012
  /// perturbs c by 0.005) and f (m).
  double typical_n = 5e-3;
  double typical_f_m = 1e-3;
  static Plane seed004(double c = 4.6, double f0 = -0.69) { return {Eigen::Vector3d(0, 1, c), f0, {2}}; }
};

/// A beam fixed to the marker frame: it starts at `origin` and points along `direction` (unit), both
/// in the marker frame (the flange for sim::flangeModel). Liu et al. 2012: origin 0, direction +z.
struct LaserBeam {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();
};

/// One configuration's range: the mean of `repeats` readings (Liu et al. 2012: 10), each with noise sigma;
/// the mean's sigma is sigma / sqrt(repeats).
struct RangeObservation {
  sim::JointSample sample;
  double range_m = 0.0;
  int repeats = 1;
  double sigma_m = 0.2e-3;  ///< of one reading (Liu et al. 2012: 0.2 mm)
};

/// The observation of `readings` of one configuration: their mean, repeats = their count.
RangeObservation averagedRange(const sim::JointSample& sample, const std::vector<double>& readings, double sigma_m);

/// h = -(n . p_s + f) / (n . b): the distance along the beam (origin p_s, direction b, both in the base
/// frame) to the plane. With p_j = p_s + h b the hit point and the right perturbation [rho; omega] of
/// world_T_marker = (R, t) in the marker frame (J_e_p), dp_s + h db = R (rho - [o + h b_m]x omega), so
///   dh / dy_geometry = -n^T R [I, -[o + h b_m]x] J_e_p / (n . b)
///   dh / dn_i = -p_j,i / (n . b),   dh / df = -1 / (n . b)       (our closed form).
/// The layout is the kinematic model's plus a last block "plane" of the identified coefficients
/// ("plane_nx", "plane_ny", "plane_nz", "plane_f"). nu = range_m - h, R = sigma^2 / repeats.
class PlaneRangeModel : public MeasurementModel {
 public:
  PlaneRangeModel(sim::KinematicModel model, LaserBeam beam, Plane plane, std::vector<RangeObservation> observations,
                  Eigen::VectorXd p0 = {});
  int numSamples() const override { return static_cast<int>(observations_.size()); }
  int rows(int) const override { return 1; }
  const sim::ParamLayout& layout() const override { return layout_; }
  Linearization linearize(int k, const Eigen::VectorXd& y) const override;

  /// h at full parameters p (kinematic parameters, then the identified plane coefficients' changes).
  double predictRange(const Eigen::VectorXd& p, const sim::JointSample& s) const;
  /// [n; f] at full parameters p.
  Eigen::Vector4d planeAt(const Eigen::VectorXd& p) const;
  const sim::KinematicModel& model() const { return model_; }
  const LaserBeam& beam() const { return beam_; }
  const Plane& plane() const { return plane_; }
  const std::vector<RangeObservation>& observations() const { return observations_; }

 private:
  double rangeAndRow(const Eigen::VectorXd& p, const sim::JointSample& s, Eigen::RowVectorXd* H) const;
  sim::KinematicModel model_;
  LaserBeam beam_;
  Plane plane_;
  std::vector<RangeObservation> observations_;
  Eigen::VectorXd p0_;
  sim::ParamLayout layout_;
  int plane_offset_ = 0;
};

/// Which configurations rangeConfigurations keeps (Liu et al. 2012 chose 101
/// non-singular configurations whose beam meets the plane).
struct RangeConfigurationSettings {
  double min_range_m = 0.2;   ///< h, along the beam from its origin to the plane
  double max_range_m = 3.0;
  double min_cosine = 0.3;    ///< |n^ . b|, n^ the unit normal: no grazing incidence
  /// sim::singularityMeasure(arm, q, -1) (all joints; translational rows over the arm's length) at
  /// least this; 0: no check.
  double min_singular_value = 0.01;
  bool beam_must_hit = true;  ///< false: any non-singular configuration (e.g. validation poses)
  int max_attempts = 0;       ///< 0: 2000 per configuration asked for
};

/// `count` configurations of joints drawn uniformly within the limits (from rng, in order) that the
/// settings accept, the beam and plane evaluated by `model` at full parameters p (empty: p = 0, the
/// nominal model a planner knows). Throws std::runtime_error when the attempts run out.
std::vector<sim::JointSample> rangeConfigurations(const PlaneRangeModel& model, const Eigen::VectorXd& p, int count,
                                                  std::mt19937_64& rng, const RangeConfigurationSettings& settings = {});

/// The observations a laser ranger makes at `samples` of the plant `model` at full parameters p_true
/// (kinematic errors and plane coefficients): each the mean of `repeats` readings h(p_true) + N(0,
/// sigma_m) (Liu et al. 2012: 0.2 mm, 10 readings). noisy = false: exact readings, still weighted as
/// if their noise were sigma_m (sigma_m must be > 0).
std::vector<RangeObservation> simulateRanges(const PlaneRangeModel& model, const Eigen::VectorXd& p_true,
                                             const std::vector<sim::JointSample>& samples, double sigma_m, int repeats,
                                             std::mt19937_64& rng, bool noisy = true);

}  // namespace orbcal::calib
