#pragma once
// Image degradations of a real camera, applied to a clean render (CV_8UC1). Exposure is not here: it
// scales the radiance inside the renderer, before the sensor saturates. Order: defocus blur, shot
// noise, read noise, rounding to 8 bits. Randomness comes only from `rng`, so a seeded stream gives
// the same image on every run.
#include <opencv2/core.hpp>
#include <random>

#include "orbcal/render/settings.hpp"

namespace orbcal::render {

/// A Gaussian blur of a CV_32FC1 image in place: sigma_px, kernel +-ceil(4 sigma), the border
/// replicated (defocus here and the camera profile's blur and unsharp mask). Nothing for sigma <= 0.
void gaussianBlur(cv::Mat& img, double sigma_px);

/// - defocus: Gaussian blur with sigma defocus_sigma_px (kernel +-4 sigma);
/// - shot noise (full_well_e > 0): signal in electrons e = DN / 255 * full_well_e gets N(0, sqrt(e))
///   added (the normal approximation of Poisson noise), then back to DN;
/// - read noise (read_noise_dn > 0): N(0, read_noise_dn) DN added;
/// - rounded and clamped to [0, 255].
/// Returns `clean` unchanged (shared) when no degradation is enabled; throws std::invalid_argument
/// unless clean is CV_8UC1.
cv::Mat applyDegradations(const cv::Mat& clean, const Degradations& d, std::mt19937_64& rng);

}  // namespace orbcal::render
