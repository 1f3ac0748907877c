#include "orbcal/sim/errors.hpp"

#include <cmath>
#include <cstdio>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::sim {

std::mt19937_64 makeRng(std::uint64_t seed, std::uint64_t stream) {
  // SplitMix64 of (seed, stream) so that neighbouring seeds and streams give unrelated states.
  std::uint64_t z = seed * 0x9E3779B97F4A7C15ULL + stream + 0xD1B54A32D192ED03ULL;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  z ^= z >> 31;
  return std::mt19937_64(z);
}

Eigen::VectorXd paperTable3Errors() {
  // Wang et al. 2023, Table 3: per joint theta [deg], alpha [deg], a [mm], d [mm].
  static const double kTable3[7][4] = {{0.3, 0.2, 0.5, -0.9},   {-0.2, 0.3, 0.8, 0.8}, {0.2, -0.25, -0.6, -1.0},
                                       {0.3, 0.3, -0.9, 0.8},   {0.2, -0.3, 1.0, 0.8}, {0.2, -0.2, -0.8, 0.75},
                                       {-0.3, 0.25, 0.9, 0.6}};
  constexpr int kPerJoint = 4;  // theta, alpha, a, d (paramIndex's layout of a 4-parameter arm)
  Eigen::VectorXd y(7 * kPerJoint);
  for (int j = 0; j < 7; ++j) {
    y[kPerJoint * j + kTheta] = kTable3[j][0] * kDegToRad;
    y[kPerJoint * j + kAlpha] = kTable3[j][1] * kDegToRad;
    y[kPerJoint * j + kA] = kTable3[j][2] * 1e-3;
    y[kPerJoint * j + kD] = kTable3[j][3] * 1e-3;
  }
  return y;
}

Eigen::VectorXd randomErrors(const Arm& arm, double angle_sigma_rad, double length_sigma_m, std::uint64_t seed) {
  std::mt19937_64 rng = makeRng(seed, 0x6572726f72ULL);
  std::normal_distribution<double> n01(0.0, 1.0);
  Eigen::VectorXd y(arm.numParams());
  for (int i = 0; i < arm.numParams(); ++i) y[i] = n01(rng) * (isAngleParam(arm, i) ? angle_sigma_rad : length_sigma_m);
  return y;
}

Eigen::VectorXd thermalErrors(const Arm& arm, double angle_sigma_rad, double length_per_metre, std::uint64_t seed) {
  Eigen::VectorXd y = randomErrors(arm, angle_sigma_rad, 0.0, seed);
  for (int j = 0; j < arm.numJoints(); ++j) {
    y[paramIndex(arm, j, kA)] = length_per_metre * std::abs(arm.joints[j].a_m);
    y[paramIndex(arm, j, kD)] = length_per_metre * std::abs(arm.joints[j].d_m);
  }
  return y;
}

Eigen::VectorXd makeErrorSet(const Arm& arm, const ErrorSetSpec& spec, const std::string& what) {
  if (spec.name == "table3") {
    if (arm.numJoints() != 7) {
      throw InputError(what + ": error set 'table3' is Wang et al. 2023's, for a 7-joint arm; " + arm.source + " has " +
                       std::to_string(arm.numJoints()) + " joints");
    }
    if (arm.paramsPerJoint() != 4) {
      throw InputError(what + ": error set 'table3' is Wang et al. 2023's 4 errors per joint; " + arm.source + " is " +
                       conventionName(arm.convention) + " DH with " + std::to_string(arm.paramsPerJoint()) +
                       " (use random, zero or an error-set file)");
    }
    return paperTable3Errors();
  }
  if (spec.name == "zero") return Eigen::VectorXd::Zero(arm.numParams());
  if (spec.name == "random") return randomErrors(arm, spec.angle_sigma_rad, spec.length_sigma_m, spec.seed);
  throw InputError(what + ": unknown error set '" + spec.name + "' (expected table3, zero or random)");
}

Eigen::VectorXd addJointNoise(const Eigen::VectorXd& q, double sigma_rad, std::mt19937_64& rng) {
  std::normal_distribution<double> n01(0.0, 1.0);
  Eigen::VectorXd out = q;
  for (Eigen::Index i = 0; i < q.size(); ++i) out[i] += sigma_rad * n01(rng);
  return out;
}

Arm errorTableArm(int per_joint) {
  Arm arm;
  arm.convention = per_joint == 7 ? DhConvention::kUrdf : per_joint == 5 ? DhConvention::kHayati : DhConvention::kStandard;
  return arm;
}

int errorTablePerJoint(const ConfigNode& row) {
  if (row.has("x_mm")) return 7;
  return row.has("beta_deg") ? 5 : 4;
}

namespace {
double edgeScale(const Arm& arm, int index) { return isAngleParam(arm, index) ? kRadToDeg : 1e3; }
}  // namespace

std::string errorRowYaml(const Arm& arm, const Eigen::VectorXd& y, int joint, std::string (*number)(double)) {
  std::string s = "{";
  for (int k = 0; k < arm.paramsPerJoint(); ++k) {
    const int i = arm.paramsPerJoint() * joint + k;
    s += (k ? ", " : "") + paramKey(arm, i) + ": " + number(y[i] * edgeScale(arm, i));
  }
  return s + "}";
}

void readErrorRow(const ConfigNode& row, const Arm& arm, int joint, Eigen::VectorXd& y) {
  std::vector<std::string> keys;
  for (int k = 0; k < arm.paramsPerJoint(); ++k) keys.push_back(paramKey(arm, arm.paramsPerJoint() * joint + k));
  row.requireOnlyKeys(keys);
  for (int k = 0; k < arm.paramsPerJoint(); ++k) {
    const int i = arm.paramsPerJoint() * joint + k;
    // Physical ranges at their keys: an error of an angle within half a turn, of a length within 10 m.
    y[i] = (isAngleParam(arm, i) ? row[keys[static_cast<std::size_t>(k)]].asDoubleWithin(-180.0, 180.0, "-180 deg to 180 deg (an angle error)")
                                 : row[keys[static_cast<std::size_t>(k)]].asDoubleWithin(-1e4, 1e4, "-10000 mm to 10000 mm (a length error)")) /
           edgeScale(arm, i);
  }
}

std::string formatErrorSet(const Arm& arm, const Eigen::VectorXd& y) {
  checkParamVector(arm, y, "formatErrorSet");
  if (arm.convention == DhConvention::kUrdf) {
    std::string out;
    for (int j = 0; j < arm.numJoints(); ++j) {
      out += "  joint " + std::to_string(j + 1) + ":";
      for (int k = 0; k < arm.paramsPerJoint(); ++k) {
        const int i = paramIndex(arm, j, static_cast<ParamKind>(k));
        char v[64];
        std::snprintf(v, sizeof v, " %s %+8.4f %s ", paramName(arm, i).c_str(), y[i] * edgeScale(arm, i),
                      isAngleParam(arm, i) ? "deg" : "mm");
        out += v;
      }
      out += "\n";
    }
    return out;
  }
  std::string out;
  char line[200];
  for (int j = 0; j < arm.numJoints(); ++j) {
    std::snprintf(line, sizeof line, "  joint %d: theta %+8.4f deg  alpha %+8.4f deg  a %+8.4f mm  d %+8.4f mm", j + 1,
                  y[paramIndex(arm, j, kTheta)] * kRadToDeg, y[paramIndex(arm, j, kAlpha)] * kRadToDeg,
                  y[paramIndex(arm, j, kA)] * 1e3, y[paramIndex(arm, j, kD)] * 1e3);
    out += line;
    if (arm.convention == DhConvention::kHayati) {
      std::snprintf(line, sizeof line, "  beta %+8.4f deg", y[paramIndex(arm, j, kBeta)] * kRadToDeg);
      out += line;
    }
    out += "\n";
  }
  return out;
}

}  // namespace orbcal::sim
