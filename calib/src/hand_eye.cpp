#include "orbcal/calib/hand_eye.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "orbcal/calib/registration.hpp"

namespace orbcal::calib {

namespace {

constexpr int kMaxIterations = 100;
constexpr double kStep = 1e-6;            ///< central differences: m and rad
constexpr double kRelativeTolerance = 1e-10;
constexpr double kSameTranslationM = 1e-6, kSameRotationRad = 1e-6;

HandEyeFrames applyStep(const HandEyeFrames& f, const Eigen::VectorXd& y) {
  return {sim::posePlus(f.world_T_base, y.head<6>()), sim::posePlus(f.flange_T_marker, y.segment<6>(6))};
}

/// The corner residuals of view `v` (2 per corner, detected - predicted, px).
void addResiduals(const HandEyeView& v, const HandEyeFrames& f, const sim::Camera& camera, const sim::Board& board,
                  sim::HandEyeSetup setup, std::vector<double>& out) {
  const Eigen::Isometry3d camera_T_board = predictedCameraTBoard(f, v.base_T_flange, setup);
  for (std::size_t n = 0; n < v.ids.size(); ++n) {
    const Eigen::Vector2d uv = sim::project(camera, camera_T_board * sim::cornerInBoard(board, v.ids[n]));
    out.push_back(v.corners_px[n].x() - uv.x());
    out.push_back(v.corners_px[n].y() - uv.y());
  }
}

Eigen::VectorXd residuals(const std::vector<HandEyeView>& views, const std::vector<int>& which, const HandEyeFrames& f,
                          const sim::Camera& camera, const sim::Board& board, sim::HandEyeSetup setup) {
  std::vector<double> out;
  for (int k : which) addResiduals(views[static_cast<std::size_t>(k)], f, camera, board, setup, out);
  return Eigen::Map<const Eigen::VectorXd>(out.data(), static_cast<Eigen::Index>(out.size()));
}

}  // namespace

Eigen::Isometry3d predictedCameraTBoard(const HandEyeFrames& frames, const Eigen::Isometry3d& base_T_flange, sim::HandEyeSetup setup) {
  const Eigen::Isometry3d world_T_marker = frames.world_T_base * base_T_flange * frames.flange_T_marker;
  return setup == sim::HandEyeSetup::kEyeInHand ? world_T_marker.inverse() : world_T_marker;
}

HandEyeFrames closedFormHandEye(const std::vector<HandEyeView>& views, sim::HandEyeSetup setup) {
  std::vector<Eigen::Isometry3d> world_T_marker, base_T_flange;
  for (const HandEyeView& v : views) {
    world_T_marker.push_back(setup == sim::HandEyeSetup::kEyeInHand ? v.camera_T_board.inverse() : v.camera_T_board);
    base_T_flange.push_back(v.base_T_flange);
  }
  const RegistrationGuess g = initialRegistration(world_T_marker, base_T_flange, true);
  return {g.world_T_base, g.flange_T_marker};
}

sim::Camera withLens(const sim::Camera& camera, const Eigen::Vector2d& lens_k) {
  sim::Camera c = camera;
  c.distortion[0] += lens_k[0];
  c.distortion[1] += lens_k[1];
  return c;
}

HandEyeFit fitHandEyeCorners(const std::vector<HandEyeView>& views, const sim::Camera& camera, const sim::Board& board,
                             sim::HandEyeSetup setup, const HandEyeFrames& start, const std::vector<int>& which_in, bool fit_lens) {
  std::vector<int> which = which_in;
  if (which.empty()) {
    for (std::size_t k = 0; k < views.size(); ++k) which.push_back(static_cast<int>(k));
  }
  HandEyeFit fit;
  fit.frames = start;
  fit.lens_fitted = fit_lens;
  const int P = fit_lens ? 14 : 12;  // the frames' 12 corrections, then k1 and k2
  // The frames and lens after step y (in the frames' corrections and the lens's k1, k2).
  const auto residualsAt = [&](const HandEyeFrames& f, const Eigen::Vector2d& k) {
    return residuals(views, which, f, withLens(camera, k), board, setup);
  };
  const auto lensAfter = [&](const Eigen::VectorXd& y) { return fit_lens ? Eigen::Vector2d(fit.lens_k + y.tail<2>()) : fit.lens_k; };
  Eigen::VectorXd r = residualsAt(fit.frames, fit.lens_k);
  double cost = r.squaredNorm(), lambda = 1e-3;
  for (fit.iterations = 0; fit.iterations < kMaxIterations; ++fit.iterations) {
    Eigen::MatrixXd J(r.size(), P);
    for (int j = 0; j < P; ++j) {
      Eigen::VectorXd y = Eigen::VectorXd::Zero(P);
      y[j] = kStep;
      const Eigen::VectorXd plus = residualsAt(applyStep(fit.frames, y), lensAfter(y));
      y[j] = -kStep;
      const Eigen::VectorXd minus = residualsAt(applyStep(fit.frames, y), lensAfter(y));
      J.col(j) = (plus - minus) / (2.0 * kStep);
    }
    const Eigen::MatrixXd JtJ = J.transpose() * J;
    const Eigen::VectorXd g = J.transpose() * r;
    bool improved = false;
    while (!improved && lambda < 1e12) {
      Eigen::MatrixXd A = JtJ;
      A.diagonal() += lambda * JtJ.diagonal().cwiseMax(1e-12);
      const Eigen::VectorXd y = -A.ldlt().solve(g);  // r = detected - predicted: J is d r / d y
      const HandEyeFrames trial = applyStep(fit.frames, y);
      const Eigen::Vector2d trial_lens = lensAfter(y);
      const Eigen::VectorXd rt = residualsAt(trial, trial_lens);
      const double ct = rt.squaredNorm();
      if (ct < cost) {
        const double gain = cost - ct;
        fit.frames = trial;
        fit.lens_k = trial_lens;
        r = rt;
        cost = ct;
        lambda = std::max(1e-12, lambda / 10.0);
        improved = true;
        if (gain <= kRelativeTolerance * cost) fit.converged = true;
      } else {
        lambda *= 10.0;
      }
    }
    if (!improved) fit.converged = true;  // no step lowers the cost: at the minimum to rounding
    if (fit.converged) break;
  }
  fit.corners = static_cast<int>(r.size() / 2);
  fit.rms_px = r.size() > 0 ? std::sqrt(cost / static_cast<double>(r.size())) : 0.0;
  return fit;
}

ViewResidual viewResidual(const HandEyeView& view, const HandEyeFrames& frames, const sim::Camera& camera, const sim::Board& board,
                          sim::HandEyeSetup setup) {
  return viewResidual(view.corners_px, view.ids, predictedCameraTBoard(frames, view.base_T_flange, setup), camera, board);
}

ViewResidual viewResidual(const std::vector<Eigen::Vector2d>& corners_px, const std::vector<int>& ids, const Eigen::Isometry3d& camera_T_board,
                          const sim::Camera& camera, const sim::Board& board) {
  ViewResidual out;
  if (ids.empty()) return out;
  const double focal = std::sqrt(camera.fx_px * camera.fy_px);
  double sse_px = 0.0, sse_m = 0.0;
  for (std::size_t n = 0; n < ids.size(); ++n) {
    const Eigen::Vector3d p = camera_T_board * sim::cornerInBoard(board, ids[n]);
    const double e2 = (corners_px[n] - sim::project(camera, p)).squaredNorm();
    sse_px += e2;
    sse_m += e2 * (p.z() / focal) * (p.z() / focal);
  }
  const auto N = static_cast<double>(ids.size());
  out.rms_px = std::sqrt(sse_px / (2.0 * N));
  out.rms_m = std::sqrt(sse_m / N);
  return out;
}

std::vector<int> viewConfigurations(const std::vector<HandEyeView>& views) {
  std::vector<int> id(views.size(), -1);
  int next = 0;
  for (std::size_t a = 0; a < views.size(); ++a) {
    if (id[a] >= 0) continue;
    id[a] = next;
    for (std::size_t b = a + 1; b < views.size(); ++b) {
      const sim::Vector6d d = sim::poseMinus(views[b].base_T_flange, views[a].base_T_flange);
      if (id[b] < 0 && d.head<3>().norm() <= kSameTranslationM && d.tail<3>().norm() <= kSameRotationRad) id[b] = next;
    }
    ++next;
  }
  return id;
}

HandEyeCrossValidation crossValidateHandEye(const std::vector<HandEyeView>& views, const sim::Camera& camera, const sim::Board& board,
                                            sim::HandEyeSetup setup, const HandEyeFit& full, const HandEyeCrossValidation* stated_lens) {
  HandEyeCrossValidation cv;
  cv.heldout.resize(views.size());
  cv.heldout_start.resize(views.size());
  const std::vector<int> group = viewConfigurations(views);
  cv.configurations = group.empty() ? 0 : *std::max_element(group.begin(), group.end()) + 1;
  std::vector<HandEyeFrames> refits(static_cast<std::size_t>(cv.configurations));
  std::vector<Eigen::Vector2d> refit_lens(static_cast<std::size_t>(cv.configurations), Eigen::Vector2d::Zero());
  const auto distance = [](const ViewResidual& r) { return Eigen::VectorXd::Constant(1, r.rms_m); };
  // Each fold writes only its own views' and configuration's entries: the folds run in parallel.
  const FoldPredictor predict = [&](const std::vector<int>& train, const std::vector<int>& held) {
    std::vector<HandEyeView> fitted;
    for (int k : train) fitted.push_back(views[static_cast<std::size_t>(k)]);
    // Where the closed form fails on the fold's views (degenerate without the one held out), the full fit stands in
    // for it: a reference that saw the view held out only makes the corner fit's gain harder to show.
    // With the lens fitted, the fold starts from the stated lens's fold fit of the same configuration.
    const auto g = static_cast<std::size_t>(group[static_cast<std::size_t>(held.front())]);
    HandEyeFrames start = stated_lens ? stated_lens->refits.at(g) : full.frames;
    if (!stated_lens) {
      try {
        start = closedFormHandEye(fitted, setup);
      } catch (const std::invalid_argument&) {
      }
    }
    const HandEyeFit fold = fitHandEyeCorners(views, camera, board, setup, start, train, full.lens_fitted);
    FoldPrediction out;
    for (int k : held) {
      const auto i = static_cast<std::size_t>(k);
      cv.heldout_start[i] = stated_lens ? stated_lens->heldout.at(i) : viewResidual(views[i], start, camera, board, setup);
      cv.heldout[i] = viewResidual(views[i], fold.frames, withLens(camera, fold.lens_k), board, setup);
      out.before.push_back(distance(cv.heldout_start[i]));
      out.after.push_back(distance(cv.heldout[i]));
    }
    refits[g] = fold.frames;
    refit_lens[g] = fold.lens_k;
    return out;
  };
  cv.verdict = crossValidatedVerdict(group, predict, stated_lens ? "the stated lens" : "the closed form (each view's own board pose)");
  if (cv.configurations >= kMinHeldoutConfigurations) {  // the folds ran
    cv.refits = refits;
    cv.refit_lens = refit_lens;
  }
  return cv;
}

sim::Vector6d jackknifeSigma(const std::vector<Eigen::Isometry3d>& refits, const Eigen::Isometry3d& full) {
  sim::Vector6d var = sim::Vector6d::Zero();
  const auto G = static_cast<double>(refits.size());
  if (refits.size() < 2) return var;
  std::vector<sim::Vector6d> d;
  sim::Vector6d mean = sim::Vector6d::Zero();
  for (const Eigen::Isometry3d& T : refits) {
    sim::Vector6d e;
    e << T.translation() - full.translation(), sim::logSO3(T.linear() * full.linear().transpose());
    d.push_back(e);
    mean += e / G;
  }
  for (const sim::Vector6d& e : d) var += (e - mean).cwiseAbs2();
  return (var * (G - 1.0) / G).cwiseSqrt();
}

}  // namespace orbcal::calib
