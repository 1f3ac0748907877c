#include "orbcal/sim/simulate.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/gravity.hpp"
#include "orbcal/sim/marker_points.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::sim {

namespace {

Eigen::Vector3d randomUnit(std::mt19937_64& rng) {
  std::normal_distribution<double> n01(0.0, 1.0);
  Eigen::Vector3d v(n01(rng), n01(rng), n01(rng));
  return v.normalized();
}

/// The effect parameters of p whose sign physics fixes (EffectKind::physicalSign: a compliance, the joint
/// yields to its load) given that sign, their magnitudes kept.
void withPhysicalSigns(const KinematicModel& m, Eigen::VectorXd& p) {
  for (std::size_t k = 0; k < m.effects.size(); ++k) {
    for (const int blk : m.effect_blocks[k]) {
      const ParamBlock& b = m.layout.block(blk);
      for (int i = 0; i < b.size(); ++i) {
        const int sign = m.effects[k].kind().physicalSign(b, i);
        if (sign != 0) p[b.offset + i] = sign * std::abs(p[b.offset + i]);
      }
    }
  }
}

/// Throws InputError naming the setting for a value no real arm or instrument has: a payload outside
/// 0 to 1e6 kg (as a robot file's masses), DH error spreads beyond half a turn or 10 m, a temperature
/// outside an arm's, times that are not positive.
void checkSpec(const SimulationSpec& spec) {
  if (spec.samples < 1) throw InputError("simulate: samples: must be at least 1");
  if (spec.sessions < 1 || spec.sessions > spec.samples) throw InputError("simulate: sessions: must be within 1..samples");
  if (spec.payload_kg.empty()) throw InputError("simulate: payload_kg: give one payload, or one per session");
  for (std::size_t i = 0; i < spec.payload_kg.size(); ++i) {
    if (!(spec.payload_kg[i] >= 0.0 && spec.payload_kg[i] <= 1e6)) {
      throw InputError("simulate: payload_kg: value " + std::to_string(i + 1) + ", " + formatNumber("%.9g", spec.payload_kg[i]) +
                       " kg, is outside 0 kg to 1e6 kg");
    }
  }
  if (!(spec.geometry.angle_sigma_rad >= 0.0 && spec.geometry.angle_sigma_rad <= kPi)) {
    throw InputError("simulate: geometry: an angle error spread of " + formatNumber("%.9g", spec.geometry.angle_sigma_rad * kRadToDeg) +
                     " deg is outside 0 deg to 180 deg");
  }
  if (!(spec.geometry.length_sigma_m >= 0.0 && spec.geometry.length_sigma_m <= 10.0)) {
    throw InputError("simulate: geometry: a length error spread of " + formatNumber("%.9g", spec.geometry.length_sigma_m * 1e3) +
                     " mm is outside 0 mm to 10000 mm");
  }
  const double end_C = spec.temperature_start_C + spec.temperature_rise_C;
  for (const double t : {spec.temperature_start_C, end_C}) {
    if (!(t >= kMinTemperatureC && t <= kMaxTemperatureC)) {
      throw InputError("simulate: temperature: " + formatNumber("%.9g", t) + " degC is outside an arm's, " +
                       formatNumber("%g", kMinTemperatureC) + " degC to " + formatNumber("%g", kMaxTemperatureC) + " degC");
    }
  }
  if (spec.markers < 0 || spec.markers > 100) throw InputError("simulate: markers: must be within 0 to 100");
  if (!(spec.missing_marker_rate >= 0.0 && spec.missing_marker_rate < 1.0)) {
    throw InputError("simulate: missing_marker_rate: must be within [0, 1)");
  }
  if (!(spec.temperature_tau_s > 0.0 && spec.sample_period_s > 0.0)) throw InputError("simulate: temperature_tau_s and sample_period_s must be positive");
}

/// Given effect values: each within its physical bound (sim::physicalBound), named by its place in the
/// list and its parameter.
void checkEffectValues(const KinematicModel& truth, int first_effect, const Eigen::VectorXd& values) {
  for (Eigen::Index i = 0; i < values.size(); ++i) {
    const ParamInfo& info = truth.layout.param(first_effect + static_cast<int>(i));
    const double b = physicalBound(info);
    if (std::abs(values[i]) <= b) continue;
    throw InputError("simulate: effect values: value " + std::to_string(i + 1) + " (" + info.name + "), " +
                     formatNumber("%.9g", values[i]) + " " + info.unit + ", is outside " + physicalRangeText(info));
  }
}

/// The rigid body's points at each sample (`rows`, measured at the true joints `truths`): the true model
/// plus the tracker's position noise, each point missing with spec.missing_marker_rate (a row keeps at
/// least one, drawn).
std::vector<MeasuredPose> measurePoints(const SimulatedData& s, const std::vector<MeasuredPose>& rows,
                                        const std::vector<JointSample>& truths, const SimulationSpec& spec, std::mt19937_64& rng) {
  std::normal_distribution<double> n01(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<MeasuredPose> out;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    std::vector<int> seen;
    for (int k = 0; k < spec.markers; ++k) {
      if (!(u(rng) < spec.missing_marker_rate)) seen.push_back(k);
    }
    if (seen.empty()) seen.push_back(std::uniform_int_distribution<int>(0, spec.markers - 1)(rng));
    for (const int k : seen) {
      MeasuredPose p = rows[i];
      p.point = k;
      p.has_rotation = false;
      p.world_T_marker = Eigen::Isometry3d::Identity();
      Eigen::Vector3d e;
      for (int a = 0; a < 3; ++a) e[a] = n01(rng);
      p.world_T_marker.translation() = predictMarkerPoint(s.truth, s.p_true, truths[i], k) + spec.noise_position_m * e;
      out.push_back(std::move(p));
    }
  }
  return out;
}

}  // namespace

SimulatedData simulateMeasured(const Arm& nominal, const SimulationSpec& spec) {
  checkSpec(spec);
  std::mt19937_64 rng = makeRng(spec.seed, 0x73696d756c617465ULL);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> n01(0.0, 1.0);
  const int S = spec.sessions;

  // The true frames: a tracker metres away, arbitrarily turned; a marker off the flange, twisted.
  const auto trackerFrame = [&] {
    Eigen::Isometry3d W = Eigen::Isometry3d::Identity();
    W.linear() = expSO3(randomUnit(rng) * (0.5 + 2.5 * u(rng)));
    W.translation() = randomUnit(rng) * spec.base_distance_m;
    return W;
  };
  const auto markerFrame = [&] {
    Eigen::Isometry3d M = Eigen::Isometry3d::Identity();
    const double tilt = 5.0 * kDegToRad;
    M.linear() = expSO3(Eigen::Vector3d(tilt * n01(rng), tilt * n01(rng), spec.marker_twist_deg * kDegToRad * (0.75 + 0.5 * u(rng))));
    M.translation() = randomUnit(rng) * spec.marker_offset_m;
    return M;
  };
  std::vector<Eigen::Isometry3d> W(spec.base == FrameSharing::kPerSession ? static_cast<std::size_t>(S) : 1);
  std::vector<Eigen::Isometry3d> M(spec.marker == FrameSharing::kPerSession ? static_cast<std::size_t>(S) : 1);
  for (auto& w : W) w = spec.base == FrameSharing::kKnown ? Eigen::Isometry3d::Identity() : trackerFrame();
  for (auto& m : M) m = spec.marker == FrameSharing::kKnown ? Eigen::Isometry3d::Identity() : markerFrame();

  SimulatedData out;
  const FrameSharing marker = spec.markers > 0 ? FrameSharing::kKnown : spec.marker;  // rigid body: the points carry it
  std::vector<Eigen::Vector3d> points;
  for (int k = 0; k < spec.markers; ++k) points.push_back(randomUnit(rng) * spec.marker_offset_m);
  if (spec.markers > 0) M.assign(1, Eigen::Isometry3d::Identity());
  out.truth = makeKinematicModel(nominal, S, spec.base, marker, W, M, spec.effects, true, points);
  out.p_true = Eigen::VectorXd::Zero(out.truth.layout.size());
  const ParamBlock& g = out.truth.layout.block(out.truth.layout.find(BlockKind::kGeometry));
  out.p_true.segment(g.offset, g.size()) = makeErrorSet(nominal, spec.geometry, "simulate: geometry");
  const int first_effect = g.offset + g.size();
  const int n_effect = out.truth.layout.size() - first_effect;
  if (spec.effect_values.size() > 0) {
    if (spec.effect_values.size() != n_effect) {
      throw InputError("simulate: effect values: expected " + std::to_string(n_effect) + ", got " +
                       std::to_string(spec.effect_values.size()));
    }
    checkEffectValues(out.truth, first_effect, spec.effect_values);
    out.p_true.tail(n_effect) = spec.effect_values;
  } else {
    const Eigen::VectorXd typical = out.truth.layout.typical();
    for (int i = first_effect; i < out.truth.layout.size(); ++i) {
      const double z = n01(rng);
      out.p_true[i] = typical[i] * (z < 0 ? std::min(z, -0.5) : std::max(z, 0.5));
    }
    withPhysicalSigns(out.truth, out.p_true);
  }

  MeasuredData& d = out.data;
  d.arm = nominal;
  d.robot_file = nominal.source;
  d.base = spec.base;
  d.marker = spec.markers > 0 ? FrameSharing::kShared : spec.marker;
  d.points = spec.markers;
  d.world_T_base = W.front();
  d.flange_T_marker = M.front();
  d.noise_position_m = spec.noise_position_m;
  d.noise_rotation_rad = spec.rotation ? std::optional<double>(spec.noise_rotation_rad) : std::nullopt;
  if (spec.joint_noise_rad > 0.0) d.noise_joint_rad = spec.joint_noise_rad;
  const bool torques = !nominal.masses.links.empty();
  d.has_torque = torques;
  d.has_temperature = d.has_time = true;
  for (int s = 0; s < S; ++s) d.files.push_back("session" + std::to_string(s + 1) + ".csv");

  Arm loaded = nominal;
  for (int k = 0; k < spec.samples; ++k) {
    const int session = std::min(S - 1, k * S / spec.samples);
    MeasuredPose mp;
    JointSample& s = mp.sample;
    s.session = session;
    s.q_rad.resize(nominal.numJoints());
    for (int j = 0; j < nominal.numJoints(); ++j) {
      const double mid = 0.5 * (nominal.lower_rad[j] + nominal.upper_rad[j]);
      const double half = 0.5 * (nominal.upper_rad[j] - nominal.lower_rad[j]) * spec.joint_range_fraction;
      s.q_rad[j] = mid + half * (2.0 * u(rng) - 1.0);
      if (std::find(spec.still_joints.begin(), spec.still_joints.end(), j) != spec.still_joints.end()) s.q_rad[j] = 0.0;
    }
    s.time_s = spec.sample_period_s * k;
    s.temperature_C = spec.temperature_start_C + spec.temperature_rise_C * (1.0 - std::exp(-s.time_s / spec.temperature_tau_s));
    if (torques) {
      loaded.masses.payload_kg = spec.payload_kg[std::min<std::size_t>(spec.payload_kg.size() - 1, static_cast<std::size_t>(session))];
      s.tau_Nm = gravityTorques(loaded, loaded.masses, s.q_rad);
    }
    mp.where = d.files[static_cast<std::size_t>(session)] + ": sample " + std::to_string(k);
    d.poses.push_back(std::move(mp));
  }
  fillApproachDirections(d.poses);

  // Measure: the true model at the true joints (readings + control noise), plus tracker noise; the
  // torque sensors' noise is added to the recorded torques after the deflection is computed.
  std::vector<JointSample> truths;  // the true joint angles (and torques) of each sample
  for (MeasuredPose& mp : d.poses) {
    JointSample truth = mp.sample;
    if (torques) truth.tau_Nm = mp.sample.tau_Nm;
    for (Eigen::Index j = 0; j < truth.q_rad.size(); ++j) truth.q_rad[j] += spec.joint_noise_rad * n01(rng);
    const Eigen::Isometry3d T = predictMarkerPose(out.truth, out.p_true, truth);
    Vector6d e;
    for (int i = 0; i < 3; ++i) e[i] = spec.noise_position_m * n01(rng);
    for (int i = 3; i < 6; ++i) e[i] = spec.rotation ? spec.noise_rotation_rad * n01(rng) : 0.0;
    mp.world_T_marker = posePlus(T, e);
    mp.has_rotation = spec.rotation;
    if (!spec.rotation) mp.world_T_marker.linear().setIdentity();
    if (torques) {
      for (Eigen::Index j = 0; j < mp.sample.tau_Nm.size(); ++j) mp.sample.tau_Nm[j] += spec.torque_noise_Nm * n01(rng);
    }
    truths.push_back(truth);
  }
  if (spec.markers > 0) d.poses = measurePoints(out, d.poses, truths, spec, rng);
  return out;
}

}  // namespace orbcal::sim
