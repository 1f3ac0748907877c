#pragma once
// Parameter-error sets injected into the "true" arm, the joint control noise of the plant, and the
// seeded random streams every experiment draws from.
#include <Eigen/Core>
#include <cstdint>
#include <random>
#include <string>

#include "orbcal/sim/arm.hpp"

namespace orbcal::sim {

/// A random stream for (seed, stream): independent streams for independent uses of one seed
/// (e.g. stream k for configuration attempt k), identical on every run and thread count.
std::mt19937_64 makeRng(std::uint64_t seed, std::uint64_t stream = 0);

/// Wang et al. 2023 Table 3, in SI units (theta, alpha in rad; a, d in m), y order. Needs a 7-joint arm of 4
/// parameters per joint (modified or standard DH).
Eigen::VectorXd paperTable3Errors();

/// Errors drawn from N(0, angle_sigma_rad) for theta, alpha (and beta) and N(0, length_sigma_m) for a and d.
Eigen::VectorXd randomErrors(const Arm& arm, double angle_sigma_rad, double length_sigma_m, std::uint64_t seed);

/// Liu et al. 2012's injected errors (section 4.4): theta, alpha and beta drawn as randomErrors does
/// (N(0, angle_sigma_rad), the same draws for a seed), a and d positive and proportional to their
/// nominal lengths, length_per_metre * |a_i| and |d_i| (thermal expansion of a warm arm; the paper:
/// ~2 mm on a 2 m arm).
Eigen::VectorXd thermalErrors(const Arm& arm, double angle_sigma_rad, double length_per_metre, std::uint64_t seed);

/// An error set by name: "table3" (Wang et al. 2023 Table 3), "zero", or "random" with the given spread and seed.
/// Throws InputError naming `what` (e.g. "--errors") for an unknown name, or for table3 on an arm that
/// is not 7 joints of 4 parameters.
struct ErrorSetSpec {
  std::string name = "table3";
  double angle_sigma_rad = 0.3 * 3.14159265358979323846 / 180.0;
  double length_sigma_m = 0.001;
  std::uint64_t seed = 1;
};
Eigen::VectorXd makeErrorSet(const Arm& arm, const ErrorSetSpec& spec, const std::string& what);

/// Joint angles of the plant: q + N(0, sigma_rad) per joint (Wang et al. 2023's "control noise").
Eigen::VectorXd addJointNoise(const Eigen::VectorXd& q, double sigma_rad, std::mt19937_64& rng);

/// One line per joint: "joint i: theta +0.300 deg  alpha ... a +0.500 mm  d ..." (degrees and mm at the
/// edge), then "  beta ... deg" for a Hayati arm. y has arm.numParams() entries.
std::string formatErrorSet(const Arm& arm, const Eigen::VectorXd& y);

class ConfigNode;
/// Error tables (a manifest's true_errors, an error-set file's geometry rows) hold one row per joint
/// keyed by paramKey: theta_deg, alpha_deg, a_mm, d_mm (4), + beta_deg (Hayati, 5), or theta_deg,
/// x_mm, y_mm, z_mm, roll_deg, pitch_deg, yaw_deg (URDF, 7). The arm whose convention a table with
/// `per_joint` entries a row is in (only its convention is set); 4 gives the standard DH.
Arm errorTableArm(int per_joint);
/// The entries per row of a table whose first row is `row` (from its keys: beta_deg 5, x_mm 7, else 4).
int errorTablePerJoint(const ConfigNode& row);
/// Joint `joint`'s row "{theta_deg: v, ...}" of y (arm.paramsPerJoint() entries a joint), values in
/// deg and mm written with `number`.
std::string errorRowYaml(const Arm& arm, const Eigen::VectorXd& y, int joint, std::string (*number)(double));
/// Reads joint `joint`'s row into y (every key required, no other allowed).
void readErrorRow(const ConfigNode& row, const Arm& arm, int joint, Eigen::VectorXd& y);

}  // namespace orbcal::sim
