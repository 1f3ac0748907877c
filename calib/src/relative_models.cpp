#include "orbcal/calib/relative_models.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::calib {

namespace {

Eigen::VectorXd startOf(const sim::ParamLayout& layout, Eigen::VectorXd p0, const char* what) {
  if (p0.size() == 0) p0 = Eigen::VectorXd::Zero(layout.size());
  if (p0.size() != layout.size()) throw std::invalid_argument(std::string(what) + ": p0 has the wrong size");
  return p0;
}

/// Distance and angle of a pair of poses (the measured or the predicted ones).
Eigen::Vector2d distanceAndAngle(const Eigen::Isometry3d& world_T_a, const Eigen::Isometry3d& world_T_b) {
  return {(world_T_b.translation() - world_T_a.translation()).norm(),
          sim::rotationAngle(world_T_a.linear().transpose() * world_T_b.linear())};
}

}  // namespace

// ---- RelativePoseModel --------------------------------------------------------------------------

std::vector<RelativeObservation> relativePairs(const std::vector<MarkerObservation>& poses, Pairing pairing,
                                               int reference, const MarkerNoise& noise, const RelativeGuard& guard) {
  const int n = static_cast<int>(poses.size());
  if (pairing == Pairing::kReference && (reference < 0 || reference >= n)) {
    throw std::invalid_argument("relativePairs: reference " + std::to_string(reference) + " of " + std::to_string(n) +
                                " poses");
  }
  std::vector<std::pair<int, int>> index;
  for (int j = 0; j < n; ++j) {
    if (pairing == Pairing::kReference && j != reference) index.emplace_back(reference, j);
    if (pairing == Pairing::kConsecutive && j + 1 < n) index.emplace_back(j, j + 1);
  }
  std::vector<RelativeObservation> out;
  for (const auto& [ia, ib] : index) {
    const MarkerObservation& a = poses[static_cast<std::size_t>(ia)];
    const MarkerObservation& b = poses[static_cast<std::size_t>(ib)];
    const Eigen::Vector2d z = distanceAndAngle(a.world_T_marker, b.world_T_marker);
    RelativeObservation o;
    o.a = a.sample;
    o.b = b.sample;
    o.distance_m = z[0];
    o.angle_rad = z[1];
    o.has_distance = z[0] >= guard.min_distance_m;
    o.has_rotation = a.has_rotation && b.has_rotation && z[1] >= guard.min_angle_rad &&
                     z[1] <= sim::kPi - guard.min_angle_rad;
    o.sigma_distance_m = std::sqrt(2.0) * noise.sigma_position_m;
    o.sigma_angle_rad = std::sqrt(2.0) * noise.sigma_rotation_rad;
    if (o.has_distance || o.has_rotation) out.push_back(o);
  }
  return out;
}

RelativePoseModel::RelativePoseModel(sim::KinematicModel model, std::vector<RelativeObservation> observations,
                                     RelativeRows rows, Eigen::VectorXd p0)
    : model_(std::move(model)) {
  p0_ = startOf(model_.layout, std::move(p0), "RelativePoseModel");
  for (RelativeObservation& o : observations) {
    sim::checkJointVector(model_.arm, o.a.q_rad, "RelativePoseModel");
    sim::checkJointVector(model_.arm, o.b.q_rad, "RelativePoseModel");
    o.has_distance = o.has_distance && rows != RelativeRows::kRotation;
    o.has_rotation = o.has_rotation && rows != RelativeRows::kDistance;
    if (o.has_distance || o.has_rotation) observations_.push_back(std::move(o));
  }
}

int RelativePoseModel::rows(int k) const {
  const RelativeObservation& o = observations_[static_cast<std::size_t>(k)];
  return static_cast<int>(o.has_distance) + static_cast<int>(o.has_rotation);
}

RelativeErrors relativeErrors(const RelativePoseModel& model, const Eigen::VectorXd& y) {
  RelativeErrors e;
  const Eigen::VectorXd p = model.p0() + y;
  for (const RelativeObservation& o : model.observations()) {
    const Eigen::Vector2d z = predictRelative(model.model(), p, o.a, o.b);
    if (o.has_distance) {
      const double d = std::abs(o.distance_m - z[0]);
      e.distance_rms_m += d * d;
      e.distance_max_m = std::max(e.distance_max_m, d);
      ++e.distance_pairs;
    }
    if (o.has_rotation) {
      const double d = std::abs(o.angle_rad - z[1]);
      e.angle_rms_rad += d * d;
      e.angle_max_rad = std::max(e.angle_max_rad, d);
      ++e.angle_pairs;
    }
  }
  e.distance_rms_m = e.distance_pairs ? std::sqrt(e.distance_rms_m / e.distance_pairs) : 0.0;
  e.angle_rms_rad = e.angle_pairs ? std::sqrt(e.angle_rms_rad / e.angle_pairs) : 0.0;
  return e;
}

Eigen::Vector2d predictRelative(const sim::KinematicModel& model, const Eigen::VectorXd& p, const sim::JointSample& a,
                                const sim::JointSample& b) {
  return distanceAndAngle(sim::predictMarkerPose(model, p, a), sim::predictMarkerPose(model, p, b));
}

namespace {

/// d L and d phi of a pair (rows over whatever J_a, J_b differentiate), from the Jacobians of the right
/// perturbations [rho; omega] of world_T_a and world_T_b in their own frames (see the header).
struct PairRows {
  Eigen::RowVectorXd distance, rotation;  ///< rotation empty when not asked for
};
PairRows pairRows(const Eigen::Isometry3d& world_T_a, const Eigen::MatrixXd& J_a, const Eigen::Isometry3d& world_T_b,
                  const Eigen::MatrixXd& J_b, bool with_rotation) {
  PairRows r;
  // Both marker translations rotated into the world frame, projected on the direction a -> b.
  const Eigen::Vector3d u = (world_T_b.translation() - world_T_a.translation()).normalized();
  r.distance = u.transpose() * (world_T_b.linear() * J_b.topRows(3) - world_T_a.linear() * J_a.topRows(3));
  if (with_rotation) {
    const Eigen::Matrix3d R_ab = world_T_a.linear().transpose() * world_T_b.linear();
    const Eigen::Vector3d w = sim::logSO3(R_ab);
    const Eigen::Vector3d k_axis = w / w.norm();  // the guard keeps phi away from 0 (and pi)
    r.rotation = k_axis.transpose() * (J_b.bottomRows(3) - R_ab.transpose() * J_a.bottomRows(3));
  }
  return r;
}

}  // namespace

Linearization RelativePoseModel::linearize(int k, const Eigen::VectorXd& y) const {
  const RelativeObservation& o = observations_.at(static_cast<std::size_t>(k));
  const Eigen::VectorXd p = p0_ + y;
  Eigen::MatrixXd J_a, J_b;
  const Eigen::Isometry3d world_T_a = sim::predictMarkerPose(model_, p, o.a, &J_a);
  const Eigen::Isometry3d world_T_b = sim::predictMarkerPose(model_, p, o.b, &J_b);
  const Eigen::Vector2d h = distanceAndAngle(world_T_a, world_T_b);
  const PairRows rows_ab = pairRows(world_T_a, J_a, world_T_b, J_b, o.has_rotation);
  const int m = rows(k);
  Linearization lin;
  lin.innovation.resize(m);
  lin.H.resize(m, model_.layout.size());
  lin.R = Eigen::MatrixXd::Zero(m, m);
  int row = 0;
  if (o.has_distance) {
    lin.H.row(row) = rows_ab.distance;
    lin.innovation[row] = o.distance_m - h[0];
    lin.R(row, row) = o.sigma_distance_m * o.sigma_distance_m;
    ++row;
  }
  if (o.has_rotation) {
    lin.H.row(row) = rows_ab.rotation;
    lin.innovation[row] = o.angle_rad - h[1];
    lin.R(row, row) = o.sigma_angle_rad * o.sigma_angle_rad;
  }
  return lin;
}

void addRelativeJointNoise(const sim::KinematicModel& model, const Eigen::VectorXd& p, double joint_sigma_rad,
                           std::vector<RelativeObservation>& pairs) {
  const Eigen::Index n = model.arm.numJoints();
  for (RelativeObservation& o : pairs) {
    Eigen::MatrixXd Jq_a, Jq_b;
    const Eigen::Isometry3d world_T_a = sim::predictMarkerPose(model, p, o.a, nullptr, &Jq_a);
    const Eigen::Isometry3d world_T_b = sim::predictMarkerPose(model, p, o.b, nullptr, &Jq_b);
    // The two configurations' joint noises are independent: columns [joints of a, joints of b].
    Eigen::MatrixXd J_a = Eigen::MatrixXd::Zero(6, 2 * n), J_b = Eigen::MatrixXd::Zero(6, 2 * n);
    J_a.leftCols(n) = Jq_a;
    J_b.rightCols(n) = Jq_b;
    const PairRows r = pairRows(world_T_a, J_a, world_T_b, J_b, o.has_rotation);
    const double s2 = joint_sigma_rad * joint_sigma_rad;
    o.sigma_distance_m = std::sqrt(o.sigma_distance_m * o.sigma_distance_m + s2 * r.distance.squaredNorm());
    if (o.has_rotation) o.sigma_angle_rad = std::sqrt(o.sigma_angle_rad * o.sigma_angle_rad + s2 * r.rotation.squaredNorm());
  }
}

// ---- PlaneRangeModel ----------------------------------------------------------------------------

RangeObservation averagedRange(const sim::JointSample& sample, const std::vector<double>& readings, double sigma_m) {
  if (readings.empty()) throw std::invalid_argument("averagedRange: no readings");
  RangeObservation o;
  o.sample = sample;
  o.repeats = static_cast<int>(readings.size());
  o.sigma_m = sigma_m;
  for (double r : readings) o.range_m += r;
  o.range_m /= static_cast<double>(readings.size());
  return o;
}

PlaneRangeModel::PlaneRangeModel(sim::KinematicModel model, LaserBeam beam, Plane plane,
                                 std::vector<RangeObservation> observations, Eigen::VectorXd p0)
    : model_(std::move(model)), beam_(beam), plane_(std::move(plane)), observations_(std::move(observations)) {
  if (std::abs(beam_.direction.norm() - 1.0) > 1e-9) throw std::invalid_argument("PlaneRangeModel: beam direction is not unit");
  if (plane_.identified.size() >= 4) throw std::invalid_argument("PlaneRangeModel: at most 3 plane coefficients can be identified");
  layout_ = model_.layout;
  plane_offset_ = layout_.size();
  if (!plane_.identified.empty()) {
    static const char* kNames[] = {"plane_nx", "plane_ny", "plane_nz", "plane_f"};
    sim::ParamBlock block;
    block.effect = "plane";
    block.kind = sim::BlockKind::kOther;
    for (int c : plane_.identified) {
      if (c < 0 || c > 3) throw std::invalid_argument("PlaneRangeModel: plane coefficient index out of 0..3");
      block.params.push_back(c < 3 ? sim::ParamInfo{kNames[c], "1", "1", 1.0, plane_.typical_n, sim::Quantity::kOther}
                                   : sim::ParamInfo{kNames[c], "m", "mm", 1e3, plane_.typical_f_m, sim::Quantity::kLength});
    }
    layout_.add(block);
  }
  p0_ = startOf(layout_, std::move(p0), "PlaneRangeModel");
  for (const RangeObservation& o : observations_) {
    sim::checkJointVector(model_.arm, o.sample.q_rad, "PlaneRangeModel");
    if (o.repeats < 1) throw std::invalid_argument("PlaneRangeModel: an observation with no readings");
  }
}

Eigen::Vector4d PlaneRangeModel::planeAt(const Eigen::VectorXd& p) const {
  Eigen::Vector4d w(plane_.n.x(), plane_.n.y(), plane_.n.z(), plane_.f);
  for (std::size_t i = 0; i < plane_.identified.size(); ++i) w[plane_.identified[i]] += p[plane_offset_ + static_cast<Eigen::Index>(i)];
  return w;
}

double PlaneRangeModel::rangeAndRow(const Eigen::VectorXd& p, const sim::JointSample& s, Eigen::RowVectorXd* H) const {
  Eigen::MatrixXd J_e_p;
  const Eigen::Isometry3d world_T_marker =
      sim::predictMarkerPose(model_, p.head(plane_offset_), s, H ? &J_e_p : nullptr);
  const Eigen::Vector4d w = planeAt(p);
  const Eigen::Vector3d n = w.head<3>();
  const Eigen::Vector3d p_s = world_T_marker * beam_.origin;
  const Eigen::Vector3d b = world_T_marker.linear() * beam_.direction;
  const double nb = n.dot(b);
  const double h = -(n.dot(p_s) + w[3]) / nb;
  if (H) {
    H->resize(layout_.size());
    Eigen::Matrix<double, 3, 6> lever;
    lever << Eigen::Matrix3d::Identity(), -sim::skew(beam_.origin + h * beam_.direction);
    H->head(plane_offset_) = -(n.transpose() * world_T_marker.linear() * lever * J_e_p) / nb;
    const Eigen::Vector3d p_j = p_s + h * b;
    for (std::size_t i = 0; i < plane_.identified.size(); ++i) {
      const int c = plane_.identified[i];
      (*H)[plane_offset_ + static_cast<Eigen::Index>(i)] = -(c < 3 ? p_j[c] : 1.0) / nb;
    }
  }
  return h;
}

double PlaneRangeModel::predictRange(const Eigen::VectorXd& p, const sim::JointSample& s) const {
  return rangeAndRow(p, s, nullptr);
}

Linearization PlaneRangeModel::linearize(int k, const Eigen::VectorXd& y) const {
  const RangeObservation& o = observations_.at(static_cast<std::size_t>(k));
  Eigen::RowVectorXd row;
  const double h = rangeAndRow(p0_ + y, o.sample, &row);
  Linearization lin;
  lin.innovation = Eigen::VectorXd::Constant(1, o.range_m - h);
  lin.H = row;
  lin.R = Eigen::MatrixXd::Constant(1, 1, o.sigma_m * o.sigma_m / static_cast<double>(o.repeats));
  return lin;
}

std::vector<sim::JointSample> rangeConfigurations(const PlaneRangeModel& model, const Eigen::VectorXd& p_in, int count,
                                                  std::mt19937_64& rng, const RangeConfigurationSettings& settings) {
  const Eigen::VectorXd p = p_in.size() == 0 ? Eigen::VectorXd::Zero(model.numParams()) : p_in;
  if (p.size() != model.numParams()) throw std::invalid_argument("rangeConfigurations: p has the wrong size");
  const sim::Arm& arm = model.model().arm;
  const int kinematic = model.model().layout.size();
  const Eigen::Vector3d unit_normal = model.planeAt(p).head<3>().normalized();
  const int budget = settings.max_attempts > 0 ? settings.max_attempts : 2000 * std::max(1, count);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::vector<sim::JointSample> out;
  for (int attempt = 0; static_cast<int>(out.size()) < count; ++attempt) {
    if (attempt >= budget) {
      throw std::runtime_error("rangeConfigurations: only " + std::to_string(out.size()) + " of " + std::to_string(count) +
                               " configurations found in " + std::to_string(budget) + " attempts");
    }
    sim::JointSample s;
    s.q_rad.resize(arm.numJoints());
    for (int j = 0; j < arm.numJoints(); ++j) s.q_rad[j] = arm.lower_rad[j] + u01(rng) * (arm.upper_rad[j] - arm.lower_rad[j]);
    if (settings.min_singular_value > 0.0 && sim::singularityMeasure(arm, s.q_rad, -1) < settings.min_singular_value) continue;
    if (settings.beam_must_hit) {
      const Eigen::Isometry3d T = sim::predictMarkerPose(model.model(), p.head(kinematic), s);
      const double cosine = unit_normal.dot(T.linear() * model.beam().direction);
      const double h = model.predictRange(p, s);
      if (std::abs(cosine) < settings.min_cosine || h < settings.min_range_m || h > settings.max_range_m) continue;
    }
    out.push_back(std::move(s));
  }
  return out;
}

std::vector<RangeObservation> simulateRanges(const PlaneRangeModel& model, const Eigen::VectorXd& p_true,
                                             const std::vector<sim::JointSample>& samples, double sigma_m, int repeats,
                                             std::mt19937_64& rng, bool noisy) {
  if (!(sigma_m > 0.0)) throw std::invalid_argument("simulateRanges: sigma_m must be > 0");
  if (repeats < 1) throw std::invalid_argument("simulateRanges: repeats must be >= 1");
  std::normal_distribution<double> n01(0.0, 1.0);
  std::vector<RangeObservation> out;
  out.reserve(samples.size());
  for (const sim::JointSample& s : samples) {
    const double h = model.predictRange(p_true, s);
    std::vector<double> readings(static_cast<std::size_t>(repeats), h);
    if (noisy) {
      for (double& r : readings) r += sigma_m * n01(rng);
    }
    out.push_back(averagedRange(s, readings, sigma_m));
  }
  return out;
}

}  // namespace orbcal::calib
