#pragma once
// What `orbcal diagnose`'s report says of the noise (workflow/src/diagnose_noise_text.cpp): the noise
// every fit whitens with and where it came from, the estimated components' uncertainty, and the floor
// the verdict is judged against.
#include <string>
#include <vector>

#include "orbcal/calib/diagnose.hpp"
#include "orbcal/sim/measured.hpp"

namespace orbcal::workflow {

/// "Noise, 1 sigma per axis, as every fit here whitens with it: ..." with where each number came from,
/// the estimated components' uncertainty, the floor the verdict is judged against (calib::NoiseFloors)
/// and, where effects were selected with the noise estimated, the noise with them fitted (what
/// `orbcal calibrate` with them reports).
std::string noiseSentence(const calib::Diagnosis& dg, const calib::DiagnoseOptions& o, const sim::MeasuredData& data,
                          const std::vector<calib::MarkerObservation>& obs);

}  // namespace orbcal::workflow
