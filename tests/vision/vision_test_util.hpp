#pragma once
// Helpers for the vision tests: the default scene and camera poses that see its board.
#include <Eigen/Geometry>
#include <random>
#include <vector>

#include "orbcal/sim/io.hpp"
#include "orbcal/sim/scene.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::test {

inline const sim::Scene& defaultScene() {
  static const sim::Scene s = sim::loadScene(sim::kDefaultScene);
  return s;
}

/// camera_T_board looking at the board centre from `distance_m`, with the optical axis tilted by
/// (tilt_x, tilt_y) rad from the board normal and rolled by `roll_rad` about the optical axis.
inline Eigen::Isometry3d lookAtBoard(const sim::Board& board, double distance_m, double tilt_x, double tilt_y,
                                     double roll_rad) {
  // Camera frame aligned with the board frame (camera on the -z side looking along +z), then turned.
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(tilt_y, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(tilt_x, Eigen::Vector3d::UnitX()) *
                             Eigen::AngleAxisd(roll_rad, Eigen::Vector3d::UnitZ()))
                                .toRotationMatrix();  // board_R_camera
  Eigen::Isometry3d board_T_camera = Eigen::Isometry3d::Identity();
  board_T_camera.linear() = R;
  board_T_camera.translation() = sim::boardCentre(board) - distance_m * R.col(2);
  return board_T_camera.inverse(Eigen::Isometry);
}

/// Random views that see the whole board under the scene's constraints (seeded).
inline std::vector<Eigen::Isometry3d> randomViews(const sim::Scene& scene, int count, std::uint64_t seed,
                                                  double max_roll_rad = sim::kPi) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> dist(scene.views.min_distance_m, scene.views.max_distance_m),
      tilt(-0.5, 0.5), roll(-max_roll_rad, max_roll_rad);
  std::vector<Eigen::Isometry3d> out;
  while (static_cast<int>(out.size()) < count) {
    const Eigen::Isometry3d T = lookAtBoard(scene.board, dist(rng), tilt(rng), tilt(rng), roll(rng));
    if (sim::boardVisibility(scene, T) == sim::Visibility::kVisible) out.push_back(T);
  }
  return out;
}

}  // namespace orbcal::test
