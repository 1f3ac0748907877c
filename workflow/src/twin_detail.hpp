#pragma once
// What twin.cpp, twin_profile.cpp and twin_report.cpp share.
#include <random>

#include "orbcal/render/renderer.hpp"
#include "orbcal/vision/shared_fit.hpp"
#include "orbcal/workflow/twin.hpp"

namespace orbcal::workflow::twin_detail {

/// Extra Gaussian blur (sigma, px) and unsharp-mask gain (mask sigma `mask_sigma_px`) that turn an edge of
/// 10-90 % width `rendered_width_px` into one of `width_px` with `overshoot` (of the step) more than it
/// had: a Gaussian edge model, searched on a grid (blur 0-3 px and gain 0-3, both by 0.05).
std::pair<double, double> blurAndSharpening(double rendered_width_px, double width_px, double overshoot, double mask_sigma_px);

/// Steps of the shared fits' central differences: k1, k2 (normalised coordinates), the sagitta (m), the scale.
inline constexpr double kLensStep = 1e-3, kBowStepM = 1e-4, kScaleStep = 1e-4;

/// The corner model at geometry g = (k1, k2, sagitta [m], scale_x / scale_y - 1): the camera with the
/// radial distortion (k1, k2) added to its own, the board bowed (render::printedBoardPoint's sagitta at
/// the half diagonal) and printed longer along x than along y.
vision::CornerModel geometryModel(const sim::Camera& camera, const sim::Board& board, const Eigen::VectorXd& g);
/// That geometry fitted to the views' detected corners, every view's pose refitted.
vision::SharedFit fitGeometry(const sim::Camera& camera, const sim::Board& board, const std::vector<ViewStats>& views);
/// A profile's geometry as g.
Eigen::VectorXd geometryOf(const render::CameraProfile& p);
/// The geometry the real corners show beyond the clean twins' (c.geometry[0] less [1]): each part (the
/// lens, the bow, the scale) where it differs significantly (beyond 2 sigma), the rest the identity.
render::CameraProfile shownGeometry(const TwinComparison& c);
/// The lens fit's shift at the image corner (px) and the bow fit's sagitta (mm), with standard errors.
vision::Estimate lensShiftEstimate(const sim::Camera& camera, const vision::SharedFit& fit);
vision::Estimate bowEstimate(const vision::SharedFit& fit);

}  // namespace orbcal::workflow::twin_detail
