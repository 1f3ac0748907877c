#pragma once
// What twin.cpp, twin_profile.cpp and twin_report.cpp share.
#include <random>

#include "orbcal/render/renderer.hpp"
#include "orbcal/workflow/twin.hpp"

namespace orbcal::workflow::twin_detail {

/// The twin at `pose` with `profile` applied: the board as printed (drawn by `printed`, a renderer with
/// the profile, where its board part is not the identity; else `clean`), then the image part
/// (render::applyCameraProfile; the background where the board's outline does not cover the image).
cv::Mat profiledTwin(render::BoardRenderer* printed, const sim::Scene& scene, const Eigen::Isometry3d& pose, const cv::Mat& clean,
                     const render::CameraProfile& profile, std::mt19937_64& rng);

/// Extra Gaussian blur (sigma, px) and unsharp-mask gain (mask sigma `mask_sigma_px`) that turn an edge of
/// 10-90 % width `rendered_width_px` into one of `width_px` with `overshoot` (of the step) more than it
/// had: a Gaussian edge model, searched on a grid (blur 0-3 px and gain 0-3, both by 0.05).
std::pair<double, double> blurAndSharpening(double rendered_width_px, double width_px, double overshoot, double mask_sigma_px);

}  // namespace orbcal::workflow::twin_detail
