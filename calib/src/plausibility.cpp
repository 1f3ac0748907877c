#include "orbcal/calib/plausibility.hpp"

#include "orbcal/sim/marker_points.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"

namespace orbcal::calib {

namespace {

/// The description the data came from, for a message; data made in memory (a simulation study) has none.
std::string dataName(const sim::MeasuredData& data) {
  return data.description.empty() ? "the measured data (made in memory)" : data.description;
}


using sim::formatNumber;

constexpr double kPositionShareOfReach = 0.05;  ///< registration residual bound: 5 % of the reach
constexpr double kRotationRmsDeg = 5.0;         ///< registration residual bound in rotation
constexpr double kLengthShareOfLink = 0.05;     ///< a length parameter's move: 5 % of its link ...
constexpr double kLengthShareOfReach = 0.01;    ///< ... or 1 % of the reach where that is more
constexpr double kAngleMoveDeg = 10.0;          ///< an angle parameter's move
constexpr double kMoveSigmas = 3.0;             ///< a move beyond its bound by more than this many 1-sigma

std::string mm(double m) { return formatNumber(std::abs(m) < 1.0 ? "%.3f" : "%.0f", m * 1e3) + " mm"; }
std::string deg(double rad) { return formatNumber("%.3g", rad * sim::kRadToDeg) + " deg"; }

/// The nominal length of the link row `joint` describes: sqrt(a^2 + d^2), or |xyz| of a URDF origin.
double linkLength(const sim::Arm& arm, int joint) {
  const sim::DhRow& r = arm.joints[static_cast<std::size_t>(joint)];
  return arm.convention == sim::DhConvention::kUrdf ? r.xyz_m.norm() : std::hypot(r.a_m, r.d_m);
}

/// One other reading of the data: its label and how it turns the data as read into it.
struct Reading {
  std::string label;
  std::function<void(sim::MeasuredData&)> apply;
};

/// The readings a user's mistake in the description most often leaves: the other length unit, the other
/// angle unit, and the quaternion's columns in x, y, z, w order.
std::vector<Reading> otherReadings(const sim::MeasuredData& data) {
  std::vector<Reading> out;
  const bool in_mm = data.length_unit == "mm";
  const double length = in_mm ? 1000.0 : 1e-3;  // from the declared unit's metres to the other's
  out.push_back({std::string("pose.length_unit: ") + (in_mm ? "m" : "mm"), [length](sim::MeasuredData& d) {
                   for (sim::MeasuredPose& p : d.poses) p.world_T_marker.translation() *= length;
                 }});
  const bool in_deg = data.angle_unit == "deg";
  const double angle = in_deg ? sim::kRadToDeg : sim::kDegToRad;
  out.push_back({std::string("joints.unit: ") + (in_deg ? "rad" : "deg"), [angle](sim::MeasuredData& d) {
                   for (sim::MeasuredPose& p : d.poses) p.sample.q_rad *= angle;
                 }});
  if (data.quaternion) {
    out.push_back({"the quaternion columns read as x, y, z, w", [](sim::MeasuredData& d) {
                     for (sim::MeasuredPose& p : d.poses) {
                       // The columns c0..c3 were read as w, x, y, z; as x, y, z, w the rotation is (c3, c0, c1, c2).
                       const Eigen::Quaterniond c(p.world_T_marker.linear());
                       p.world_T_marker.linear() = Eigen::Quaterniond(c.z(), c.w(), c.x(), c.y()).normalized().toRotationMatrix();
                     }
                   }});
  }
  return out;
}

/// How far residuals stand from the bounds: the larger of position RMS / its bound and rotation RMS / its.
double excess(const ResidualStats& s, const PlausibilityBounds& b) {
  return std::max(s.position_rms_m / b.position_rms_m, s.rotation_rms_rad / b.rotation_rms_rad);
}

std::string residualText(const ResidualStats& s) {
  return mm(s.position_rms_m) + " RMS" + (s.rotation_rms_rad > 0.0 ? " (" + deg(s.rotation_rms_rad) + ")" : "");
}

/// "; the effects fitted with it (compliance:2 ...) may take the geometry's place ..." when there are any.
std::string confoundedEffects(const std::vector<sim::Effect>& effects) {
  if (effects.empty()) return "";
  std::string names;
  for (const sim::Effect& e : effects) names += (names.empty() ? "" : " ") + sim::formatEffect(e);
  return "; the effects fitted with it (" + names + ") may stand in for the geometry where the data cannot tell them apart "
         "(fit fewer --effects; orbcal diagnose names confounded causes)";
}

}  // namespace

double PlausibilityBounds::lengthMove(const sim::Arm& arm, const sim::ParamInfo& param) const {
  const int joint = std::max(0, param.joint);
  return std::max(kLengthShareOfLink * linkLength(arm, joint), kLengthShareOfReach * reach_m);
}

PlausibilityBounds plausibilityBounds(const sim::Arm& arm) {
  PlausibilityBounds b;
  b.reach_m = sim::characteristicLength(arm);
  b.position_rms_m = kPositionShareOfReach * b.reach_m;
  b.rotation_rms_rad = kRotationRmsDeg * sim::kDegToRad;
  b.angle_move_rad = kAngleMoveDeg * sim::kDegToRad;
  return b;
}

Fit fitRegistration(const sim::KinematicModel& start, const std::vector<MarkerObservation>& obs, FitOptions options) {
  options.method = "LM";
  for (const sim::ParamBlock& b : start.layout.blocks()) {
    if (sim::isRegistrationFrame(b.kind) || sim::isPointBlock(b)) continue;
    for (int i = 0; i < b.size(); ++i) options.hold.push_back(b.offset + i);
  }
  std::sort(options.hold.begin(), options.hold.end());
  options.hold.erase(std::unique(options.hold.begin(), options.hold.end()), options.hold.end());
  return fitMarkerModel(start, obs, options);
}

ResidualStats nominalRegistration(const sim::MeasuredData& data) {
  const std::vector<MarkerObservation> obs = observationsFrom(data, false);
  FitOptions o;
  o.sigma_position_m = data.noise_position_m;
  o.sigma_rotation_rad = data.noise_rotation_rad;
  o.joint_noise_sigma_rad = data.noise_joint_rad.value_or(0.0);
  o.analyze = false;
  return fitRegistration(startingModel(data, obs, {}), obs, o).residuals;
}

std::string likelyCauses(const sim::MeasuredData& data) {
  const PlausibilityBounds b = plausibilityBounds(data.arm);
  std::string causes = "; likely causes: a wrong pose.length_unit (" + data.length_unit + "), joints.unit (" + data.angle_unit + ")" +
                       (data.quaternion ? ", quaternion order (pose.quaternion_wxyz)" : "") +
                       ", joint order or sign (joints.columns), or robot file (robot: " + data.robot_file + ")";
  if (data.base == sim::FrameSharing::kKnown || data.marker == sim::FrameSharing::kKnown) causes += ", or a wrong known frame";
  std::string best_label;
  ResidualStats best;
  double best_excess = std::numeric_limits<double>::infinity();
  for (const Reading& r : otherReadings(data)) {
    sim::MeasuredData other = data;
    r.apply(other);
    try {
      const ResidualStats s = nominalRegistration(other);
      if (excess(s, b) < best_excess) best_excess = excess(s, b), best = s, best_label = r.label;
    } catch (const std::exception&) {
      // A reading whose frames cannot even be registered fits no better.
    }
  }
  if (best_excess <= 1.0) return causes + "; with " + best_label + " the nominal arm's registration residual is " + residualText(best);
  return causes + (data.quaternion ? "; neither the other length unit, the other angle unit nor the quaternion read x, y, z, w"
                                    : "; neither the other length unit nor the other angle unit") +
         " brings the nominal arm's registration residual within the bound";
}

void requirePlausibleResidual(const sim::MeasuredData& data, const ResidualStats& residuals, const std::string& what) {
  const PlausibilityBounds b = plausibilityBounds(data.arm);
  if (excess(residuals, b) <= 1.0) return;
  throw sim::InputError(dataName(data) + ": " + what + " is " + residualText(residuals) + ", beyond what any real arm and instrument give (" +
                        mm(b.position_rms_m) + ", 5 % of the arm's reach of " + formatNumber("%.3g", b.reach_m) + " m, and " +
                        deg(b.rotation_rms_rad) + ")" + likelyCauses(data));
}

std::string fitRefusal(const Fit& fit, const std::vector<MarkerObservation>& observations, const FitOptions& options) {
  if (options.method == "LM") return "";
  FitOptions lm = options;
  lm.method = "LM";
  lm.analyze = false;
  const Fit best = fitMarkerModel(fit.model, observations, lm, fit.p0);
  if (fit.residuals.position_rms_m <= kFarAboveLeastSquares * best.residuals.position_rms_m) return "";
  return "the fit leaves a position RMS of " + mm(fit.residuals.position_rms_m) + " on its own " +
         std::to_string(fit.residuals.samples) + " samples, more than " + formatNumber("%g", kFarAboveLeastSquares) +
         " times the " + mm(best.residuals.position_rms_m) + " the least-squares fit of the same model reaches there: " +
         options.method + " did not converge to the fit; calibrate with --method LM";
}

void requirePlausibleGeometry(const sim::MeasuredData& data, const Fit& fit) {
  const int g = fit.model.layout.find(sim::BlockKind::kGeometry);
  if (g < 0) return;
  const sim::ParamBlock& block = fit.model.layout.block(g);
  const sim::Arm& arm = fit.model.arm;
  const PlausibilityBounds b = plausibilityBounds(arm);
  for (int i = 0; i < block.size(); ++i) {
    const int k = block.offset + i;
    const double move = fit.p[k];
    const double sigma = fit.estimate.covariance.rows() > k ? std::sqrt(std::max(0.0, fit.estimate.covariance(k, k))) : 0.0;
    const bool angle = block.params[static_cast<std::size_t>(i)].quantity == sim::Quantity::kAngle;
    const double bound = angle ? b.angle_move_rad : b.lengthMove(arm, block.params[static_cast<std::size_t>(i)]);
    if (std::abs(move) <= bound + kMoveSigmas * sigma) continue;
    const auto in = [angle](double v) { return angle ? deg(v) : mm(v); };
    throw sim::InputError(dataName(data) + ": the calibrated geometry moves " + block.params[static_cast<std::size_t>(i)].name + " by " +
                          in(move) + " (1-sigma " + in(sigma) + "), more than a real arm is built off its drawing (" +
                          (angle ? in(bound) + " for an angle" : in(bound) + ": 5 % of the link, at least 1 % of the reach") + ")" +
                          confoundedEffects(fit.model.effects) + likelyCauses(data));
  }
}

}  // namespace orbcal::calib
