#pragma once
// The configuration generator: N joint configurations within the limits, away from singularity, in
// which the eye-in-hand camera sees the whole board at a usable distance and viewing angle.
//
// Attempt k (its own random stream, so the result does not depend on the thread count):
//  1. a camera pose looking at a point near the board centre: distance uniform in the scene's range,
//     tilt from the board normal uniform in [0, max tilt], azimuth and roll about the optical axis uniform;
//  2. the flange pose base_T_camera * camera_T_flange, solved by IK from a random start within the
//     limits, with the scene's locked joint (views.locked_joint; theta_2, Wang et al. 2023's choice, by default)
//     drawn uniformly within its limits;
//  3. accepted if IK converged within the limits, the singularity measure is at least the scene's
//     views.min_singular_value, boardVisibility() says kVisible for the solution's true camera pose, and
//     (with a floor) every moving frame of the chain and the flange lie above the floor.
// The first N accepted attempts, in attempt order, are returned.
//
// Singularity measure: the smallest singular value of the 6 x (n-1) manipulator Jacobian without the
// locked joint's column, its translational rows divided by the arm's characteristic length L (so both
// row blocks are dimensionless). Below it, the locked-joint IK and small joint motions degenerate.
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "orbcal/sim/arm.hpp"
#include "orbcal/sim/scene.hpp"

namespace orbcal::sim {

struct GeneratorSettings {
  int count = 50;
  std::uint64_t seed = 1;
  int max_attempts = 0;        ///< 0: 400 per configuration asked for (count), at least 4000
  int threads = 0;             ///< 0: sim::availableCores()
  /// > 0: stop after the first stop_after configurations; they are the first stop_after of the `count`
  /// (attempt budget and order unchanged), for a caller that needs only a prefix (a dataset's shard).
  int stop_after = 0;
  /// A floor plane z = floor_z_m of the base frame (m): a configuration with the origin of any frame a
  /// joint moves (chainFrames after base_T_first: the joints' frames and the flange) below it is
  /// rejected (GeneratorStats::below_floor). Unset: no floor.
  std::optional<double> floor_z_m;
};


struct GeneratorStats {
  int attempts = 0;
  int ik_failed = 0;      ///< no solution within the limits from the random start
  int singular = 0;       ///< below the singularity threshold
  int not_visible = 0;    ///< the camera does not see the whole board
  int below_floor = 0;    ///< a joint origin or the flange below GeneratorSettings::floor_z_m
  int accepted = 0;
};

/// Throws InputError naming scene.source ("...: board: no configuration sees the whole board ...")
/// when fewer than settings.count (settings.stop_after) configurations are found within the attempt budget.
std::vector<Eigen::VectorXd> generateConfigurations(const Arm& arm, const Scene& scene, const GeneratorSettings& settings,
                                                    GeneratorStats* stats = nullptr,
                                                    const std::function<void(int, int)>& progress = {});

/// `arm` with its joint limits narrowed to the box [lower_rad, upper_rad] (one bound each per joint): a
/// cell or workspace narrower than the robot's travel. InputError naming `what` (the option) for a
/// wrong count or a box that leaves a joint no travel within the robot's limits.
Arm withJointBox(Arm arm, const Eigen::VectorXd& lower_rad, const Eigen::VectorXd& upper_rad, const std::string& what);

double singularityMeasure(const Arm& arm, const Eigen::VectorXd& q, int locked_joint);

/// camera_T_board seen at joint angles q: (base_T_flange * flange_T_camera)^-1 * base_T_board.
Eigen::Isometry3d cameraTBoard(const Arm& arm, const Scene& scene, const Eigen::VectorXd& q);
/// The same from the flange pose (e.g. a sim::TrueArm's, effects included).
Eigen::Isometry3d cameraTBoard(const Eigen::Isometry3d& base_T_flange, const Scene& scene);

}  // namespace orbcal::sim
