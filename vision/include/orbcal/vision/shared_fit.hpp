#pragma once
// A few parameters that every view of a board shares (a lens's residual distortion, the bow of the
// printed sheet), fitted against the detected corners with each view's pose fitted again for every
// value of them (variable projection: Golub and Pereyra 2003), so that what the poses take up is not
// read as the shared effect. Used by `orbcal twin` (workflow/twin.hpp) to tell a field that depends on
// where a corner falls in the image, or on the sheet's shape, from the scatter about each view's pose.
#include <Eigen/Geometry>
#include <functional>
#include <limits>
#include <vector>

#include "orbcal/sim/scene.hpp"

namespace orbcal::vision {

/// One view's detected corners (by inner-corner id) and its pose to start from.
struct CornerView {
  Eigen::Isometry3d camera_T_board = Eigen::Isometry3d::Identity();
  std::vector<int> ids;
  std::vector<Eigen::Vector2d> corners_px;
};

/// The corner model at one value of the shared parameters: the camera the corners are seen through and
/// where each inner corner id lies in the board frame (m).
struct CornerModel {
  sim::Camera camera;
  std::function<Eigen::Vector3d(int id)> point;
};
using SharedModel = std::function<CornerModel(const Eigen::VectorXd& shared)>;

struct SharedFit {
  bool ok = false;
  Eigen::VectorXd value, sigma;  ///< the shared parameters and their standard errors (Gauss-Newton covariance)
  Eigen::MatrixXd covariance;
  /// RMS length (px) of the corner residuals with every pose refitted, at the start and at the fit.
  double rms_start_px = std::numeric_limits<double>::quiet_NaN(), rms_fit_px = std::numeric_limits<double>::quiet_NaN();
  int corners = 0, views = 0;
};

/// The view's pose refitted to its corners under `model` (Levenberg-Marquardt from its camera_T_board).
Eigen::Isometry3d refitPose(const CornerView& view, const CornerModel& model);

/// Each view's pose refitted (Levenberg-Marquardt from its camera_T_board) under `model(shared)`, then
/// its residuals, detected minus projected (px), stacked u0 v0 u1 v1 ... over the views in order.
Eigen::VectorXd refittedResiduals(const std::vector<CornerView>& views, const CornerModel& model);

/// Gauss-Newton on the shared parameters from `start` (forward differences of refittedResiduals with
/// `step`), at most 10 iterations, until a step gains less than 1e-6 of the sum of squares; the standard errors from the residuals' variance over 2N - 6 views -
/// parameters. Views with fewer than 6 corners are left out; !ok without at least two views.
SharedFit fitSharedWithPoses(const std::vector<CornerView>& views, const SharedModel& model, const Eigen::VectorXd& start,
                             const Eigen::VectorXd& step);

}  // namespace orbcal::vision
