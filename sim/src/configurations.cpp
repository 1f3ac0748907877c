#include "orbcal/sim/configurations.hpp"

#include "orbcal/sim/cores.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <thread>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/ik.hpp"
#include "orbcal/sim/jacobian.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::sim {

Arm withJointBox(Arm arm, const Eigen::VectorXd& lower_rad, const Eigen::VectorXd& upper_rad, const std::string& what) {
  const int n = arm.numJoints();
  if (lower_rad.size() != n || upper_rad.size() != n) {
    throw InputError(what + ": expected a lower and an upper bound for each of the " + std::to_string(n) + " joints of " + arm.source);
  }
  for (int j = 0; j < n; ++j) {
    const double lo = std::max(arm.lower_rad[j], lower_rad[j]), hi = std::min(arm.upper_rad[j], upper_rad[j]);
    if (!(lo < hi)) {
      const double scale = jointEdgeScale(arm, j);
      const std::string unit = std::string(" ") + jointEdgeUnit(arm, j);
      throw InputError(what + ": joint " + std::to_string(j + 1) + ": the box " + formatNumber("%g", lower_rad[j] * scale) + ".." +
                       formatNumber("%g", upper_rad[j] * scale) + unit + " leaves no travel within the robot's limits " +
                       formatNumber("%g", arm.lower_rad[j] * scale) + ".." + formatNumber("%g", arm.upper_rad[j] * scale) + unit);
    }
    arm.lower_rad[j] = lo;
    arm.upper_rad[j] = hi;
  }
  return arm;
}

double singularityMeasure(const Arm& arm, const Eigen::VectorXd& q, int locked_joint) {
  const Matrix6Xd J = scaledManipulatorJacobian(arm, q, characteristicLength(arm));
  Eigen::MatrixXd Js(6, arm.numJoints() - (locked_joint >= 0 ? 1 : 0));
  for (int j = 0, c = 0; j < arm.numJoints(); ++j) {
    if (j == locked_joint) continue;
    Js.col(c++) = J.col(j);
  }
  return Eigen::JacobiSVD<Eigen::MatrixXd>(Js).singularValues().minCoeff();
}

Eigen::Isometry3d cameraTBoard(const Arm& arm, const Scene& scene, const Eigen::VectorXd& q) {
  return cameraTBoard(forwardKinematics(arm, q), scene);
}

Eigen::Isometry3d cameraTBoard(const Eigen::Isometry3d& base_T_flange, const Scene& scene) {
  return (base_T_flange * scene.flange_T_camera).inverse() * scene.base_T_board;
}

namespace {

enum class Outcome { kAccepted, kIkFailed, kSingular, kNotVisible, kBelowFloor };

/// True when the origin of every frame a joint moves (chainFrames after base_T_first, the flange
/// last) of `arm` at q lies at z >= floor_z_m (base frame).
bool aboveFloor(const Arm& arm, const Eigen::VectorXd& q, double floor_z_m) {
  const std::vector<Eigen::Isometry3d> frames = chainFrames(arm, q);
  return std::all_of(frames.begin() + 1, frames.end(), [&](const Eigen::Isometry3d& f) { return f.translation().z() >= floor_z_m; });
}

struct Attempt {
  Outcome outcome = Outcome::kIkFailed;
  Eigen::VectorXd q;
};

Attempt tryOne(const Arm& arm, const Scene& scene, const GeneratorSettings& s, std::uint64_t k) {
  std::mt19937_64 rng = makeRng(s.seed, k);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const ViewConstraints& v = scene.views;
  // 1. Camera pose in the board frame, looking at a point near the board centre.
  const Board& b = scene.board;
  const Eigen::Vector3d target = boardCentre(b) + Eigen::Vector3d((u01(rng) - 0.5) * 0.3 * b.corners_x * b.square_m,
                                                                  (u01(rng) - 0.5) * 0.3 * b.corners_y * b.square_m, 0);
  const double tilt = u01(rng) * v.max_tilt_rad;
  const double azimuth = u01(rng) * 2.0 * kPi;
  const double distance = v.min_distance_m + u01(rng) * (v.max_distance_m - v.min_distance_m);
  const double roll = (u01(rng) - 0.5) * 2.0 * kPi;
  // The printed face looks along -z_board: the camera sits on that side and looks back along +z-ish.
  const Eigen::Vector3d to_camera(std::sin(tilt) * std::cos(azimuth), std::sin(tilt) * std::sin(azimuth), -std::cos(tilt));
  const Eigen::Vector3d z_cam = -to_camera;
  const Eigen::Vector3d helper = std::abs(z_cam.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d x0 = (helper - helper.dot(z_cam) * z_cam).normalized();
  const Eigen::Vector3d x_cam = Eigen::AngleAxisd(roll, z_cam) * x0;
  Eigen::Isometry3d board_T_camera = Eigen::Isometry3d::Identity();
  board_T_camera.linear() << x_cam, z_cam.cross(x_cam), z_cam;
  board_T_camera.translation() = target + distance * to_camera;
  const Eigen::Isometry3d base_T_flange = scene.base_T_board * board_T_camera * scene.flange_T_camera.inverse();
  // 2. IK from a random start.
  Eigen::VectorXd q0(arm.numJoints());
  for (int j = 0; j < arm.numJoints(); ++j) q0[j] = arm.lower_rad[j] + u01(rng) * (arm.upper_rad[j] - arm.lower_rad[j]);
  IkOptions opt;
  opt.locked_joint = v.locked_joint;
  opt.least_motion = false;
  opt.max_iterations = 60;
  opt.position_tol_m = 1e-9;
  opt.rotation_tol_rad = 1e-9;
  const IkResult ik = inverseKinematics(arm, base_T_flange, q0, opt);
  Attempt a;
  a.q = ik.q;
  if (!ik.converged) return a;
  // 3. Acceptance.
  if (singularityMeasure(arm, a.q, v.locked_joint) < v.min_singular_value) {
    a.outcome = Outcome::kSingular;
  } else if (boardVisibility(scene, cameraTBoard(arm, scene, a.q)) != Visibility::kVisible) {
    a.outcome = Outcome::kNotVisible;
  } else if (s.floor_z_m && !aboveFloor(arm, a.q, *s.floor_z_m)) {
    a.outcome = Outcome::kBelowFloor;
  } else {
    a.outcome = Outcome::kAccepted;
  }
  return a;
}

}  // namespace

std::vector<Eigen::VectorXd> generateConfigurations(const Arm& arm, const Scene& scene, const GeneratorSettings& s,
                                                    GeneratorStats* stats_out,
                                                    const std::function<void(int, int)>& progress) {
  if (s.count < 0) throw std::invalid_argument("generateConfigurations: count must be >= 0");
  if (scene.views.locked_joint >= arm.numJoints()) {
    throw InputError(scene.source + ": views.locked_joint: joint " + std::to_string(scene.views.locked_joint + 1) +
                                " but the arm has " + std::to_string(arm.numJoints()) + " joints");
  }
  const int max_attempts = s.max_attempts > 0 ? s.max_attempts : std::max(4000, 400 * s.count);
  const int stop_after = s.stop_after > 0 ? std::min(s.stop_after, s.count) : s.count;
  const int threads = s.threads > 0 ? s.threads : availableCores();
  GeneratorStats stats;
  std::vector<Eigen::VectorXd> out;
  std::vector<Attempt> batch;
  while (static_cast<int>(out.size()) < stop_after && stats.attempts < max_attempts) {
    const int needed = stop_after - static_cast<int>(out.size());
    // Batch size: the attempts still needed at the acceptance rate seen so far (+10 %), so that few are
    // tried in vain (a fixed 8 x needed tried 4.6 x too many for 20,000 views of the default scene). The
    // first batch is a probe of at most 1024 at a guessed rate of 1/2; never more than 8 x needed. The
    // result does not depend on the batches: attempts are counted in attempt order.
    const double rate = stats.attempts > 0 ? std::max(0.02, static_cast<double>(out.size()) / stats.attempts) : 0.5;
    const double wanted = std::min(8.0 * needed, 1.1 * needed / rate + 16.0);
    const int n = std::min(max_attempts - stats.attempts,
                           std::max(64, static_cast<int>(stats.attempts > 0 ? wanted : std::min(wanted, 1024.0))));
    batch.assign(n, Attempt{});
    const int first = stats.attempts;
    auto work = [&](int t) {
      for (int i = t; i < n; i += threads) batch[i] = tryOne(arm, scene, s, static_cast<std::uint64_t>(first + i));
    };
    std::vector<std::thread> pool;
    for (int t = 1; t < threads; ++t) pool.emplace_back(work, t);
    work(0);
    for (auto& th : pool) th.join();
    for (int i = 0; i < n && static_cast<int>(out.size()) < stop_after; ++i) {
      ++stats.attempts;
      switch (batch[i].outcome) {
        case Outcome::kAccepted: out.push_back(batch[i].q); break;
        case Outcome::kIkFailed: ++stats.ik_failed; break;
        case Outcome::kSingular: ++stats.singular; break;
        case Outcome::kNotVisible: ++stats.not_visible; break;
        case Outcome::kBelowFloor: ++stats.below_floor; break;
      }
    }
    if (progress) progress(static_cast<int>(out.size()), s.count);
    if (out.empty() && stats.attempts >= 4000) break;  // nothing at all: the scene is unusable
  }
  stats.accepted = static_cast<int>(out.size());
  if (stats_out) *stats_out = stats;
  if (static_cast<int>(out.size()) < stop_after) {
    throw InputError(scene.source + ": base_T_board: only " + std::to_string(out.size()) + " of " +
                     std::to_string(stop_after) + " configurations see the whole board after " +
                     std::to_string(stats.attempts) + " attempts (IK failed " + std::to_string(stats.ik_failed) +
                     ", singular " + std::to_string(stats.singular) + ", board not visible " +
                     std::to_string(stats.not_visible) + (s.floor_z_m ? ", below the floor " + std::to_string(stats.below_floor) : std::string()) +
                     "); move the board or relax 'views'");
  }
  return out;
}

}  // namespace orbcal::sim
