#include "orbcal/sim/open_world.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>
#include <stdexcept>

#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/gravity.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::sim {

namespace {

// Independent random streams of one seed (makeRng's stream argument).
enum Stream : std::uint64_t { kConfigs = 1, kGeometry = 2, kFrames = 3, kCause = 4, kNoise = 5, kJointNoise = 6 };

/// A rotation uniform over SO(3): a normalised 4-D Gaussian as a quaternion.
Eigen::Matrix3d randomRotation(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Quaterniond qt(n(rng), n(rng), n(rng), n(rng));
  return qt.normalized().toRotationMatrix();
}

Eigen::Vector3d randomDirection(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Vector3d v(n(rng), n(rng), n(rng));
  return v.normalized();
}

/// The far end of the body moved by joint r, from the origin of its frame, in that frame: the next
/// row's translation (at that joint's angle) or the flange's.
Eigen::Vector3d farEnd(const Arm& arm, int r, const Eigen::VectorXd& q) {
  if (r + 1 < arm.numJoints()) {
    const std::size_t next = static_cast<std::size_t>(r + 1);
    return linkTransform(arm.convention, arm.joints[next], q[r + 1]).translation();
  }
  return arm.last_T_flange.translation();
}

/// The mass model of the torques and the bending: the robot's link masses or, where it has none, each
/// link density x its length (at q = 0) at its mid-point; the spec's payload.
MassModel massModel(const OpenWorldSpec& spec) {
  MassModel m = spec.arm.masses;
  if (m.links.empty()) {
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(spec.arm.numJoints());
    for (int r = 0; r < spec.arm.numJoints(); ++r) {
      const Eigen::Vector3d p = farEnd(spec.arm, r, zero);
      m.links.push_back({spec.link_density_kg_per_m * p.norm(), 0.5 * p});
    }
  }
  m.payload_kg = spec.payload_kg;
  m.payload_com_flange_m = spec.payload_com_flange_m;
  return m;
}

/// base_T_flange of `arm` at true angles q, with the cantilever of `bending` (a link_bending cause;
/// nullptr: none) inserted at the far end of its body. The rows composed here, as sim::forwardKinematics
/// does, so that the deflection can go between them.
Eigen::Isometry3d chainWithBending(const Arm& arm, const MassModel& masses, const Eigen::VectorXd& q,
                                   const OpenCause* bending) {
  Eigen::Isometry3d T = arm.base_T_first;
  for (int r = 0; r < arm.numJoints(); ++r) {
    T = T * linkTransform(arm.convention, arm.joints[static_cast<std::size_t>(r)], q[r]);
    if (!bending || r != bending->joint_a) continue;
    double carried = masses.payload_kg;
    for (std::size_t k = static_cast<std::size_t>(r) + 1; k < masses.links.size(); ++k) carried += masses.links[k].mass_kg;
    const Eigen::Vector3d force = T.linear().transpose() * (carried * masses.gravity_base);  // in the body's frame
    T = T * cantileverDeflection(farEnd(arm, r, q), force, bending->a);
  }
  return T * arm.last_T_flange;
}

/// RMS over the readings of |p(with cause) - p(without)|.
double effectRms(const OpenWorldTruth& truth, const std::vector<JointSample>& samples) {
  double sum = 0.0;
  for (const JointSample& s : samples) {
    const Eigen::Vector3d with = openWorldMarkerPose(truth, s.q_rad, s.tau_Nm, true).translation();
    const Eigen::Vector3d without = openWorldMarkerPose(truth, s.q_rad, s.tau_Nm, false).translation();
    sum += (with - without).squaredNorm();
  }
  return std::sqrt(sum / static_cast<double>(samples.size()));
}

/// Joints whose RMS gravity torque over the samples is at least 10% of the largest joint's: the ones a
/// torque-driven cause can show on (a joint about a vertical axis carries none).
std::vector<int> loadedJoints(const std::vector<JointSample>& samples, int n) {
  Eigen::VectorXd sum = Eigen::VectorXd::Zero(n);
  for (const JointSample& s : samples) sum += s.tau_Nm.array().square().matrix();
  const double largest = sum.maxCoeff();
  std::vector<int> loaded;
  for (int j = 0; j < n; ++j) {
    if (largest > 0.0 && sum[j] >= 0.01 * largest) loaded.push_back(j);  // 10% in RMS = 1% in mean square
  }
  return loaded;
}

/// Links long enough to bend: length at q = 0 at least a quarter of the longest, and carrying a load.
std::vector<int> bendableLinks(const Arm& arm, const MassModel& masses) {
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(arm.numJoints());
  double longest = 0.0;
  for (int r = 0; r < arm.numJoints(); ++r) longest = std::max(longest, farEnd(arm, r, zero).norm());
  std::vector<int> links;
  for (int r = 0; r < arm.numJoints(); ++r) {
    double carried = masses.payload_kg;
    for (std::size_t k = static_cast<std::size_t>(r) + 1; k < masses.links.size(); ++k) carried += masses.links[k].mass_kg;
    if (farEnd(arm, r, zero).norm() >= 0.25 * longest && carried > 0.0) links.push_back(r);
  }
  return links;
}

int pickJoint(int given, const std::vector<int>& allowed, int exclude, std::mt19937_64& rng, const char* what) {
  std::vector<int> pool;
  for (int j : allowed) {
    if (j != exclude) pool.push_back(j);
  }
  if (given >= 0) {
    if (std::find(pool.begin(), pool.end(), given) == pool.end()) {
      throw std::invalid_argument(std::string("generateOpenWorld: ") + what + " " + std::to_string(given + 1) +
                                  " cannot carry this cause");
    }
    return given;
  }
  if (pool.empty()) throw std::invalid_argument(std::string("generateOpenWorld: no joint can serve as ") + what);
  std::uniform_int_distribution<std::size_t> pick(0, pool.size() - 1);
  return pool[pick(rng)];
}

/// The cause with seeded joints, signs and phase, and amplitudes of a convenient scale (about 1 mrad
/// at the joint or the link's tip), before the SNR scaling.
OpenCause drawCause(const OpenWorldSpec& spec, const MassModel& masses, const std::vector<JointSample>& samples) {
  std::mt19937_64 rng = makeRng(spec.seed, kCause);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const int n = spec.arm.numJoints();
  std::vector<int> all(static_cast<std::size_t>(n));
  for (int j = 0; j < n; ++j) all[static_cast<std::size_t>(j)] = j;
  const double sign = u(rng) < 0.5 ? -1.0 : 1.0;
  OpenCause c;
  c.kind = spec.cause;
  c.phase_rad = 2.0 * kPi * u(rng);
  const auto tauMax = [&](int j) {
    double m = 0.0;
    for (const JointSample& s : samples) m = std::max(m, std::abs(s.tau_Nm[j]));
    return m;
  };
  switch (spec.cause) {
    case OpenCauseKind::kHarmonic3:
    case OpenCauseKind::kHarmonic4:
      c.harmonic = spec.cause == OpenCauseKind::kHarmonic3 ? 3 : 4;
      c.joint_a = pickJoint(spec.joint_a, all, -1, rng, "joint");
      c.a = sign * 1e-3;
      break;
    case OpenCauseKind::kCoupling:
      c.joint_a = pickJoint(spec.joint_a, all, -1, rng, "joint");
      c.joint_b = pickJoint(spec.joint_b, all, c.joint_a, rng, "coupling source joint");
      c.a = sign * 1e-3;
      break;
    case OpenCauseKind::kStiffening: {
      c.joint_a = pickJoint(spec.joint_a, loadedJoints(samples, n), -1, rng, "loaded joint");
      const double t = tauMax(c.joint_a);
      const double ratio = 1.0 + 2.0 * u(rng);  // c3 t^2 / c1 in [1, 3]: the cubic term carries 50-75%
      c.a = sign * 1e-3 / (t * (1.0 + ratio));  // deflection 1 mrad at the largest torque
      c.b = ratio * c.a / (t * t);
      break;
    }
    case OpenCauseKind::kLinkBending:
      c.joint_a = pickJoint(spec.joint_a, bendableLinks(spec.arm, masses), -1, rng, "link of joint");
      c.a = 1e-6;  // 1/(E I), sign fixed: a link bends towards its load; rescaled below
      break;
    case OpenCauseKind::kTwoCatalog: {
      c.joint_a = pickJoint(spec.joint_a, loadedJoints(samples, n), -1, rng, "loaded joint");
      c.joint_b = pickJoint(spec.joint_b, all, c.joint_a, rng, "cyclic joint");
      c.harmonic = 1;
      c.a = sign * 1e-3 / tauMax(c.joint_a);
      c.b = (u(rng) < 0.5 ? -1.0 : 1.0) * 1e-3 * (0.5 + 1.5 * u(rng));  // the two of comparable size
      break;
    }
  }
  return c;
}

/// Scales the cause's amplitudes (a and b together) until the effect's RMS is the target: fixed-point
/// steps s *= target / rms, exact for a linear effect, a few steps for the mildly nonlinear ones.
void scaleToTarget(OpenWorldTruth& truth, const std::vector<JointSample>& samples) {
  for (int it = 0; it < 100; ++it) {
    truth.effect_rms_m = effectRms(truth, samples);
    if (truth.effect_rms_m <= 0.0) throw std::invalid_argument("generateOpenWorld: the cause has no effect on the positions");
    const double ratio = truth.target_rms_m / truth.effect_rms_m;
    if (std::abs(ratio - 1.0) < 1e-10) return;  // well below any test's tolerance, well above rounding
    truth.cause.a *= ratio;
    truth.cause.b *= ratio;
  }
  throw std::runtime_error("generateOpenWorld: the amplitude scaling did not converge");
}

}  // namespace

const std::vector<OpenCauseKind>& openCauseKinds() {
  static const std::vector<OpenCauseKind> kinds{OpenCauseKind::kHarmonic3,  OpenCauseKind::kHarmonic4,
                                                OpenCauseKind::kCoupling,   OpenCauseKind::kStiffening,
                                                OpenCauseKind::kLinkBending, OpenCauseKind::kTwoCatalog};
  return kinds;
}

const char* openCauseName(OpenCauseKind kind) {
  switch (kind) {
    case OpenCauseKind::kHarmonic3: return "harmonic3";
    case OpenCauseKind::kHarmonic4: return "harmonic4";
    case OpenCauseKind::kCoupling: return "coupling";
    case OpenCauseKind::kStiffening: return "stiffening";
    case OpenCauseKind::kLinkBending: return "link_bending";
    case OpenCauseKind::kTwoCatalog: return "two_catalog";
  }
  return "?";
}

OpenCauseKind parseOpenCause(const std::string& name) {
  std::string names;
  for (OpenCauseKind k : openCauseKinds()) {
    if (name == openCauseName(k)) return k;
    names += (names.empty() ? "" : ", ") + std::string(openCauseName(k));
  }
  throw std::invalid_argument("unknown open-world cause '" + name + "' (expected one of " + names + ")");
}

Eigen::VectorXd causeJointOffsets(const OpenCause& c, const Eigen::VectorXd& q, const Eigen::VectorXd& tau) {
  Eigen::VectorXd dq = Eigen::VectorXd::Zero(q.size());
  switch (c.kind) {
    case OpenCauseKind::kHarmonic3:
    case OpenCauseKind::kHarmonic4:
      dq[c.joint_a] = c.a * std::sin(c.harmonic * q[c.joint_a] + c.phase_rad);
      break;
    case OpenCauseKind::kCoupling:
      dq[c.joint_a] = c.a * q[c.joint_b];
      break;
    case OpenCauseKind::kStiffening: {
      const double t = tau[c.joint_a];
      dq[c.joint_a] = c.a * t + c.b * t * t * t;
      break;
    }
    case OpenCauseKind::kLinkBending:
      break;
    case OpenCauseKind::kTwoCatalog:
      dq[c.joint_a] = c.a * tau[c.joint_a];
      dq[c.joint_b] += c.b * std::sin(q[c.joint_b] + c.phase_rad);
      break;
  }
  return dq;
}

Eigen::Isometry3d cantileverDeflection(const Eigen::Vector3d& far_end_m, const Eigen::Vector3d& force_N, double compliance) {
  const double L = far_end_m.norm();
  Eigen::Isometry3d D = Eigen::Isometry3d::Identity();
  if (L <= 0.0) return D;
  const Eigen::Vector3d along = far_end_m / L;
  const Eigen::Vector3d perp = force_N - force_N.dot(along) * along;  // F_perp
  const Eigen::Vector3d delta = perp * (L * L * L * compliance / 3.0);
  const Eigen::Vector3d tilt = along.cross(perp) * (L * L * compliance / 2.0);  // |tilt| = |F_perp| L^2 / 2EI
  const double angle = tilt.norm();
  const Eigen::Matrix3d R =
      angle > 0.0 ? Eigen::AngleAxisd(angle, tilt / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
  D.linear() = R;
  D.translation() = far_end_m + delta - R * far_end_m;
  return D;
}

Eigen::Isometry3d openWorldMarkerPose(const OpenWorldTruth& truth, const Eigen::VectorXd& q, const Eigen::VectorXd& tau,
                                      bool with_cause, const Eigen::VectorXd& joint_error) {
  checkJointVector(truth.arm, q, "openWorldMarkerPose");
  const Eigen::VectorXd error = joint_error.size() == q.size() ? joint_error : Eigen::VectorXd::Zero(q.size());
  if (!with_cause) return truth.world_T_base * forwardKinematics(truth.arm, q + error) * truth.flange_T_marker;
  const Eigen::VectorXd q_true = q + causeJointOffsets(truth.cause, q, tau) + error;
  const bool bends = truth.cause.kind == OpenCauseKind::kLinkBending;
  return truth.world_T_base * chainWithBending(truth.arm, truth.masses, q_true, bends ? &truth.cause : nullptr) *
         truth.flange_T_marker;
}

namespace {

void checkSpec(const OpenWorldSpec& spec) {
  const int n = spec.arm.numJoints();
  const auto fail = [](const std::string& what) { throw std::invalid_argument("generateOpenWorld: " + what); };
  if (n < 1 || spec.arm.lower_rad.size() != n || spec.arm.upper_rad.size() != n) fail("the arm needs joints with limits");
  if (spec.samples < 1) fail("expected at least 1 sample, got " + std::to_string(spec.samples));
  if (!(spec.snr > 0.0)) fail("expected a positive SNR");
  if (!(spec.noise_position_m > 0.0) || !(spec.noise_rotation_rad >= 0.0)) fail("expected a positive tracker noise");
  if (!(spec.noise_joint_rad >= 0.0)) fail("expected a joint noise of at least 0");
  if (spec.repeats < 1) fail("expected at least 1 measurement per configuration");
  const bool two = spec.cause == OpenCauseKind::kCoupling || spec.cause == OpenCauseKind::kTwoCatalog;
  if (two && n < 2) fail(std::string(openCauseName(spec.cause)) + " needs two joints");
  for (int j : {spec.joint_a, spec.joint_b}) {
    if (j >= n) fail("joint " + std::to_string(j + 1) + " of a " + std::to_string(n) + "-joint arm");
  }
}

/// Readings uniform within the joint limits, with the gravity torques of the mass model.
std::vector<JointSample> drawSamples(const OpenWorldSpec& spec, const MassModel& masses) {
  std::mt19937_64 rng = makeRng(spec.seed, kConfigs);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const int n = spec.arm.numJoints();
  std::vector<JointSample> samples(static_cast<std::size_t>(spec.samples));
  for (JointSample& s : samples) {
    s.q_rad.resize(n);
    for (int j = 0; j < n; ++j) s.q_rad[j] = spec.arm.lower_rad[j] + u(rng) * (spec.arm.upper_rad[j] - spec.arm.lower_rad[j]);
    s.tau_Nm = gravityTorques(spec.arm, masses, s.q_rad);
  }
  return samples;
}

/// The true arm's DH errors, N(0, sigma) per parameter, and the unknown frames.
void drawGeometry(const OpenWorldSpec& spec, OpenWorldTruth& truth) {
  std::mt19937_64 rng = makeRng(spec.seed, kGeometry);
  std::normal_distribution<double> n(0.0, 1.0);
  truth.dh_errors.resize(spec.arm.numParams());
  for (int k = 0; k < spec.arm.numParams(); ++k) {
    truth.dh_errors[k] = n(rng) * (isAngleParam(spec.arm, k) ? spec.dh_angle_sigma_rad : spec.dh_length_sigma_m);
  }
  truth.arm = withErrors(spec.arm, truth.dh_errors);
  std::mt19937_64 frames = makeRng(spec.seed, kFrames);
  truth.world_T_base.linear() = randomRotation(frames);
  truth.world_T_base.translation() = spec.base_distance_m * randomDirection(frames);
  truth.flange_T_marker.linear() = randomRotation(frames);
  truth.flange_T_marker.translation() = spec.marker_offset_m * randomDirection(frames);
}

}  // namespace

OpenWorldDataset generateOpenWorld(const OpenWorldSpec& spec) {
  checkSpec(spec);
  OpenWorldDataset out;
  OpenWorldTruth& truth = out.truth;
  truth.masses = massModel(spec);
  const std::vector<JointSample> samples = drawSamples(spec, truth.masses);
  drawGeometry(spec, truth);
  truth.cause = drawCause(spec, truth.masses, samples);
  truth.snr = spec.snr;
  truth.target_rms_m = spec.snr * std::sqrt(3.0) * spec.noise_position_m;
  scaleToTarget(truth, samples);

  std::mt19937_64 rng = makeRng(spec.seed, kNoise);
  std::normal_distribution<double> n(0.0, 1.0);
  MeasuredData& d = out.data;
  d.robot_file = spec.arm.source;
  d.arm = spec.arm;
  d.files = {"session_1.csv"};
  d.base = d.marker = FrameSharing::kShared;
  d.noise_position_m = spec.noise_position_m;
  d.noise_rotation_rad = spec.noise_rotation_rad;
  // The readings are the encoders'; the causes (and the joint noise) sit between them and the true angles.
  d.noise_joint_rad = spec.noise_joint_rad;
  d.has_torque = true;
  std::mt19937_64 joint_rng = makeRng(spec.seed, kJointNoise);
  for (int r = 0; r < spec.repeats; ++r) {
    for (const JointSample& s : samples) {
      MeasuredPose m;
      m.sample = s;
      Eigen::VectorXd joint_error = Eigen::VectorXd::Zero(s.q_rad.size());
      if (spec.noise_joint_rad > 0.0) {
        for (Eigen::Index j = 0; j < joint_error.size(); ++j) joint_error[j] = n(joint_rng) * spec.noise_joint_rad;
      }
      const Eigen::Isometry3d exact = openWorldMarkerPose(truth, s.q_rad, s.tau_Nm, true, joint_error);
      const Eigen::Vector3d dp(n(rng), n(rng), n(rng));
      const Eigen::Vector3d dr(n(rng), n(rng), n(rng));
      m.world_T_marker.linear() = expSO3(dr * spec.noise_rotation_rad) * exact.linear();
      m.world_T_marker.translation() = exact.translation() + dp * spec.noise_position_m;
      d.poses.push_back(m);
    }
  }
  fillApproachDirections(d.poses);  // as loadMeasuredData does for files without direction columns
  return out;
}

std::string writeOpenWorld(const OpenWorldDataset& dataset, const std::string& folder, const std::string& robot_file) {
  const std::string description = writeMeasuredData(dataset.data, folder, robot_file);
  const OpenWorldTruth& t = dataset.truth;
  const OpenCause& c = t.cause;
  std::ostringstream y;
  y << "# What generateOpenWorld hid in " << description << " (sim/open_world.hpp gives the formulas; SI units).\n"
    << "cause: " << openCauseName(c.kind) << "\n"
    << "joint_a: " << c.joint_a + 1 << "\n";
  if (c.joint_b >= 0) y << "joint_b: " << c.joint_b + 1 << "\n";
  y << "a: " << exactNumber(c.a) << "\nb: " << exactNumber(c.b) << "\nphase_rad: " << exactNumber(c.phase_rad)
    << "\nharmonic: " << c.harmonic << "\nsnr: " << exactNumber(t.snr) << "\ntarget_rms_m: " << exactNumber(t.target_rms_m)
    << "\neffect_rms_m: " << exactNumber(t.effect_rms_m) << "\nworld_T_base: " << transformYaml(t.world_T_base)
    << "\nflange_T_marker: " << transformYaml(t.flange_T_marker) << "\ndh_errors: [";
  for (Eigen::Index k = 0; k < t.dh_errors.size(); ++k) y << (k ? ", " : "") << exactNumber(t.dh_errors[k]);
  y << "]\n";
  writeFileAtomic(folder + "/truth.yaml", y.str());
  return description;
}

}  // namespace orbcal::sim
