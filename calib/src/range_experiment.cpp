#include "orbcal/calib/range_experiment.hpp"

#include <chrono>
#include <cmath>
#include <stdexcept>
#include <tuple>

#include "orbcal/sim/errors.hpp"

namespace orbcal::calib {

namespace {

// Independent random streams of one seed.
constexpr std::uint64_t kCandidateStream = 0x6c69753163ULL;
constexpr std::uint64_t kNoiseStream = 0x6c6975316eULL;
constexpr std::uint64_t kValidationStream = 0x6c69753176ULL;

/// Case of `size` of the pool by O3: every subset when there are at most pool of them (size >= pool - 1),
/// else selectConfigurations.
std::pair<std::vector<int>, std::string> chooseByO3(const std::vector<Eigen::MatrixXd>& blocks, int size, std::uint64_t seed) {
  const int pool = static_cast<int>(blocks.size());
  std::vector<int> all(static_cast<std::size_t>(pool));
  for (int k = 0; k < pool; ++k) all[static_cast<std::size_t>(k)] = k;
  if (size == pool) return {all, "the whole pool"};
  if (size == pool - 1) {
    std::vector<int> best;
    double best_o3 = -1.0;
    for (int out = 0; out < pool; ++out) {
      std::vector<int> subset;
      for (int k = 0; k < pool; ++k) {
        if (k != out) subset.push_back(k);
      }
      const double o3 = observabilityIndices(stackBlocks(blocks, subset), size).o3;
      if (o3 > best_o3) {
        best_o3 = o3;
        best = subset;
      }
    }
    return {best, "largest O3 of all " + std::to_string(pool) + " subsets (each leaves one configuration out)"};
  }
  SelectionOptions options;
  options.index = ObservabilityIndex::kO3;
  options.seed = seed;
  return {selectConfigurations(blocks, size, options).chosen, "largest O3 found by greedy + DETMAX + pair exchanges"};
}

}  // namespace

RangeExperimentResult runRangeExperiment(const sim::Arm& nominal, const Eigen::VectorXd& p_true,
                                         const RangeExperimentSettings& settings, std::uint64_t seed) {
  const auto start = std::chrono::steady_clock::now();
  const sim::KinematicModel km = sim::flangeModel(nominal);
  const int kinematic = km.layout.size();
  const PlaneRangeModel probe(km, settings.beam, settings.plane, {});
  if (p_true.size() != probe.numParams()) throw std::invalid_argument("runRangeExperiment: p_true has the wrong size");
  if (settings.candidates < 1 || settings.validation < 1) throw std::invalid_argument("runRangeExperiment: no configurations");
  for (int n : settings.case_sizes) {
    if (n < 1 || n > settings.candidates) throw std::invalid_argument("runRangeExperiment: a case larger than the pool");
  }

  RangeExperimentResult result;
  for (int i = 0; i < probe.numParams(); ++i) result.names.push_back(probe.paramName(i));

  // The candidates (on the nominal model: what a planner knows) and their ranges.
  RangeConfigurationSettings cs = settings.configurations;
  cs.beam_must_hit = true;
  auto candidate_rng = sim::makeRng(seed, kCandidateStream);
  const std::vector<sim::JointSample> samples = rangeConfigurations(probe, {}, settings.candidates, candidate_rng, cs);
  auto noise_rng = sim::makeRng(seed, kNoiseStream);
  const std::vector<RangeObservation> observations =
      simulateRanges(probe, p_true, samples, settings.sigma_m, settings.repeats, noise_rng);
  const PlaneRangeModel pool(km, settings.beam, settings.plane, observations);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(pool.numParams());
  result.held = unidentifiableToFix(pool, zero);
  const std::vector<Eigen::MatrixXd> blocks = observabilityBlocks(pool, zero, result.held);
  result.pool_indices = observabilityIndices(stackBlocks(blocks), settings.candidates);
  result.rank = result.pool_indices.rank;

  // Validation: anywhere in the workspace, the true arm's poses.
  cs.beam_must_hit = false;
  auto validation_rng = sim::makeRng(seed, kValidationStream);
  PlantSamples plant;
  const sim::Arm true_arm = calibratedArm(nominal, p_true.head(kinematic));
  for (const sim::JointSample& s : rangeConfigurations(probe, {}, settings.validation, validation_rng, cs)) {
    plant.q_commanded.push_back(s.q_rad);
    plant.q_true.push_back(s.q_rad);
    plant.base_T_flange_true.push_back(sim::forwardKinematics(true_arm, s.q_rad));
  }
  result.nominal_errors = poseErrors(nominal, plant);
  result.nominal_validation = summarizeAxes(result.nominal_errors);

  for (int size : settings.case_sizes) {
    RangeCaseResult c;
    c.size = size;
    std::tie(c.chosen, c.selection) = chooseByO3(blocks, size, seed);
    c.indices = observabilityIndices(stackBlocks(blocks, c.chosen), size);
    c.random_o3 = size < settings.candidates ? meanRandomIndex(blocks, size, ObservabilityIndex::kO3, 20, seed) : c.indices.o3;
    std::vector<RangeObservation> chosen;
    for (int k : c.chosen) chosen.push_back(observations[static_cast<std::size_t>(k)]);
    const PlaneRangeModel model(km, settings.beam, settings.plane, chosen);
    LseOptions lse;
    lse.weighted = true;
    lse.hold = result.held;
    c.estimate = runLse(model, lse);
    c.plane_estimate = c.estimate.y.tail(c.estimate.y.size() - kinematic);
    for (int k = 0; k < model.numSamples(); ++k) {
      const double before = model.linearize(k, zero).innovation[0];
      const double after = model.linearize(k, c.estimate.y).innovation[0];
      c.residual_rms_before_m += before * before / size;
      c.residual_rms_after_m += after * after / size;
      c.residual_max_before_m = std::max(c.residual_max_before_m, std::abs(before));
      c.residual_max_after_m = std::max(c.residual_max_after_m, std::abs(after));
    }
    c.residual_rms_before_m = std::sqrt(c.residual_rms_before_m);
    c.residual_rms_after_m = std::sqrt(c.residual_rms_after_m);
    c.validation_errors = poseErrors(calibratedArm(nominal, c.estimate.y.head(kinematic)), plant);
    c.validation = summarizeAxes(c.validation_errors);
    result.cases.push_back(std::move(c));
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace orbcal::calib
