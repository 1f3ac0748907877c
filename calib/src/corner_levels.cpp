#include "orbcal/calib/corner_levels.hpp"

#include <algorithm>
#include <cmath>

#include "orbcal/calib/experiment.hpp"

namespace orbcal::calib {

namespace {

/// The pixel sigma the first round starts from; the second takes it from the first's residuals.
constexpr double kStartSigmaPx = 0.5;

std::vector<CornerObservation> subset(const std::vector<CornerObservation>& all, const std::vector<int>& which) {
  if (which.empty()) return all;
  std::vector<CornerObservation> out;
  for (int k : which) out.push_back(all.at(static_cast<std::size_t>(k)));
  return out;
}

}  // namespace

sim::KinematicModel handEyeChainModel(const sim::Arm& arm, const HandEyeFrames& frames) {
  return sim::makeKinematicModel(arm, 1, sim::FrameSharing::kShared, sim::FrameSharing::kShared, {frames.world_T_base},
                                 {frames.flange_T_marker}, {});
}

std::vector<CornerObservation> cornerObservations(const std::vector<HandEyeView>& views, const std::vector<sim::JointSample>& samples) {
  std::vector<CornerObservation> out;
  for (std::size_t k = 0; k < views.size(); ++k) out.push_back({samples.at(k), views[k].corners_px, views[k].ids});
  return out;
}

CornerLevelFit fitCornerLevel(const sim::KinematicModel& start, const sim::Camera& camera, const sim::Board& board,
                              sim::HandEyeSetup setup, const std::vector<CornerObservation>& observations, const FitOptions& options,
                              const std::vector<int>& which) {
  const std::vector<CornerObservation> obs = subset(observations, which);
  CornerLevelFit f;
  f.start = start;
  const int n = start.layout.size();
  CornerNoise noise;
  noise.sigma_px = kStartSigmaPx;
  for (int round = 0; round < 2; ++round) {
    const CornerMeasurementModel m(start, camera, board, obs, noise, {}, setup);
    FitControls controls = fitControls(options, m.layout(), Eigen::VectorXd::Zero(m.numParams()));
    for (int i = 0; i < 4; ++i) controls.hold.push_back(m.distortionOffset() + i);  // the lens: the camera file's
    std::sort(controls.hold.begin(), controls.hold.end());
    controls.covariance = options.analyze && round == 1;
    f.estimate = runMethod(findMethod(comparisonMethods(0.0), options.method, "method"), m, controls);
    f.p = f.estimate.y;
    f.rows = 0;
    for (int k = 0; k < m.numSamples(); ++k) f.rows += m.rows(k);
    const int free = m.numParams() - static_cast<int>(f.estimate.held.size());
    f.effective_parameters = options.map ? f.estimate.effective_parameters : free;
    const int dof = std::max(1, f.rows - static_cast<int>(std::lround(f.effective_parameters)));
    f.rms_px = cornerResidualRms(m, f.p);
    f.sigma_px = noise.sigma_px;
    // Variance component: the pixel sigma of the residuals (without the prior's share of the cost), rows over dof.
    if (round == 0) noise.sigma_px = std::max(1e-6, f.rms_px * std::sqrt(static_cast<double>(f.rows) / dof));
  }
  const sim::FoldedModel folded = sim::foldParameters(start, f.p.head(n));
  f.frames = {folded.model.world_T_base.front(), folded.model.flange_T_marker.front()};
  f.arm = folded.model.arm;
  return f;
}

ViewResidual cornerViewResidual(const CornerLevelFit& fit, const sim::Camera& camera, const sim::Board& board, sim::HandEyeSetup setup,
                                const CornerObservation& observation) {
  const Eigen::Isometry3d world_T_marker = sim::predictMarkerPose(fit.start, fit.p.head(fit.start.layout.size()), observation.sample);
  const Eigen::Isometry3d camera_T_board = setup == sim::HandEyeSetup::kEyeInHand ? world_T_marker.inverse() : world_T_marker;
  std::vector<int> ids = observation.ids;
  for (std::size_t n = ids.size(); n < observation.corners_px.size(); ++n) ids.push_back(static_cast<int>(n));
  return viewResidual(observation.corners_px, ids, camera_T_board, camera, board);
}

CornerLevelCrossValidation crossValidateCornerLevel(const std::vector<HandEyeView>& views, const std::vector<CornerObservation>& observations,
                                                    const sim::Arm& arm, const sim::Camera& camera, const sim::Board& board,
                                                    sim::HandEyeSetup setup, const Level& level, const FitOptions& options,
                                                    const HandEyeCrossValidation& frames_cv) {
  CornerLevelCrossValidation cv;
  cv.level = level;
  cv.heldout.resize(views.size());
  const std::vector<int> group = viewConfigurations(views);
  const int G = group.empty() ? 0 : *std::max_element(group.begin(), group.end()) + 1;
  std::vector<HandEyeFrames> refits(static_cast<std::size_t>(G));
  std::vector<Eigen::VectorXd> refit_p(static_cast<std::size_t>(G));
  FitOptions o = levelOptions(options, handEyeChainModel(arm, {}), level, "--level");
  o.analyze = false;
  const auto distance = [](const ViewResidual& r) { return Eigen::VectorXd::Constant(1, r.rms_m); };
  // Each fold starts from the frames level's refit without the same configuration, and writes only its own entries.
  const FoldPredictor predict = [&](const std::vector<int>& train, const std::vector<int>& held) {
    const auto g = static_cast<std::size_t>(group[static_cast<std::size_t>(held.front())]);
    const CornerLevelFit fit = fitCornerLevel(handEyeChainModel(arm, frames_cv.refits.at(g)), camera, board, setup, observations, o, train);
    FoldPrediction out;
    for (int k : held) {
      const auto i = static_cast<std::size_t>(k);
      cv.heldout[i] = cornerViewResidual(fit, camera, board, setup, observations[i]);
      out.before.push_back(distance(frames_cv.heldout.at(i)));
      out.after.push_back(distance(cv.heldout[i]));
    }
    refits[g] = fit.frames;
    refit_p[g] = fit.p;
    return out;
  };
  cv.verdict = crossValidatedVerdict(group, predict, "the frames level (the nominal arm)");
  if (G >= kMinHeldoutConfigurations) {
    cv.refits = refits;
    cv.refit_p = refit_p;
  }
  double s = 0.0;
  for (const ViewResidual& r : cv.heldout) s += r.rms_m * r.rms_m;
  cv.heldout_rms_m = cv.heldout.empty() ? 0.0 : std::sqrt(s / static_cast<double>(cv.heldout.size()));
  return cv;
}

Eigen::VectorXd jackknifeSigma(const std::vector<Eigen::VectorXd>& refits) {
  if (refits.size() < 2) return refits.empty() ? Eigen::VectorXd() : Eigen::VectorXd::Zero(refits.front().size());
  const auto G = static_cast<double>(refits.size());
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(refits.front().size());
  for (const Eigen::VectorXd& p : refits) mean += p / G;
  Eigen::VectorXd var = Eigen::VectorXd::Zero(mean.size());
  for (const Eigen::VectorXd& p : refits) var += (p - mean).cwiseAbs2();
  return (var * (G - 1.0) / G).cwiseSqrt();
}

}  // namespace orbcal::calib
