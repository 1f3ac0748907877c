#include "orbcal/calib/rigid_body.hpp"

#include <stdexcept>

#include "orbcal/calib/registration.hpp"
#include "orbcal/sim/config.hpp"

namespace orbcal::calib {

sim::KinematicModel rigidBodyStart(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs,
                                   const std::vector<Eigen::Isometry3d>& F, const sim::KinematicModel& shape) {
  const auto n = static_cast<std::size_t>(data.points);
  std::vector<std::vector<Eigen::Isometry3d>> T(n), Fk(n);  // per point: measured positions, flange poses
  for (std::size_t i = 0; i < obs.size(); ++i) {
    const auto k = static_cast<std::size_t>(obs[i].point);
    if (obs[i].point < 0 || k >= n) throw std::invalid_argument("rigidBodyStart: an observation without its marker point");
    T[k].push_back(obs[i].world_T_marker);
    Fk[k].push_back(F[i]);
  }
  std::size_t most = 0;
  for (std::size_t k = 0; k < n; ++k) {
    if (T[k].empty()) {
      throw sim::InputError(data.description + ": pose.points[" + std::to_string(k) + "]: marker point " + std::to_string(k + 1) +
                            " has no measurement in the samples fitted (its cells are empty in every row)");
    }
    if (T[k].size() > T[most].size()) most = k;
  }
  std::vector<Eigen::Vector3d> points(n);
  Eigen::Isometry3d W = data.world_T_base;
  try {
    if (data.base != sim::FrameSharing::kKnown) W = initialRegistration(T[most], Fk[most], false).world_T_base;
    for (std::size_t k = 0; k < n; ++k) points[k] = initialMarker(T[k], Fk[k], W, false).translation();
  } catch (const std::invalid_argument& e) {
    throw sim::InputError(data.description + ": registration: the samples cannot fix the base frame and the marker points (" +
                          e.what() + ")");
  }
  const std::vector<Eigen::Isometry3d> bases(shape.world_T_base.size(), W);
  return sim::makeKinematicModel(shape.arm, shape.sessions, shape.base, sim::FrameSharing::kKnown, bases,
                                 {Eigen::Isometry3d::Identity()}, shape.effects, true, points);
}

}  // namespace orbcal::calib
