// What the corners say about the geometry the images were taken with (workflow/twin.hpp): a radial
// distortion the stated intrinsics lack, the bow of the printed sheet and its scale along x against y
// (a uniform scale moves no corner about a view's own pose), fitted together as parameters
// shared by all views with every view's pose refitted (vision/shared_fit.hpp), so that neither is
// read from what a view's own pose takes up.
#include <algorithm>
#include <cmath>

#include "orbcal/render/camera_profile.hpp"
#include "orbcal/workflow/twin.hpp"
#include "twin_detail.hpp"

namespace orbcal::workflow::twin_detail {

namespace {

std::vector<vision::CornerView> cornerViews(const std::vector<ViewStats>& views) {
  std::vector<vision::CornerView> out;
  for (const ViewStats& s : views) {
    if (s.found) out.push_back(s.corners_seen);
  }
  return out;
}

/// Standard error of f(p) from the fit's covariance (g^T C g, g by central differences).
double propagated(const std::function<double(const Eigen::VectorXd&)>& f, const vision::SharedFit& fit, const Eigen::VectorXd& step) {
  Eigen::VectorXd g(step.size());
  for (Eigen::Index j = 0; j < step.size(); ++j) {
    Eigen::VectorXd hi = fit.value, lo = fit.value;
    hi(j) += step(j);
    lo(j) -= step(j);
    g(j) = (f(hi) - f(lo)) / (2.0 * step(j));
  }
  return std::sqrt(std::max(0.0, g.dot(fit.covariance * g)));
}

Eigen::VectorXd steps() { return Eigen::Vector4d(kLensStep, kLensStep, kBowStepM, kScaleStep); }

}  // namespace

Eigen::VectorXd geometryOf(const render::CameraProfile& p) {
  return Eigen::Vector4d(p.lens.k1, p.lens.k2, p.board.bow_m, p.board.scale_x / p.board.scale_y - 1.0);
}

vision::CornerModel geometryModel(const sim::Camera& camera, const sim::Board& board, const Eigen::VectorXd& g) {
  render::CameraProfile p;
  p.lens = {g(0), g(1)};
  p.board.bow_m = g(2);
  p.board.scale_x = 1.0 + g(3);
  const render::BoardPrint print = p.board;
  return vision::CornerModel{render::profiledCamera(camera, p),
                             [board, print](int id) { return render::printedBoardPoint(board, print, sim::cornerInBoard(board, id).head<2>()); }};
}

vision::SharedFit fitGeometry(const sim::Camera& camera, const sim::Board& board, const std::vector<ViewStats>& views) {
  const vision::SharedModel model = [camera, board](const Eigen::VectorXd& g) { return geometryModel(camera, board, g); };
  return vision::fitSharedWithPoses(cornerViews(views), model, Eigen::Vector4d::Zero(), steps());
}

render::CameraProfile shownGeometry(const TwinComparison& c) {
  render::CameraProfile p;
  if (c.geometry.size() < 2 || !c.geometry[0].ok || !c.geometry[1].ok) return p;
  const vision::SharedFit &real = c.geometry[0], &twin = c.geometry[1];
  const Eigen::VectorXd d = real.value - twin.value;
  if (vision::differsSignificantly(lensShiftEstimate(c.camera, real), lensShiftEstimate(c.camera, twin))) p.lens = {d(0), d(1)};
  if (vision::differsSignificantly(bowEstimate(real), bowEstimate(twin))) p.board.bow_m = d(2);
  if (std::abs(d(3)) > 2.0 * std::sqrt(real.covariance(3, 3) + twin.covariance(3, 3))) p.board.scale_x = 1.0 + d(3);
  return p;
}

vision::Estimate lensShiftEstimate(const sim::Camera& camera, const vision::SharedFit& fit) {
  vision::Estimate e;
  if (!fit.ok) return e;
  const auto shift = [&](const Eigen::VectorXd& k) { return render::lensShiftAtImageCorner(camera, {k(0), k(1)}); };
  e.value = shift(fit.value);
  e.sigma = propagated(shift, fit, steps());
  e.n = fit.views;
  return e;
}

vision::Estimate bowEstimate(const vision::SharedFit& fit) {
  vision::Estimate e;
  if (!fit.ok) return e;
  e.value = fit.value(2) * 1e3;
  e.sigma = fit.sigma(2) * 1e3;
  e.n = fit.views;
  return e;
}

}  // namespace orbcal::workflow::twin_detail
