#pragma once
// Wang et al. 2023's own measurement setting: no images, the true flange pose with noise added,
// base_T_flange_measured = base_T_flange_true * exp([nu_p; nu_o]), nu ~ N(0, diag(sp^2 x3, so^2 x3))
// in the flange frame.
#include <random>
#include <vector>

#include "orbcal/calib/model.hpp"
#include "orbcal/calib/validation.hpp"

namespace orbcal::calib {

std::vector<PoseObservation> syntheticObservations(const PlantSamples& plant, double sigma_position_m,
                                                   double sigma_orientation_rad, std::mt19937_64& rng);

}  // namespace orbcal::calib
