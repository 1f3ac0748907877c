#pragma once
// The noise of a diagnosis (calib/src/diagnose_noise.cpp): the variance components estimated with a
// model flexible enough to take smooth structure, the floor a verdict is judged against and where its
// joint-reading noise comes from (diagnose.hpp's NoiseFloors), and rows that repeat another exactly.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "orbcal/calib/diagnose.hpp"

namespace orbcal::calib {

/// The fit of `effects` plus a flexible model of smooth structure, with the noise estimated as `options`
/// say: per moving joint its harmonics (cyclic, up to `max_degree`) and smooth functions of its own angle
/// and torque (empirical, degree up to 3), and every joint's reading off by a multiple of every other's
/// (coupling); the most flexible of a few levels whose free parameters stay within a quarter of the
/// rows of `obs`.
/// A seeded random `keep` of `obs` (std::sample with std::mt19937_64(seed), in their order); empty where
/// that is all of them or would leave out a session (its frames need its samples). The same seed and
/// size give the same subset: the noise's flexible fits and the selection share it.
std::vector<MarkerObservation> seededSubset(const std::vector<MarkerObservation>& obs, std::size_t keep, std::uint64_t seed);

struct FlexibleFit {
  Fit fit;
  int degree = 0;                        ///< its harmonics (0: none fits, the fit of `effects` alone)
  std::vector<MarkerObservation> subset;  ///< what it was fitted on where a seeded random subset of the input, else empty
  /// What it was fitted on: the subset, else `all` (the input).
  const std::vector<MarkerObservation>& fitted(const std::vector<MarkerObservation>& all) const { return subset.empty() ? all : subset; }
};
/// Fitted on a seeded random `max_obs` of `obs` where there are more (0: all of them), but never on fewer
/// than the most flexible level that all of `obs` allow needs: a subset estimates the noise less
/// precisely, never with less structure taken.
FlexibleFit flexibleFit(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs, const std::vector<sim::Effect>& effects,
                        const FitOptions& options, int max_degree, int max_obs, std::uint64_t seed);

/// The fit's own residuals still structured against a variable of the extended family (lack_of_fit.hpp),
/// whitened with its noise: what it estimated as noise may hold structure it could not take.
bool leavesStructure(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs, const Fit& fit, double alpha);

/// The noise the verdict's floor uses: the whitening tracker noise, and the joint noise of
/// NoiseFloors::joint_floor_rad.
MarkerNoise floorNoise(const NoiseFloors& n);

/// Sets joint_floor_rad and joint_source from what is stated, the repeats (`replicated` groups) and
/// the survived estimate.
void chooseJointFloor(NoiseFloors& n, int replicated);

/// Sets n's estimate_contradicted (and the sums it compares): under the tracker noise plus the estimated
/// joint noise, the held-out position residuals `residual` of `fit` have a whitened chi-square or a plain
/// mean square below its lower alpha/2 quantile. Call before chooseJointFloor.
void testEstimate(NoiseFloors& n, const Fit& fit, const std::vector<MarkerObservation>& obs,
                  const std::vector<Eigen::VectorXd>& residual, int folds, double alpha);

/// The floors with and without the estimated joint noise, and the joint noise at which the held-out
/// position residuals `residual` of `fit` would be noise.
void measureFloors(NoiseFloors& n, const Fit& fit, const std::vector<MarkerObservation>& obs,
                   const std::vector<Eigen::VectorXd>& residual, int folds);

/// `obs` without the rows that repeat an earlier row exactly (same session, point, readings and
/// measured pose: a copy carries no new measurement); source[i] is the kept row input row i maps to.
std::vector<MarkerObservation> dropExactDuplicates(const std::vector<MarkerObservation>& obs, std::vector<int>& source);

/// Back to one entry per input row after dropExactDuplicates (a copy shares its original's residuals);
/// the verdict counts the copies.
void expandRows(Diagnosis& out, const std::vector<int>& source, std::size_t rows);

/// The fit options of what is stated (description, else command line) and whether the joint noise is
/// estimated; sets n's tracker_stated, joint_stated, joint_estimated.
FitOptions statedFitOptions(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs, const DiagnoseOptions& o,
                            NoiseFloors& n);
/// The fit options every fit of the diagnosis whitens with: the stated noise, and what is not stated
/// estimated (variance components) by flexibleFit of geometry + registration + empirical corrections,
/// so that structure they can take is not counted as noise; sets n's whitening, components,
/// flexible_degree and (as a first survived estimate) joint_estimate_rad.
FitOptions whiteningFitOptions(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs, const DiagnoseOptions& o,
                               const FitOptions& stated, NoiseFloors& n);

/// NoiseFloors::with_selected: the tracker noise of a calibration of `selected` on all of `obs`, as
/// `orbcal calibrate` estimates it (the same fit: position and rotation variance components where the
/// noise is not given (`stated`: statedFitOptions'); joint readings as stated, else not modelled), its steps solved as diagnose's own
/// fits solve them (DiagnoseOptions::lean_fits: the normal equations summed per block of samples, where
/// calibrate takes a QR of the stacked Jacobian): the same minimum; on a seeded random subset of `obs`
/// where there are more than DiagnoseOptions::noise_observations (its size second, else 0). Empty where
/// nothing is selected, the noise is all stated (n's flags, statedFitOptions) or samples carry their
/// own covariance.
std::pair<std::optional<MarkerNoise>, int> noiseWithSelected(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs,
                                                             const std::vector<sim::Effect>& selected, const DiagnoseOptions& o,
                                                             const FitOptions& stated, const NoiseFloors& n);

/// The noise paragraph of the verdict where it depends on the noise: both floors, the joint noise the
/// residuals would need, and the plan that decides it. Empty where the verdict does not depend on it.
std::string noiseDependenceText(const Diagnosis& d);

/// The joint noise that survives the selected model with empirical corrections beside it (flexibleFit), the
/// floor the verdict is judged against (chooseJointFloor), the selected model's lack of fit against that
/// floor, both floors (measureFloors), and whether the verdict depends on a noise the data cannot tell.
void judgeAgainstFloor(const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs, const DiagnoseOptions& o,
                       const FitOptions& stated_options, int replicated, int folds, Diagnosis& out);

}  // namespace orbcal::calib
