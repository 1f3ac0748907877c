// `orbcal experiment --preset jia2019`: Jia et al. 2019 (as reconstructed in docs/methods.md): self-calibration
// of a 7-DOF space arm from the distance and the rotation angle between the end-effector poses of pairs
// of configurations, which do not depend on the board-to-base transform, against the absolute pose,
// which does. Pose-level simulation (no images): the camera's board_T_flange with Gaussian noise.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <map>
#include <sstream>

#include "orbcal/workflow/experiment.hpp"
#include "orbcal/workflow/report_html.hpp"
#include "orbcal/calib/estimators.hpp"
#include "orbcal/calib/marker_model.hpp"
#include "orbcal/calib/parameter_classes.hpp"
#include "orbcal/calib/relative_models.hpp"
#include "orbcal/calib/validation.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/hemisphere.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/model.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::workflow {

namespace {

std::string fmt(const char* f, double v) { return formatNumber(f, v); }

// The preset's settings (stated in the report).
constexpr double kCameraSigmaPositionM = 0.2e-3;                  ///< per axis: the middle of 0.1-0.3 mm
constexpr double kCameraSigmaRotationRad = 0.05 * sim::kDegToRad;  ///< per axis: the middle of 0.01-0.1 deg
constexpr std::size_t kValidation = 500;                                  ///< the paper's validation set
const std::vector<double> kFrameChangeMm{0, 1, 2, 5, 10};
constexpr double kFrameRotationDegPerMm = 0.02;                    ///< 10 mm with 0.2 deg
/// The reference configuration (deg) of a 7-joint arm: the end effector about 7 m out, away from
/// singularity, every hemisphere point reachable with theta_3 locked (tests/calib/test_jia2019.cpp).
const double kReferenceDeg[7] = {0, 30, -60, 100, -40, 90, 0};

enum class Kind { kDistance, kBoth, kAbsoluteGround, kAbsoluteRegistered, kBothSpread };
struct ModelSpec {
  Kind kind;
  std::string name;
};
const std::vector<ModelSpec>& models() {
  static const std::vector<ModelSpec> m{{Kind::kDistance, "distance only"},
                                        {Kind::kBoth, "distance + rotation (D&R)"},
                                        {Kind::kAbsoluteGround, "absolute (ground board-to-base)"},
                                        {Kind::kAbsoluteRegistered, "absolute (board-to-base estimated)"},
                                        {Kind::kBothSpread, "D&R on random configurations (control)"}};
  return m;
}

/// Wang et al. 2023 Table 3's magnitudes with random signs: |theta|, |alpha|, |beta| uniform in [0.2, 0.3] deg,
/// |a|, |d| uniform in [0.5, 1.0] mm. beta only where the nominal alpha is 0 (consecutive axes parallel:
/// the paper keeps beta only there, the paper's case 3). Joint 1 error-free (the paper excludes it).
Eigen::VectorXd jiaErrors(const sim::Arm& arm, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Eigen::VectorXd y = Eigen::VectorXd::Zero(arm.numParams());
  const sim::ParamBlock g = sim::geometryBlock(arm);
  for (int i = 0; i < g.size(); ++i) {
    const int joint = g.params[static_cast<std::size_t>(i)].joint;
    if (joint == 0) continue;
    if (sim::paramKind(arm, i) == sim::kBeta && std::abs(arm.joints[static_cast<std::size_t>(joint)].alpha_rad) > 1e-9) continue;
    const double mag = g.params[static_cast<std::size_t>(i)].quantity == sim::Quantity::kAngle ? (0.2 + 0.1 * u(rng)) * sim::kDegToRad : (0.5 + 0.5 * u(rng)) * 1e-3;
    y[i] = (u(rng) < 0.5 ? -1.0 : 1.0) * mag;
  }
  return y;
}

Eigen::Vector3d randomUnit(std::mt19937_64& rng) {
  std::normal_distribution<double> n01(0.0, 1.0);
  Eigen::Vector3d v(n01(rng), n01(rng), n01(rng));
  return v.normalized();
}

struct Validation {
  double position_mean = 0, position_max = 0, rotation_mean = 0, rotation_max = 0;  // m, rad
  calib::PoseErrors errors;
};
Validation validate(const sim::Arm& model, const calib::PlantSamples& plant) {
  Validation v;
  v.errors = calib::poseErrors(model, plant);
  const calib::ErrorSummary s = calib::summarize(v.errors);
  v.position_mean = s.position_avg_m;
  v.position_max = s.position_max_m;
  for (const Eigen::Vector3d& o : v.errors.orientation_rad) {
    v.rotation_mean += o.norm() / static_cast<double>(v.errors.orientation_rad.size());
    v.rotation_max = std::max(v.rotation_max, o.norm());
  }
  return v;
}

struct Fit {
  Eigen::VectorXd y_geometry;
  calib::Estimate estimate;
  calib::ParameterClasses classes;  // filled when asked
};

/// Identifies one model by weighted Gauss-Newton with the truncated-SVD pseudo-inverse (runLse),
/// joint 1's parameters held, and the unidentifiable ones held as runLse finds them.
Fit identify(const calib::MeasurementModel& model, const sim::Arm& arm, bool classify) {
  const int geometry = model.layout().block(model.layout().find(sim::BlockKind::kGeometry)).offset;
  calib::LseOptions lse;
  lse.weighted = true;
  const sim::ParamBlock g = sim::geometryBlock(arm);
  for (int k = 0; k < g.size(); ++k) {
    if (g.params[static_cast<std::size_t>(k)].joint == 0) lse.hold.push_back(geometry + k);
  }
  Fit f;
  f.estimate = calib::runLse(model, lse);
  f.y_geometry = f.estimate.y.segment(geometry, arm.numParams());
  if (classify) f.classes = calib::classifyParameters(model, Eigen::VectorXd::Zero(model.numParams()));
  return f;
}

struct Stat {
  std::vector<double> v;
  double mean() const { return meanAndStd(v).first; }
  double stddev() const { return meanAndStd(v).second; }
  double max() const { return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end()); }
};

std::string meanStd(const Stat& s, double scale, const char* f = "%.3f") {
  return fmt(f, s.mean() * scale) + " +- " + fmt(f, s.stddev() * scale);
}

/// What every repetition shares: the arm, the paper's configurations and the frames.
struct JiaSetup {
  sim::Arm nominal;
  Eigen::VectorXd q_ref;
  sim::HemisphereSettings hs;
  sim::HemisphereConfigurations hemi;
  std::vector<Eigen::VectorXd> q_ident;  ///< q_ref and the reachable hemisphere points
  Eigen::VectorXd box_lo, box_hi;        ///< the joint box the identification configurations span
  Eigen::Isometry3d base_T_board_ground = Eigen::Isometry3d::Identity();
  sim::KinematicModel flange, registered;
  calib::MarkerNoise camera;
  Eigen::VectorXd p_flange0;
};

JiaSetup jiaSetup(const ExperimentOptions& o) {
  JiaSetup s;
  s.nominal = sim::loadArm(o.robotSource());
  if (s.nominal.numJoints() != 7) {
    throw sim::InputError(o.robot + ": the jia2019 preset needs a 7-joint arm (Jia et al. 2019's), got " +
                          std::to_string(s.nominal.numJoints()));
  }
  s.q_ref = Eigen::VectorXd(7);
  for (int j = 0; j < 7; ++j) s.q_ref[j] = kReferenceDeg[j] * sim::kDegToRad;
  if (!sim::withinLimits(s.nominal, s.q_ref)) throw sim::InputError(o.robot + ": joint limits exclude the jia2019 reference configuration");
  // The paper's configurations: the reference and 51 on the 0.5 m hemisphere, pointing at the board centre.
  s.hemi = sim::hemisphereConfigurations(s.nominal, s.q_ref, s.hs);
  if (s.hemi.q.size() < 10) {
    throw sim::InputError(o.robot + ": only " + std::to_string(s.hemi.q.size()) + " of 51 hemisphere points reachable from the jia2019 reference");
  }
  s.q_ident = {s.q_ref};
  s.q_ident.insert(s.q_ident.end(), s.hemi.q.begin(), s.hemi.q.end());
  // The joint box the identification configurations span: the local validation set is drawn in it.
  s.box_lo = s.box_hi = s.q_ref;
  for (const auto& q : s.q_ident) {
    s.box_lo = s.box_lo.cwiseMin(q);
    s.box_hi = s.box_hi.cwiseMax(q);
  }
  // The board as calibrated on the ground: centred at c, its z axis back towards the reference flange.
  s.base_T_board_ground.linear() = s.hemi.reference_pose.linear() * sim::expSO3(Eigen::Vector3d(sim::kPi, 0, 0));
  s.base_T_board_ground.translation() = s.hemi.target;
  s.flange = sim::flangeModel(s.nominal);
  s.registered = sim::makeKinematicModel(s.nominal, 1, sim::FrameSharing::kShared, sim::FrameSharing::kKnown,
                                         {s.base_T_board_ground.inverse()}, {Eigen::Isometry3d::Identity()}, {});
  s.camera = calib::MarkerNoise{kCameraSigmaPositionM, kCameraSigmaRotationRad, o.joint_noise_sigma_rad};
  s.p_flange0 = Eigen::VectorXd::Zero(s.flange.layout.size());
  return s;
}

/// What the repetitions gather: per (change, model) and per model, over repetitions, and the CSV rows.
struct JiaStats {
  explicit JiaStats(std::size_t n_models)
      : pos_mean(kFrameChangeMm.size(), std::vector<Stat>(n_models)), pos_max(pos_mean), rot_mean(pos_mean), rot_max(pos_mean),
        local_pos(pos_mean), local_rot(pos_mean), ranks(n_models), held(n_models), seconds(n_models), converged(n_models),
        classes(n_models) {
    runs << "repetition,frame_change_mm,frame_change_deg,model,position_mean_mm,position_max_mm,orientation_mean_deg,"
            "orientation_max_deg,local_position_mean_mm,local_orientation_mean_deg,rank,held,iterations,seconds\n";
    pooled << "model,sample,position_mm,x_deg,y_deg,z_deg\n";
    sweep << "method,frame_change_mm,repetition,position_mean_mm,orientation_mean_deg,local_position_mean_mm\n";
  }
  std::vector<std::vector<Stat>> pos_mean, pos_max, rot_mean, rot_max, local_pos, local_rot;  ///< [change][model]
  Stat nominal_pos, nominal_pos_max, nominal_rot, nominal_rot_max, floor_pos, nominal_local_pos, nominal_local_rot;
  std::vector<Stat> ranks, held, seconds, converged;
  std::vector<calib::ParameterClasses> classes;  ///< repetition 0, no change
  std::ostringstream runs, pooled, sweep;        ///< runs.csv, validation_errors.csv, frame_change.csv
  std::string first_errors;                      ///< the injected errors of repetition 0
};

/// One repetition's plant: the identification and control samples with their camera noise, the direction
/// of the frame change, and the validation sets.
struct JiaPlant {
  sim::Arm true_arm;
  calib::PlantSamples ident, spread, valid, valid_local;
  std::vector<sim::Vector6d> camera_noise;
  Eigen::Vector3d shift_dir, turn_axis;
};

/// `count` configurations uniform in the joint box [lo, hi].
std::vector<Eigen::VectorXd> uniformIn(std::size_t count, const Eigen::VectorXd& lo, const Eigen::VectorXd& hi, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::vector<Eigen::VectorXd> qs(count, Eigen::VectorXd(7));
  for (auto& q : qs) {
    for (int j = 0; j < 7; ++j) q[j] = lo[j] + u01(rng) * (hi[j] - lo[j]);
  }
  return qs;
}

/// Repetition r's plant, and the nominal arm's validation errors and the control-noise floor in `stats`.
JiaPlant simulateRepetition(const ExperimentOptions& o, const JiaSetup& s, int r, JiaStats& stats) {
  JiaPlant p;
  const std::uint64_t seed = o.seed + static_cast<std::uint64_t>(r);
  auto rng_errors = sim::makeRng(seed, 0x6a696165ULL);
  const Eigen::VectorXd y_true = jiaErrors(s.nominal, rng_errors);
  if (r == 0) stats.first_errors = sim::formatErrorSet(s.nominal, y_true);
  p.true_arm = calib::calibratedArm(s.nominal, y_true);
  auto rng_ident = sim::makeRng(seed, 0x6a696964ULL);
  p.ident = calib::simulatePlant(p.true_arm, s.q_ident, o.joint_noise_sigma_rad, rng_ident);
  // The camera's noise (right perturbation of board_T_flange) and the direction of the frame change:
  // drawn once per repetition, the same for every size of the change (common random numbers).
  std::normal_distribution<double> n01(0.0, 1.0);
  p.camera_noise.resize(s.q_ident.size());
  for (auto& e : p.camera_noise) {
    for (int i = 0; i < 6; ++i) e[i] = n01(rng_ident) * (i < 3 ? kCameraSigmaPositionM : kCameraSigmaRotationRad);
  }
  p.shift_dir = randomUnit(rng_ident);
  p.turn_axis = randomUnit(rng_ident);
  // The control: as many configurations uniform within the joint limits (a camera on the flange
  // would not see the board from most of them; distances and angles do not need it), same noise.
  auto rng_spread = sim::makeRng(seed, 0x6a696173ULL);
  const std::vector<Eigen::VectorXd> q_spread = uniformIn(s.q_ident.size(), s.nominal.lower_rad, s.nominal.upper_rad, rng_spread);
  p.spread = calib::simulatePlant(p.true_arm, q_spread, o.joint_noise_sigma_rad, rng_spread);
  // Validation: 500 configurations uniform within the joint limits, the true plant at the commanded
  // joints (no control noise: the table shows the model's own error); the floor the 0.01 deg control
  // noise would add is computed on the same configurations.
  auto rng_valid = sim::makeRng(o.seed + kValidationSeedOffset + static_cast<std::uint64_t>(r), 0x6a696176ULL);
  const std::vector<Eigen::VectorXd> q_valid = uniformIn(kValidation, s.nominal.lower_rad, s.nominal.upper_rad, rng_valid);
  p.valid = calib::simulatePlant(p.true_arm, q_valid, 0.0, rng_valid);
  const std::vector<Eigen::VectorXd> q_local = uniformIn(kValidation, s.box_lo, s.box_hi, rng_valid);
  p.valid_local = calib::simulatePlant(p.true_arm, q_local, 0.0, rng_valid);
  const calib::PlantSamples valid_noisy = calib::simulatePlant(p.true_arm, q_valid, o.joint_noise_sigma_rad, rng_valid);
  stats.floor_pos.v.push_back(calib::summarize(calib::poseErrors(p.true_arm, valid_noisy)).position_avg_m);
  const Validation before = validate(s.nominal, p.valid);
  stats.nominal_pos.v.push_back(before.position_mean);
  stats.nominal_pos_max.v.push_back(before.position_max);
  stats.nominal_rot.v.push_back(before.rotation_mean);
  stats.nominal_rot_max.v.push_back(before.rotation_max);
  const Validation before_local = validate(s.nominal, p.valid_local);
  stats.nominal_local_pos.v.push_back(before_local.position_mean);
  stats.nominal_local_rot.v.push_back(before_local.rotation_mean);
  return p;
}

/// What the camera sees with the board moved by `change`: board_T_flange with its noise (in the board
/// frame) and the same mapped to the base by the ground transform.
struct JiaObservations {
  std::vector<calib::MarkerObservation> in_board, in_base, spread_in_board;
  std::vector<calib::RelativeObservation> pairs, spread_pairs;
};

JiaObservations observe(const ExperimentOptions& o, const JiaSetup& s, const JiaPlant& p, const Eigen::Isometry3d& change) {
  JiaObservations ob;
  const Eigen::Isometry3d base_T_board_true = change * s.base_T_board_ground;
  for (std::size_t k = 0; k < s.q_ident.size(); ++k) {
    calib::MarkerObservation m;
    m.sample.q_rad = p.ident.q_commanded[k];
    m.world_T_marker = sim::posePlus(base_T_board_true.inverse() * p.ident.base_T_flange_true[k], p.camera_noise[k]);
    ob.in_board.push_back(m);
    m.world_T_marker = s.base_T_board_ground * m.world_T_marker;  // what the ground transform makes of it
    ob.in_base.push_back(m);
  }
  for (std::size_t k = 0; k < p.spread.q_commanded.size(); ++k) {
    calib::MarkerObservation m;
    m.sample.q_rad = p.spread.q_commanded[k];
    m.world_T_marker = sim::posePlus(base_T_board_true.inverse() * p.spread.base_T_flange_true[k], p.camera_noise[k]);
    ob.spread_in_board.push_back(m);
  }
  ob.pairs = calib::relativePairs(ob.in_board, calib::Pairing::kReference, 0, s.camera);
  ob.spread_pairs = calib::relativePairs(ob.spread_in_board, calib::Pairing::kReference, 0, s.camera);
  calib::addRelativeJointNoise(s.flange, s.p_flange0, o.joint_noise_sigma_rad, ob.pairs);
  calib::addRelativeJointNoise(s.flange, s.p_flange0, o.joint_noise_sigma_rad, ob.spread_pairs);
  return ob;
}

Fit fitModel(Kind kind, const JiaSetup& s, const JiaObservations& ob, bool classify) {
  switch (kind) {
    case Kind::kDistance:
      return identify(calib::RelativePoseModel(s.flange, ob.pairs, calib::RelativeRows::kDistance), s.nominal, classify);
    case Kind::kBoth:
      return identify(calib::RelativePoseModel(s.flange, ob.pairs, calib::RelativeRows::kBoth), s.nominal, classify);
    case Kind::kAbsoluteGround:
      return identify(calib::MarkerPoseModel(s.flange, ob.in_base, s.camera), s.nominal, classify);
    case Kind::kAbsoluteRegistered:
      return identify(calib::MarkerPoseModel(s.registered, ob.in_board, s.camera), s.nominal, classify);
    case Kind::kBothSpread:
      return identify(calib::RelativePoseModel(s.flange, ob.spread_pairs, calib::RelativeRows::kBoth), s.nominal, classify);
  }
  return {};
}

/// Fits every model at frame change c of repetition r and records their validation errors and CSV rows.
void fitAtChange(const ExperimentOptions& o, const JiaSetup& s, const JiaPlant& p, int r, std::size_t c, JiaStats& st) {
  const double shift_m = kFrameChangeMm[c] * 1e-3, turn_rad = kFrameChangeMm[c] * kFrameRotationDegPerMm * sim::kDegToRad;
  // The board-to-base transform at use: the ground one moved by the change (launch loads, thermal).
  Eigen::Isometry3d change = Eigen::Isometry3d::Identity();
  change.linear() = sim::expSO3(turn_rad * p.turn_axis);
  change.translation() = shift_m * p.shift_dir;
  const JiaObservations ob = observe(o, s, p, change);
  for (std::size_t mi = 0; mi < models().size(); ++mi) {
    const ModelSpec& spec = models()[mi];
    const bool classify = r == 0 && c == 0;
    const Fit fit = fitModel(spec.kind, s, ob, classify);
    if (classify) st.classes[mi] = fit.classes;
    const sim::Arm calibrated = calib::calibratedArm(s.nominal, fit.y_geometry);
    const Validation v = validate(calibrated, p.valid), vl = validate(calibrated, p.valid_local);
    st.local_pos[c][mi].v.push_back(vl.position_mean);
    st.local_rot[c][mi].v.push_back(vl.rotation_mean);
    st.pos_mean[c][mi].v.push_back(v.position_mean);
    st.pos_max[c][mi].v.push_back(v.position_max);
    st.rot_mean[c][mi].v.push_back(v.rotation_mean);
    st.rot_max[c][mi].v.push_back(v.rotation_max);
    if (c == 0) {
      st.ranks[mi].v.push_back(fit.estimate.rank);
      st.held[mi].v.push_back(static_cast<double>(fit.estimate.held.size()));
      st.seconds[mi].v.push_back(fit.estimate.seconds);
      st.converged[mi].v.push_back(fit.estimate.converged ? 1.0 : 0.0);
      for (std::size_t k = 0; k < v.errors.position_m.size(); ++k) {
        const Eigen::Vector3d d = v.errors.orientation_rad[k] * sim::kRadToDeg;
        st.pooled << spec.name << "," << k << "," << fmt("%.6f", v.errors.position_m[k] * 1e3) << "," << fmt("%.7f", d.x())
                  << "," << fmt("%.7f", d.y()) << "," << fmt("%.7f", d.z()) << "\n";
      }
    }
    st.runs << r << "," << kFrameChangeMm[c] << "," << fmt("%.4f", turn_rad * sim::kRadToDeg) << "," << spec.name << ","
            << fmt("%.6f", v.position_mean * 1e3) << "," << fmt("%.6f", v.position_max * 1e3) << ","
            << fmt("%.7f", v.rotation_mean * sim::kRadToDeg) << "," << fmt("%.7f", v.rotation_max * sim::kRadToDeg) << ","
            << fmt("%.6f", vl.position_mean * 1e3) << "," << fmt("%.7f", vl.rotation_mean * sim::kRadToDeg) << ","
            << fit.estimate.rank << "," << fit.estimate.held.size() << "," << fit.estimate.iterations << ","
            << fmt("%.4f", fit.estimate.seconds) << "\n";
    st.sweep << spec.name << "," << kFrameChangeMm[c] << "," << r << "," << fmt("%.6f", v.position_mean * 1e3) << ","
             << fmt("%.7f", v.rotation_mean * sim::kRadToDeg) << "," << fmt("%.6f", vl.position_mean * 1e3) << "\n";
  }
}

// ---- Report -------------------------------------------------------------------------------------

std::string setupSection(const ExperimentOptions& o, const JiaSetup& s, const JiaStats& st) {
  std::ostringstream md;
  md << "# Jia et al. 2019: distance, rotation and absolute models of a 7-DOF space arm\n\n"
     << "Jia, Wang, Chen, Sun, *Int. J. Aerospace Eng.* 2019 (as reconstructed in orbcal's docs/methods.md): the hand-eye camera "
        "measures the end-effector pose relative to a board on the spacecraft, and the board-to-base transform "
        "calibrated on the ground changes with launch loads and thermal deformation. The distance L = |p_b - p_a| "
        "and the rotation angle phi = angle(R_a^T R_b) between two configurations' end-effector poses do not "
        "depend on that transform. Pose-level simulation (no images).\n\n"
     << "## Setup\n\n"
     << "- robot: `" << o.robot << "` (" << s.nominal.name << ", " << s.nominal.numParams() << " DH parameters)\n"
     << "- reference configuration q_ref = [";
  for (int j = 0; j < 7; ++j) md << (j ? ", " : "") << kReferenceDeg[j];
  md << "] deg (singularity measure " << fmt("%.4f", sim::singularityMeasure(s.nominal, s.q_ref, s.hs.locked_joint))
     << ", theta_3 locked); the board centre c 0.5 m along its flange z axis\n"
     << "- identification: q_ref and " << s.hemi.q.size() << " of " << s.hs.count
     << " Fibonacci-lattice points on the 0.5 m hemisphere around the reference flange position, opening away "
        "from the board, flange z axis at c, roll the smallest turn from the reference's; damped-Newton IK from "
        "q_ref, theta_3 locked (joint 1 must move: held, theta2 and d2 would move every pose rigidly), least motion, within the limits";
  if (!s.hemi.unreachable.empty()) {
    md << "; unreachable lattice points:";
    for (int i : s.hemi.unreachable) md << " " << i;
  }
  md << "; " << s.hemi.q.size() << " pairs (reference, j)\n"
     << "- injected errors, drawn per repetition (seed + r): Wang et al. 2023 Table 3's magnitudes with random signs, "
        "|theta|, |alpha|, |beta| uniform in [0.2, 0.3] deg, |a|, |d| in [0.5, 1.0] mm; beta only where the "
        "nominal alpha is 0 (parallel consecutive axes, where the paper keeps it); joint 1 error-free and its "
        "parameters held in every model, as the paper excludes joint 1\n"
     << "- encoder noise " << fmt("%.4g", o.joint_noise_sigma_rad * sim::kRadToDeg)
     << " deg (1 sigma, every joint, identification); camera pose noise " << fmt("%.2g", kCameraSigmaPositionM * 1e3)
     << " mm / " << fmt("%.2g", kCameraSigmaRotationRad * sim::kRadToDeg)
     << " deg per axis (right perturbation of board_T_flange); R of every model = camera noise + encoder noise "
        "through the joint Jacobian (pairs: of both configurations)\n"
     << "- control, not the paper's: D&R on " << s.q_ident.size()
     << " configurations uniform within the joint limits, pairs against the first, the same noise (a camera on the "
        "flange would not see the board from most of them; distances and angles do not need it): does the model or "
        "the protocol limit the relative calibration?\n"
     << "- estimator: iterated weighted least squares with the truncated-SVD pseudo-inverse (runLse, weighted), "
        "holding joint 1 and the parameters the data cannot identify\n"
     << "- validation: " << kValidation << " configurations uniform within the joint limits; flange position and "
        "orientation error (angle of R_true R_model^T) in the base frame against the true plant at the commanded "
        "joints (the paper's set: the whole workspace); and, as a second set, 500 configurations uniform in the "
        "joint box the identification configurations span (the hemisphere's neighbourhood; per joint [";
  for (int j = 0; j < 7; ++j) {
    md << (j ? "; " : "") << fmt("%.1f", s.box_lo[j] * sim::kRadToDeg) << ", " << fmt("%.1f", s.box_hi[j] * sim::kRadToDeg);
  }
  md << "] deg); " << o.repetitions << " repetitions, mean +- std over them\n\n"
     << "Injected errors of repetition 0:\n\n```\n" << st.first_errors << "```\n\n";
  return md.str();
}

std::string validationSection(const ExperimentOptions& o, const JiaStats& st) {
  std::ostringstream md;
  md << "## Validation with the board-to-base transform unchanged since the ground calibration\n\n"
     << "Workspace: the paper's 500 random configurations; local: the hemisphere's joint box.\n\n"
     << "| model | rank | held | converged | position mean (mm) | position max (mm) | orientation mean (deg) | orientation max (deg) "
        "| local position mean (mm) | local orientation mean (deg) |\n"
     << "|---|---|---|---|---|---|---|---|---|---|\n"
     << "| nominal (not calibrated) | | | | " << meanStd(st.nominal_pos, 1e3) << " | " << meanStd(st.nominal_pos_max, 1e3) << " | "
     << meanStd(st.nominal_rot, sim::kRadToDeg, "%.4f") << " | " << meanStd(st.nominal_rot_max, sim::kRadToDeg, "%.4f") << " | "
     << meanStd(st.nominal_local_pos, 1e3) << " | "
     << meanStd(st.nominal_local_rot, sim::kRadToDeg, "%.4f") << " |\n";
  for (std::size_t mi = 0; mi < models().size(); ++mi) {
    md << "| " << models()[mi].name << " | " << fmt("%.0f", st.ranks[mi].mean()) << " | " << fmt("%.0f", st.held[mi].mean())
       << " | " << fmt("%.0f", st.converged[mi].mean() * static_cast<double>(o.repetitions)) << "/" << o.repetitions
       << " | " << meanStd(st.pos_mean[0][mi], 1e3) << " | " << meanStd(st.pos_max[0][mi], 1e3) << " | "
       << meanStd(st.rot_mean[0][mi], sim::kRadToDeg, "%.4f") << " | " << meanStd(st.rot_max[0][mi], sim::kRadToDeg, "%.4f") << " | "
       << meanStd(st.local_pos[0][mi], 1e3) << " | " << meanStd(st.local_rot[0][mi], sim::kRadToDeg, "%.4f") << " |\n";
  }
  md << "\n`rank`: of the Jacobian the estimator used, joint 1 held (the classification below includes joint 1); "
        "`held`: parameters held at zero. `converged`: repetitions in which Gauss-Newton met its step tolerance within 50 iterations (the others "
        "stopped there, oscillating along weakly determined directions).\n\nThe 0.01 deg control noise alone would add a floor of " << fmt("%.3f", st.floor_pos.mean() * 1e3)
     << " mm mean position error on these configurations (the true parameters driven by noisy joints).\n\n";
  return md.str();
}

/// The paper's ranking, stated and compared.
std::string rankingParagraph(const JiaStats& st) {
  std::ostringstream md;
  const double dist = st.pos_mean[0][0].mean(), dr = st.pos_mean[0][1].mean(), abs_g = st.pos_mean[0][2].mean(),
               abs_r = st.pos_mean[0][3].mean();
  md << "**Ranking.** Jia et al. 2019 report absolute >= D&R > distance-only (validation position error, their "
        "Table 10, lost in our copy). Measured mean position errors: absolute (ground transform) "
     << fmt("%.3f", abs_g * 1e3) << " mm, D&R " << fmt("%.3f", dr * 1e3) << " mm, distance only " << fmt("%.3f", dist * 1e3)
     << " mm, absolute with the board-to-base frame estimated " << fmt("%.3f", abs_r * 1e3) << " mm: "
     << (abs_g <= dr && dr < dist ? "the paper's ranking holds"
                                  : std::string("the paper's ranking does not hold (") +
                                        (abs_g <= dr ? "" : "D&R beats the absolute model; ") +
                                        (dr < dist ? "" : "distance-only is not worse than D&R; ") + "see above)")
     << (std::min(dist, dr) > st.nominal_pos.mean()
             ? "; but both relative models end worse than the uncalibrated arm (" + fmt("%.3f", st.nominal_pos.mean() * 1e3) +
                   " mm): an error that moves the whole cluster of hemisphere poses rigidly changes no distance and no "
                   "angle, and over 0.5 m of this arm most errors nearly do (ranks below); the encoder noise along the "
                   "weakly determined directions then sends Gauss-Newton far off"
             : std::string())
     << ". The control, D&R on configurations spread over the workspace, reaches " << fmt("%.3f", st.pos_mean[0][4].mean() * 1e3)
     << " mm: the relative model is not the limit, a single 0.5 m hemisphere is"
     << ". Orientation: absolute " << fmt("%.4f", st.rot_mean[0][2].mean() * sim::kRadToDeg) << " deg, D&R "
     << fmt("%.4f", st.rot_mean[0][1].mean() * sim::kRadToDeg) << " deg, distance only "
     << fmt("%.4f", st.rot_mean[0][0].mean() * sim::kRadToDeg)
     << " deg (no relative model sees theta7, alpha7, beta7: the last joint's orientation errors stay).\n\n";
  return md.str();
}

std::string identifiabilitySection(const JiaStats& st) {
  std::ostringstream md;
  md << "## Identifiability on the identification set (repetition 0; calib::classifyParameters)\n\n"
     << "| model | parameters | rank | ineffective (zero columns) |\n|---|---|---|---|\n";
  for (std::size_t mi = 0; mi < models().size(); ++mi) {
    const calib::ParameterClasses& pc = st.classes[mi];
    md << "| " << models()[mi].name << " | " << pc.names.size() << " | " << pc.rank << " | ";
    for (std::size_t i = 0; i < pc.ineffective.size(); ++i) md << (i ? ", " : "") << pc.names[static_cast<std::size_t>(pc.ineffective[i])];
    md << " |\n";
  }
  md << "\nRelative groups (only their observable combinations are determined):\n\n";
  for (std::size_t mi = 0; mi < models().size(); ++mi) {
    md << "- " << models()[mi].name << ":";
    if (st.classes[mi].groups.empty()) md << " none";
    for (const sim::Redundancy& g : st.classes[mi].groups) md << " " << g.describe() << ";";
    md << "\n";
  }
  md << "\nThe hemisphere spans 0.5 m of a ~10 m arm with theta_3 locked, so these ranks are below those over "
        "random configurations (tests/calib/test_jia2019.cpp, 60 random pairs: 22 / 11 / 24 of 35 for distance / "
        "rotation / D&R, as our numerical check of the paper's identifiability statements).\n\n";
  return md.str();
}

/// One table per validation quantity: rows the board-to-base changes, columns the models.
std::string sweepTable(const std::vector<std::vector<Stat>>& stat, double scale, const char* f) {
  std::ostringstream md;
  for (const auto& m : models()) md << " " << m.name << " |";
  md << "\n|---|";
  for (std::size_t mi = 0; mi < models().size(); ++mi) md << "---|";
  md << "\n";
  for (std::size_t c = 0; c < kFrameChangeMm.size(); ++c) {
    md << "| " << kFrameChangeMm[c] << " mm / " << fmt("%.2f", kFrameChangeMm[c] * kFrameRotationDegPerMm) << " deg |";
    for (std::size_t mi = 0; mi < models().size(); ++mi) md << " " << meanStd(stat[c][mi], scale, f) << " |";
    md << "\n";
  }
  return md.str();
}

std::string sweepSection(const ExperimentOptions& o, const std::string& folder, const JiaStats& st) {
  std::ostringstream md;
  md << "## The board-to-base transform changes after the ground calibration\n\n"
     << "The board moved by a translation of the given size and a rotation of " << kFrameRotationDegPerMm
     << " deg per mm about an axis, both in a random direction per repetition (the same errors, configurations "
        "and noise for every size). Mean validation position error (mm), mean +- std over repetitions:\n\n| change |";
  md << sweepTable(st.pos_mean, 1e3, "%.3f");
  md << "\nLocal validation (the hemisphere's joint box), mean position error (mm):\n\n| change |";
  md << sweepTable(st.local_pos, 1e3, "%.3f");
  md << "\nOrientation (workspace, mean validation error, deg):\n\n| change |";
  md << sweepTable(st.rot_mean, sim::kRadToDeg, "%.4f");
  auto sweepFigure = [&](const std::string& column, const std::string& label, const std::string& png) {
    return drawFigure(o, folder,
                      "curve " + shellQuote(folder + "/frame_change.csv") + " --x frame_change_mm 'board-to-base change (mm)' --y " + column +
                          " " + shellQuote(label),
                      png, label + " against the board-to-base change");
  };
  md << "\n"
     << sweepFigure("position_mean_mm", "mean validation position error (mm)", "frame_change_position.png")
     << sweepFigure("orientation_mean_deg", "mean validation orientation error (deg)", "frame_change_orientation.png")
     << sweepFigure("local_position_mean_mm", "mean local validation position error (mm)", "frame_change_position_local.png")
     << drawFigure(o, folder, "boxplot " + shellQuote(folder + "/validation_errors.csv"), "validation_boxplot.png",
                   "validation errors, board-to-base transform unchanged")
     << "\nFiles: `runs.csv` (every repetition, change and model), `frame_change.csv` (the sweep), "
        "`validation_errors.csv` (every validation error at no change, all repetitions).\n\n";
  return md.str();
}

}  // namespace

void runJia2019(const ExperimentOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  const JiaSetup setup = jiaSetup(o);
  sim::OutputFolder output(o.out + "/jia2019", "orbcal experiment");  // written as a whole
  const std::string& folder = output.path();
  JiaStats stats(models().size());
  Progress progress(o.callbacks.progress, "jia2019", o.quiet ? 0 : o.repetitions * static_cast<int>(kFrameChangeMm.size()));
  for (int r = 0; r < o.repetitions; ++r) {
    const JiaPlant plant = simulateRepetition(o, setup, r, stats);
    for (std::size_t c = 0; c < kFrameChangeMm.size(); ++c) {
      fitAtChange(o, setup, plant, r, c, stats);
      progress.update(r * static_cast<int>(kFrameChangeMm.size()) + static_cast<int>(c) + 1);
    }
  }
  progress.finish();
  sim::writeFileAtomic(folder + "/runs.csv", stats.runs.str());
  sim::writeFileAtomic(folder + "/validation_errors.csv", stats.pooled.str());
  sim::writeFileAtomic(folder + "/frame_change.csv", stats.sweep.str());

  std::ostringstream md;
  md << setupSection(o, setup, stats) << validationSection(o, stats) << rankingParagraph(stats) << identifiabilitySection(stats)
     << sweepSection(o, folder, stats);
  double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  md << "Run time " << fmt("%.1f", total) << " s (LSE per fit, mean:";
  for (std::size_t mi = 0; mi < models().size(); ++mi) md << (mi ? "," : "") << " " << models()[mi].name << " " << fmt("%.1f", stats.seconds[mi].mean() * 1e3) << " ms";
  md << ").\n";
  writeReport(folder, md.str());
  output.commit();
  std::cout << md.str();
}

}  // namespace orbcal::workflow
