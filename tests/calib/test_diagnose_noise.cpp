// The noise a diagnosis judges against (calib/diagnose.hpp, NoiseFloors): joint-reading noise enters the
// verdict's floor only from a source independent of the residuals judged (stated, repeats, or an
// estimate that survives empirical corrections), so that unmodelled structure cannot hide in it; the
// variance components come with their uncertainty; rows repeated exactly do not change a verdict; and
// a verdict that depends on an unmeasured noise says so, with the plan that decides it. Seeded data with
// a known truth: open-world datasets (sim/open_world.hpp) and the measured-data simulator.
#include <catch2/catch.hpp>
#include <numeric>
#include <algorithm>
#include <cmath>
#include <vector>

#include "orbcal/calib/diagnose.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/open_world.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/sim/simulate.hpp"

using namespace orbcal;

namespace {

/// An open-world iiwa7 dataset, the tracker's noise stated and the joint readings' not.
sim::OpenWorldDataset unstatedJointNoise(sim::OpenCauseKind kind, double snr, double joint_noise_deg, std::uint64_t seed,
                                         int samples = 150) {
  sim::OpenWorldSpec spec;
  spec.arm = sim::loadArm("builtin:iiwa7.yaml");
  spec.cause = kind;
  spec.snr = snr;
  spec.samples = samples;
  spec.noise_joint_rad = joint_noise_deg * sim::kDegToRad;
  spec.seed = seed;
  sim::OpenWorldDataset ds = sim::generateOpenWorld(spec);
  ds.data.noise_joint_rad.reset();
  return ds;
}

/// The held-out position RMS the true noise gives the selected model (tracker + the truth's joint noise
/// through its joint Jacobian).
double trueFloor(const calib::Diagnosis& d, const std::vector<calib::MarkerObservation>& obs, double joint_noise_deg) {
  calib::MarkerNoise truth = d.noise.whitening;
  truth.sigma_position_m = sim::OpenWorldSpec{}.noise_position_m;
  truth.sigma_rotation_rad = sim::OpenWorldSpec{}.noise_rotation_rad;
  truth.joint_noise_sigma_rad = joint_noise_deg * sim::kDegToRad;
  return std::sqrt(calib::heldoutNoise(d.fit, obs, truth, d.residual_selected, 5).position_ms_m2);
}

std::string selectedText(const calib::Diagnosis& d) {
  std::string s;
  for (const sim::Effect& e : d.selected) s += sim::formatEffect(e) + " ";
  return s;
}

}  // namespace

// (b) No joint noise in the truth, none stated: the floor the verdict uses holds none the fits made up,
// no `effects` or `clean` verdict stands while the held-out RMS is above 1.5x the true floor, and every
// `unexplained` names its floor and where it came from.
namespace {

calib::Diagnosis checkFloorHonest(sim::OpenCauseKind kind, std::uint64_t seed, int samples = 150) {
  const sim::OpenWorldDataset ds = unstatedJointNoise(kind, 20.0, 0.0, seed, samples);
  const std::vector<calib::MarkerObservation> obs = calib::observationsFrom(ds.data, true);
  const calib::Diagnosis d = calib::diagnose(ds.data, obs, {});
  const double floor = trueFloor(d, obs, 0.0);
  const double ratio = d.heldout.selected.position_rms_m / floor;
  CAPTURE(sim::openCauseName(kind), selectedText(d), ratio, d.lack_of_fit.noise_position_rms_m / floor, d.noise.joint_source,
          d.noise.joint_estimate_rad * sim::kRadToDeg, d.verdict);
  if (ratio > 1.5) CHECK(d.unexplained);
  if (d.unexplained) {
    CHECK(d.verdict.find(sim::formatNumber("%.3g", d.lack_of_fit.noise_position_rms_m * 1e3) + " mm") != std::string::npos);
    CHECK((d.verdict.find("stated tracker noise") != std::string::npos || d.verdict.find("the stated noise") != std::string::npos));
  }
  return d;
}

}  // namespace

TEST_CASE("diagnose: an unstated joint noise cannot hide structure in the floor", "[calib][diagnose][noise]") {
  checkFloorHonest(sim::OpenCauseKind::kCoupling, 12);
  checkFloorHonest(sim::OpenCauseKind::kHarmonic4, 13);
  // A bending link, which the flexible model takes with every link's bending (the iiwa7 has masses):
  // before it did, a 0.0095 deg estimate survived and lifted the floor to 1.48x the true one.
  checkFloorHonest(sim::OpenCauseKind::kLinkBending, 11);
}

// A bending the catalog's cantilever does not follow exactly (sim/open_world.hpp bends the link by its
// end load alone): what is left, mostly in the marker's rotation, inflates the joint-noise estimate
// (0.032 deg, where the truth has none) beyond what the held-out positions show (0.30 mm RMS against
// the 0.6 mm it would give). The estimate is refused by the positions, not counted, and the verdict
// says so and is judged against the stated tracker noise.
TEST_CASE("diagnose: an estimate the held-out positions contradict stays out of the floor", "[calib][diagnose][noise]") {
  const calib::Diagnosis d = checkFloorHonest(sim::OpenCauseKind::kLinkBending, 1, 200);
  CHECK(d.noise.estimate_contradicted);
  CHECK(d.noise.joint_source == "unstated");
  CHECK(d.noise.estimate_ms_m2 < d.noise.estimate_ms_expected_m2);
  CHECK(d.unexplained);
  CHECK(d.verdict.find("contradicted by the held-out positions") != std::string::npos);
}

// (c) Joint noise in the truth, unstated: its level recovered within a factor 2 (it survives the
// empirical corrections), in the floor, and no false `unexplained`.
TEST_CASE("diagnose: an unstated joint noise that is there is recovered and counted", "[calib][diagnose][noise]") {
  std::uint64_t seed = 21;
  const double truth_deg = 0.005;
  for (const sim::OpenCauseKind kind : {sim::OpenCauseKind::kStiffening, sim::OpenCauseKind::kTwoCatalog}) {
    const sim::OpenWorldDataset ds = unstatedJointNoise(kind, 20.0, truth_deg, seed++);
    const std::vector<calib::MarkerObservation> obs = calib::observationsFrom(ds.data, true);
    const calib::Diagnosis d = calib::diagnose(ds.data, obs, {});
    const double ratio = d.heldout.selected.position_rms_m / trueFloor(d, obs, truth_deg);
    const double estimate_deg = d.noise.joint_estimate_rad * sim::kRadToDeg;
    CAPTURE(sim::openCauseName(kind), selectedText(d), ratio, estimate_deg, d.noise.joint_source, d.verdict);
    CHECK(estimate_deg > 0.5 * truth_deg);
    CHECK(estimate_deg < 2.0 * truth_deg);
    CHECK(d.noise.joint_source == "survives");
    CHECK_FALSE(d.noise.estimate_contradicted);
    if (ratio < 1.2) CHECK_FALSE(d.unexplained);
  }
}

// A long log's noise from a seeded random subset of its observations (DiagnoseOptions::noise_observations):
// the subset's joint-noise estimate is the truth's within the factor 2 of (c), agrees with the estimate
// from every observation within 3 of its own 1-sigma (the subset's estimate varies about the full one by
// at most that), and the selection and verdict are the same. A subset too small for the flexible model
// that every observation allows is enlarged to what it needs: fitted on 50 observations its most flexible
// level would not fit, and a less flexible one took the hidden stiffening for joint noise (0.028 deg
// against the true 0.005 deg). The noise a calibration of the selected effects would estimate is
// estimated on a subset of the same size.
TEST_CASE("diagnose: the noise estimated on a random subset of a long log", "[calib][diagnose][noise]") {
  const double truth_deg = 0.005;
  const sim::OpenWorldDataset ds = unstatedJointNoise(sim::OpenCauseKind::kStiffening, 20.0, truth_deg, 41, 600);
  const std::vector<calib::MarkerObservation> obs = calib::observationsFrom(ds.data, true);
  calib::DiagnoseOptions all, subset;
  all.noise_observations = 0;
  subset.noise_observations = 200;
  const calib::Diagnosis full = calib::diagnose(ds.data, obs, all);
  const calib::Diagnosis part = calib::diagnose(ds.data, obs, subset);
  const double full_deg = full.noise.joint_estimate_rad * sim::kRadToDeg, part_deg = part.noise.joint_estimate_rad * sim::kRadToDeg;
  const double part_sd_deg = part.noise.survived.sigmaSd(2) * sim::kRadToDeg;
  CAPTURE(full_deg, part_deg, part_sd_deg, selectedText(full), selectedText(part), full.verdict, part.verdict);
  CHECK(full.noise.noise_observations == 0);
  CHECK(part.noise.noise_observations == 200);
  CHECK(part_deg > 0.5 * truth_deg);
  CHECK(part_deg < 2.0 * truth_deg);
  CHECK(part_sd_deg > 0.0);
  CHECK(std::abs(part_deg - full_deg) < 3.0 * part_sd_deg);
  CHECK(selectedText(part) == selectedText(full));
  CHECK(part.unexplained == full.unexplained);
  CHECK(part.noise.flexible_degree == full.noise.flexible_degree);
  // The noise a calibration of the selection would estimate (the report's), on the same subset's size.
  REQUIRE(full.noise.with_selected.has_value());
  REQUIRE(part.noise.with_selected.has_value());
  CHECK(full.noise.with_selected_observations == 0);
  CHECK(part.noise.with_selected_observations == 200);
  CHECK(part.noise.with_selected->sigma_position_m == Approx(full.noise.with_selected->sigma_position_m).epsilon(0.2));
  calib::DiagnoseOptions tiny;
  tiny.noise_observations = 50;
  const calib::Diagnosis small = calib::diagnose(ds.data, obs, tiny);
  CAPTURE(small.noise.noise_observations, small.noise.joint_estimate_rad * sim::kRadToDeg);
  CHECK(small.noise.noise_observations > 50);
  CHECK(small.noise.noise_observations < 600);
  CHECK(small.noise.flexible_degree == full.noise.flexible_degree);
  CHECK(small.noise.joint_estimate_rad * sim::kRadToDeg < 2.0 * truth_deg);
}

// A long log's selection on a seeded random subset (DiagnoseOptions::selection_observations): a hidden
// stiffening drawn with a seed is selected from 250 of 600 observations as from all of them, the selected
// model is then fitted and cross-validated on all 600 (its held-out residuals are every observation's,
// and its held-out SSE is the one the selection on every observation reaches: the same model, the same
// folds), and the verdict is the same.
TEST_CASE("diagnose: the effects selected on a random subset of a long log", "[calib][diagnose][noise]") {
  const sim::OpenWorldDataset ds = unstatedJointNoise(sim::OpenCauseKind::kStiffening, 20.0, 0.005, 41, 600);
  const std::vector<calib::MarkerObservation> obs = calib::observationsFrom(ds.data, true);
  calib::DiagnoseOptions all, subset;
  all.selection_observations = 0;
  subset.selection_observations = 250;
  const calib::Diagnosis full = calib::diagnose(ds.data, obs, all);
  const calib::Diagnosis part = calib::diagnose(ds.data, obs, subset);
  CAPTURE(selectedText(full), selectedText(part), full.verdict, part.verdict, full.cv_selected, part.cv_selected);
  CHECK(full.selection_observations == 0);
  CHECK(part.selection_observations == 250);
  CHECK_FALSE(full.selected.empty());
  CHECK(selectedText(part) == selectedText(full));
  CHECK(part.unexplained == full.unexplained);
  CHECK(part.residual_selected.size() == obs.size());
  CHECK(std::abs(part.cv_selected - full.cv_selected) < 1e-3 * full.cv_selected);
  CHECK(part.fit.residuals.position_rms_m == Approx(full.fit.residuals.position_rms_m).epsilon(1e-6));
}

// The registration check that refuses data no real arm gives runs on the selection's random subset of a
// long log: millimetres read as metres (every measured position 1000x too far) are refused as before, with
// the check's one-line message, whatever the subset.
TEST_CASE("diagnose: a long log in the wrong length unit is refused on the selection's subset", "[calib][diagnose][noise]") {
  const sim::OpenWorldDataset ds = unstatedJointNoise(sim::OpenCauseKind::kStiffening, 20.0, 0.005, 41, 600);
  sim::MeasuredData millimetres = ds.data;
  for (sim::MeasuredPose& p : millimetres.poses) p.world_T_marker.translation() *= 1000.0;
  calib::DiagnoseOptions subset;
  subset.selection_observations = 250;
  const std::vector<calib::MarkerObservation> obs = calib::observationsFrom(millimetres, true);
  REQUIRE(obs.size() > 250);
  CHECK_THROWS_AS(calib::diagnose(millimetres, obs, subset), sim::InputError);
  CHECK_THROWS_WITH(calib::diagnose(millimetres, obs, subset), Catch::Contains("the nominal arm's registration residual is"));
}

// Every row three times, exactly: a copy is no new measurement, and the verdict stays what it was.
TEST_CASE("diagnose: rows repeated exactly do not change the verdict", "[calib][diagnose][noise]") {
  const sim::OpenWorldDataset ds = unstatedJointNoise(sim::OpenCauseKind::kStiffening, 20.0, 0.003, 31, 100);
  sim::MeasuredData tripled = ds.data;
  tripled.poses.clear();
  for (const sim::MeasuredPose& p : ds.data.poses) tripled.poses.insert(tripled.poses.end(), 3, p);
  // The run also tells its phases, in order, each once, then its end (DiagnoseOptions::progress).
  calib::DiagnoseOptions told;
  std::vector<int> phases;
  told.progress = [&phases](int done, int total) {
    CHECK(total == static_cast<int>(calib::kDiagnosePhases.size()));
    phases.push_back(done);
  };
  const calib::Diagnosis once = calib::diagnose(ds.data, calib::observationsFrom(ds.data, true), told);
  std::vector<int> in_order(calib::kDiagnosePhases.size() + 1);  // 0, 1, ..., then the end (= the count)
  std::iota(in_order.begin(), in_order.end(), 0);
  CHECK(phases == in_order);
  const calib::Diagnosis thrice = calib::diagnose(tripled, calib::observationsFrom(tripled, true), {});
  CAPTURE(selectedText(once), selectedText(thrice), once.verdict, thrice.verdict);
  CHECK(selectedText(once) == selectedText(thrice));
  CHECK(once.unexplained == thrice.unexplained);
  CHECK(once.clean == thrice.clean);
  CHECK(thrice.noise.duplicates_dropped == 2 * static_cast<int>(ds.data.poses.size()));
  REQUIRE(thrice.residual_selected.size() == tripled.poses.size());
  CHECK((thrice.residual_selected[2] - once.residual_selected[0]).norm() < 1e-12);
}

// Repeated configurations measured anew (fresh tracker and joint noise), joint noise unstated: the
// floor comes from their scatter (pure error), and it is the truth's.
TEST_CASE("diagnose: repeated configurations give the floor", "[calib][diagnose][noise]") {
  sim::OpenWorldSpec spec;
  spec.arm = sim::loadArm("builtin:iiwa7.yaml");
  spec.cause = sim::OpenCauseKind::kStiffening;
  spec.snr = 20.0;
  spec.samples = 60;
  spec.repeats = 3;
  spec.noise_joint_rad = 0.004 * sim::kDegToRad;
  spec.seed = 41;
  sim::OpenWorldDataset ds = sim::generateOpenWorld(spec);
  ds.data.noise_joint_rad.reset();
  const std::vector<calib::MarkerObservation> obs = calib::observationsFrom(ds.data, true);
  const calib::Diagnosis d = calib::diagnose(ds.data, obs, {});
  const double floor = trueFloor(d, obs, 0.004);
  CAPTURE(selectedText(d), d.lack_of_fit.noise_position_rms_m / floor, d.verdict);
  CHECK(d.lack_of_fit.source == calib::NoiseSource::kPureError);
  CHECK(d.noise.joint_source == "pure error");
  CHECK(d.lack_of_fit.noise_position_rms_m > 0.8 * floor);
  CHECK(d.lack_of_fit.noise_position_rms_m < 1.25 * floor);
  if (d.heldout.selected.position_rms_m < 1.2 * floor) CHECK_FALSE(d.unexplained);
}

// A new user's simulation with no noise stated at all (joint-2 compliance; tracker 0.02 mm, 0.005 deg;
// joints 0.002 deg): the cause named without a false alarm, the components reported with intervals that
// hold the truth, and the verdict says it depends on the noise and how to decide it.
TEST_CASE("diagnose: no noise stated: the cause, the components with their uncertainty, the plan", "[calib][diagnose][noise]") {
  sim::SimulationSpec s;
  s.samples = 150;
  s.seed = 5;
  s.marker = sim::FrameSharing::kShared;
  s.payload_kg = {2.0};
  s.noise_position_m = 0.02e-3;
  s.noise_rotation_rad = 0.005 * sim::kDegToRad;
  s.joint_noise_rad = 0.002 * sim::kDegToRad;
  const sim::Arm arm = sim::loadArm("builtin:iiwa7.yaml");
  s.effects.push_back(sim::parseEffect("compliance:2", arm.numJoints(), "test"));
  sim::SimulatedData sd = sim::simulateMeasured(arm, s);
  sd.data.noise_position_m.reset();
  sd.data.noise_rotation_rad.reset();
  sd.data.noise_joint_rad.reset();
  const calib::Diagnosis d = calib::diagnose(sd.data, calib::observationsFrom(sd.data, true), {});
  const calib::NoiseComponents& c = d.noise.survived;
  CAPTURE(selectedText(d), d.verdict, d.noise.whitening.sigma_position_m, d.noise.whitening.sigma_rotation_rad * sim::kRadToDeg,
          d.noise.joint_estimate_rad * sim::kRadToDeg);
  CHECK(std::any_of(d.selected.begin(), d.selected.end(), [](const sim::Effect& e) { return sim::formatEffect(e) == "compliance:2"; }));
  CHECK_FALSE(d.unexplained);
  CHECK(d.noise.verdict_depends_on_noise);
  CHECK(d.verdict.find("--repeat") != std::string::npos);
  // Each component: within a factor 2 of the truth, or its reported 2-sigma interval holds it.
  const double truth[3] = {s.noise_position_m, s.noise_rotation_rad, s.joint_noise_rad};
  for (int k = 0; k < 3; ++k) {
    REQUIRE(c.estimated[static_cast<std::size_t>(k)]);
    const double sigma = std::sqrt(std::max(0.0, c.variance[k]));
    const double sd = std::sqrt(c.covariance(k, k));
    CAPTURE(k, sigma, sd, truth[k]);
    const bool within = sigma > 0.5 * truth[k] && sigma < 2.0 * truth[k];
    const bool interval = std::abs(c.variance[k] - truth[k] * truth[k]) < 2.0 * sd;
    CHECK((within || interval));
  }
}
