#pragma once
// The starting model of rigid-body data (a description's pose.points; sim/marker_points.hpp): the
// marker frame is the flange (known), each marker point gets its own offset, and the base frame and
// the offsets come from the closed-form registration guess (calib/registration.hpp) on the points.
#include <vector>

#include "orbcal/calib/marker_model.hpp"
#include "orbcal/sim/measured.hpp"
#include "orbcal/sim/model.hpp"

namespace orbcal::calib {

/// `shape` (startingModel's: the data's sessions, base sharing and effects) rebuilt with the marker
/// known at the flange and one point block per marker point, started from the guess: the base frame
/// from the point seen most often (unless known), then each point's offset given the base. `F`: the
/// nominal arm's base_T_flange at each observation. InputError naming the description when a point is
/// never seen or the samples cannot fix the frames.
sim::KinematicModel rigidBodyStart(const sim::MeasuredData& data, const std::vector<MarkerObservation>& observations,
                                   const std::vector<Eigen::Isometry3d>& F, const sim::KinematicModel& shape);

}  // namespace orbcal::calib
