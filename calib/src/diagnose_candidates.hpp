#pragma once
// The candidate causes diagnose tries on a dataset (calib/src/diagnose_candidates.cpp).
#include <vector>

#include "orbcal/calib/diagnose.hpp"

namespace orbcal::calib {

/// Every catalog effect the data can reveal (what it needs: torques, temperature, time, sessions),
/// adapted to the samples (e.g. a reference temperature at their mean).
std::vector<sim::Effect> catalogCandidates(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs,
                                           const DiagnoseOptions& o);
/// Empirical corrections (sim/src/effects/empirical.cpp) the data can carry: each joint against its
/// own angle and, with torques, its own torque, at degree `degree` (the score test's reach; the degree
/// is then chosen by cross-validation), over the data's range.
std::vector<sim::Effect> empiricalCandidates(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs, int degree);

}  // namespace orbcal::calib
