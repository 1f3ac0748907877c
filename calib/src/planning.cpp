#include "orbcal/calib/planning.hpp"

#include <cmath>
#include <stdexcept>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::calib {

namespace {

struct KindName {
  MeasurementKind kind;
  const char* name;
  const char* description;
};
const KindName kKinds[] = {
    {MeasurementKind::kPose, "pose", "absolute end-effector pose (Wang et al. 2023: an eye-in-hand camera and a board)"},
    {MeasurementKind::kPosition, "position", "absolute end-effector position only (a laser tracker without orientation)"},
    {MeasurementKind::kDistance, "distance", "distance between the end-effector positions of pairs of configurations (Jia et al. 2019)"},
    {MeasurementKind::kRotation, "rotation", "rotation angle between the end-effector orientations of pairs of configurations (Jia et al. 2019)"},
    {MeasurementKind::kDistanceRotation, "dr",
     "distance and rotation angle between pairs of configurations (Jia et al. 2019: no measurement-frame transform)"},
    {MeasurementKind::kRange, "range", "laser range along a beam fixed to the end-effector to an identified plane (Liu et al. 2012)"},
};

const KindName& entry(MeasurementKind kind) {
  for (const KindName& k : kKinds) {
    if (k.kind == kind) return k;
  }
  throw std::invalid_argument("measurement kind: unknown");
}

}  // namespace

MeasurementKind parseMeasurementKind(const std::string& text, const std::string& what) {
  std::string choices;
  for (const KindName& k : kKinds) {
    if (text == k.name) return k.kind;
    choices += std::string(choices.empty() ? "" : ", ") + k.name;
  }
  throw sim::InputError(what + ": '" + text + "' is not a measurement kind (one of " + choices + ")");
}

std::string measurementKindName(MeasurementKind kind) { return entry(kind).name; }
std::string measurementKindDescription(MeasurementKind kind) { return entry(kind).description; }
bool isPoseKind(MeasurementKind kind) { return kind != MeasurementKind::kRange; }
bool isRelativeKind(MeasurementKind kind) {
  return kind == MeasurementKind::kDistance || kind == MeasurementKind::kRotation || kind == MeasurementKind::kDistanceRotation;
}

RelativeRows relativeRows(MeasurementKind kind) {
  switch (kind) {
    case MeasurementKind::kDistance: return RelativeRows::kDistance;
    case MeasurementKind::kRotation: return RelativeRows::kRotation;
    case MeasurementKind::kDistanceRotation: return RelativeRows::kBoth;
    default: throw std::invalid_argument("relativeRows: " + measurementKindName(kind) + " is not a relative kind");
  }
}

std::vector<sim::JointSample> samplesOf(const std::vector<Eigen::VectorXd>& configs) {
  std::vector<sim::JointSample> out(configs.size());
  for (std::size_t k = 0; k < configs.size(); ++k) out[k].q_rad = configs[k];
  return out;
}

std::unique_ptr<MeasurementModel> modelFromPoses(const MeasurementSetup& setup, const sim::KinematicModel& km,
                                                 std::vector<MarkerObservation> poses) {
  switch (setup.kind) {
    case MeasurementKind::kPose:
    case MeasurementKind::kPosition:
      for (MarkerObservation& o : poses) {
        o.has_rotation = setup.kind == MeasurementKind::kPose;
      }
      return std::make_unique<MarkerPoseModel>(km, std::move(poses), setup.noise);
    case MeasurementKind::kDistance:
    case MeasurementKind::kRotation:
    case MeasurementKind::kDistanceRotation:
    {
      std::vector<RelativeObservation> pairs = relativePairs(poses, setup.pairing, setup.reference, setup.noise, setup.guard);
      if (setup.noise.joint_noise_sigma_rad > 0.0) {
        addRelativeJointNoise(km, Eigen::VectorXd::Zero(km.layout.size()), setup.noise.joint_noise_sigma_rad, pairs);
      }
      return std::make_unique<RelativePoseModel>(km, std::move(pairs), relativeRows(setup.kind));
    }
    case MeasurementKind::kRange: break;
  }
  throw std::invalid_argument("modelFromPoses: a range is not a pose (use PlaneRangeModel)");
}

std::unique_ptr<MeasurementModel> planningModel(const MeasurementSetup& setup, const sim::KinematicModel& km,
                                                const std::vector<sim::JointSample>& samples) {
  if (setup.kind == MeasurementKind::kRange) {
    const PlaneRangeModel probe(km, setup.beam, setup.plane, {});
    const Eigen::VectorXd p = Eigen::VectorXd::Zero(probe.numParams());
    std::vector<sim::JointSample> hitting;  // the beam not parallel to the plane
    for (const sim::JointSample& s : samples) {
      if (std::isfinite(probe.predictRange(p, s))) hitting.push_back(s);
    }
    std::mt19937_64 unused;
    return std::make_unique<PlaneRangeModel>(
        km, setup.beam, setup.plane, simulateRanges(probe, p, hitting, setup.range_sigma_m, setup.range_repeats, unused, false));
  }
  const Eigen::VectorXd p = Eigen::VectorXd::Zero(km.layout.size());
  std::vector<MarkerObservation> poses;
  for (const sim::JointSample& s : samples) {
    MarkerObservation o;
    o.sample = s;
    o.world_T_marker = sim::predictMarkerPose(km, p, s);
    poses.push_back(std::move(o));
  }
  return modelFromPoses(setup, km, std::move(poses));
}

std::vector<MarkerObservation> simulatePoses(const sim::KinematicModel& truth, const Eigen::VectorXd& p_true,
                                             const std::vector<sim::JointSample>& commanded, double joint_noise_sigma_rad,
                                             const MarkerNoise& noise, std::mt19937_64& rng) {
  std::normal_distribution<double> n01(0.0, 1.0);
  std::vector<MarkerObservation> out;
  for (const sim::JointSample& s : commanded) {
    sim::JointSample plant = s;
    for (Eigen::Index j = 0; j < plant.q_rad.size(); ++j) plant.q_rad[j] += joint_noise_sigma_rad * n01(rng);
    sim::Vector6d e;
    for (int i = 0; i < 6; ++i) e[i] = n01(rng) * (i < 3 ? noise.sigma_position_m : noise.sigma_rotation_rad);
    MarkerObservation o;
    o.sample = s;
    o.world_T_marker = sim::posePlus(sim::predictMarkerPose(truth, p_true, plant), e);
    out.push_back(std::move(o));
  }
  return out;
}

}  // namespace orbcal::calib
