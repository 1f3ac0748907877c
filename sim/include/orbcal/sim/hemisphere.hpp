#pragma once
// The configurations of Jia et al. 2019's protocol: around a reference configuration
// q_ref, N flange positions spread uniformly over a hemisphere of radius r centred at the reference
// flange position p_ref, each with the flange z axis pointing at the board centre c.
//
//  - c = p_ref + target_distance * z_ref (the board centre, 0.5 m in front of the reference flange);
//  - the hemisphere opens away from the board: its pole is p_ref - r z_ref, its rim the circle of
//    radius r about p_ref in the plane perpendicular to z_ref (the paper does not say which side; the
//    board side would put the pole on the board itself);
//  - positions: a Fibonacci lattice (our choice), point i = 0..N-1 at polar angle acos(1 - (i + 0.5) / N)
//    from the pole and azimuth i times the golden angle pi (3 - sqrt 5), in the reference flange's x/y
//    axes: equal-area height bands, so the points are uniform over the hemisphere's area;
//  - orientation: the flange z axis along c - p; the roll about it is the one nearest the reference's:
//    R = Rot(z_ref x z, angle(z_ref, z)) R_ref, the smallest rotation of the reference orientation that
//    points z at c (swing without twist). Among all orientations pointing at c it has the smallest
//    rotation angle from R_ref (angle of Rot(k, a) Rz(psi) for k perpendicular to z: trace
//    (1 + cos a) cos psi + cos a, largest at psi = 0);
//  - joints: sim::inverseKinematics from q_ref, with one joint locked at its q_ref value for a 7-joint
//    arm and the least-motion choice among branches; a point whose IK finds no solution within the
//    joint limits is reported in `unreachable`, never dropped silently.
#include <Eigen/Geometry>
#include <vector>

#include "orbcal/sim/arm.hpp"

namespace orbcal::sim {

struct HemisphereSettings {
  int count = 51;                   ///< lattice points (Jia et al. 2019: 51)
  double radius_m = 0.5;            ///< hemisphere radius (Jia et al. 2019: 0.5 m)
  double target_distance_m = 0.5;   ///< |c - p_ref| along z_ref (the board 0.5 m from the reference flange)
  /// 0-based joint held at q_ref; -1: none. Default theta_3: joint 1 must move (held, theta2 and d2 turn
  /// and shift every pose rigidly, invisible to distances and angles and confounded with an estimated
  /// base frame), and on the SSRMS-type arm (scenes/ssrms_hayati.yaml) holding theta_2 (Wang et al. 2023's choice)
  /// leaves joints 1, 3..7 near singular at the jia2019 reference (singularity measure 0.026, 24 of 51
  /// points unreachable) where holding theta_3 leaves a well-conditioned chain (0.18, all 51 reached).
  int locked_joint = 2;
};

struct HemisphereConfigurations {
  Eigen::Isometry3d reference_pose = Eigen::Isometry3d::Identity();  ///< base_T_flange at q_ref
  Eigen::Vector3d target = Eigen::Vector3d::Zero();                  ///< c, base frame
  std::vector<Eigen::Isometry3d> poses;  ///< every lattice point's flange pose (count of them), lattice order
  std::vector<Eigen::VectorXd> q;        ///< the reached configurations, lattice order
  std::vector<int> reached;              ///< lattice index of each entry of q
  std::vector<int> unreachable;          ///< lattice indices with no IK solution within the joint limits
};

/// n unit vectors on the upper hemisphere (z >= 0) by the Fibonacci lattice described above.
std::vector<Eigen::Vector3d> fibonacciHemisphere(int n);

/// The rotation with z axis `z` (unit) nearest to R_ref: Rot(z_ref x z, angle(z_ref, z)) R_ref.
/// Throws std::invalid_argument when z is opposite to R_ref's z axis (the swing axis is undefined).
Eigen::Matrix3d pointingRotation(const Eigen::Matrix3d& R_ref, const Eigen::Vector3d& z);

/// The configurations of Jia et al. 2019 around q_ref (see above). Throws std::invalid_argument for
/// count < 1, radius or target distance <= 0, a locked joint out of range, or q_ref outside the limits.
HemisphereConfigurations hemisphereConfigurations(const Arm& arm, const Eigen::VectorXd& q_ref,
                                                  const HemisphereSettings& settings = {});

}  // namespace orbcal::sim
