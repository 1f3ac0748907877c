// orbcal diagnose on data whose hidden cause was drawn by the open-world generator (sim/open_world.hpp,
// written without the catalog's code): two catalog causes at once, coupled transmissions, 3rd and 4th
// harmonics, stiffening joints and bending links, on the SSRMS and the iiwa7, at signal-to-noise ratios
// 3 and 20 (seeded; at SNR 2 a bending link of the iiwa7 can read as a joint-2 angle error, see
// docs/diagnose.md). Required: the verdict is never clean; every cause the catalog now has is named on
// its joint (or link); the selected model's held-out position RMS is within 1.3 times the noise's in at
// least 80 % of the datasets; every dataset that ends above 1.5 times lists what is left unexplained.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>

#include "orbcal/calib/diagnose.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/open_world.hpp"

using namespace orbcal;

namespace {

/// Named: selected, or in a confounded set of a selected cause (the data cannot tell them apart, and
/// diagnose says so with the measurement that would).
bool named(const calib::Diagnosis& d, const std::string& kind, const std::vector<int>& joints) {
  const auto is = [&](const sim::Effect& e) { return e.name() == kind && e.joints() == joints; };
  if (std::any_of(d.selected.begin(), d.selected.end(), is)) return true;
  return std::any_of(d.confounded.begin(), d.confounded.end(),
                     [&](const calib::ConfoundedSet& c) { return std::any_of(c.effects.begin(), c.effects.end(), is); });
}

/// The generator numbers a bending body by the DH frame it starts at (frames[i+1] -> frames[i+2] of
/// chainFrames); in standard DH that body turns with joint i+1, which is how link_bending names it.
int bentJoint(const sim::Arm& arm, int generator_index) {
  return arm.convention == sim::DhConvention::kStandard || arm.convention == sim::DhConvention::kHayati ? generator_index + 1
                                                                                                        : generator_index;
}

/// The catalog's name for the generator's cause, on the right joints.
bool namesCause(const calib::Diagnosis& d, const sim::OpenWorldDataset& ds) {
  const sim::OpenCause& c = ds.truth.cause;
  switch (c.kind) {
    case sim::OpenCauseKind::kHarmonic3:
    case sim::OpenCauseKind::kHarmonic4: return named(d, "cyclic", {c.joint_a});
    case sim::OpenCauseKind::kCoupling: return named(d, "coupling", {c.joint_a, c.joint_b});
    case sim::OpenCauseKind::kStiffening: return named(d, "compliance", {c.joint_a});
    case sim::OpenCauseKind::kLinkBending: return named(d, "link_bending", {bentJoint(ds.data.arm, c.joint_a)});
    case sim::OpenCauseKind::kTwoCatalog: return named(d, "compliance", {c.joint_a}) && named(d, "cyclic", {c.joint_b});
  }
  return false;
}

struct Tally {
  int datasets = 0, within_1_3 = 0;
};

void diagnoseOpenWorld(const sim::Arm& arm, std::uint64_t first_seed, Tally& tally) {
  std::uint64_t seed = first_seed;
  for (const sim::OpenCauseKind kind : sim::openCauseKinds()) {
    for (const double snr : {3.0, 20.0}) {
      sim::OpenWorldSpec spec;
      spec.arm = arm;
      spec.cause = kind;
      spec.snr = snr;
      spec.seed = seed++;
      const sim::OpenWorldDataset ds = sim::generateOpenWorld(spec);
      const calib::Diagnosis d = calib::diagnose(ds.data, calib::observationsFrom(ds.data, true), {});
      const double ratio = d.heldout.selected.position_rms_m / d.heldout.noise_position_rms_m;
      std::string verdict;
      for (const sim::Effect& e : d.selected) verdict += sim::formatEffect(e) + " ";
      CAPTURE(sim::openCauseName(kind), ds.truth.cause.joint_a + 1, ds.truth.cause.joint_b + 1, snr, spec.seed, verdict, ratio,
              d.verdict);
      CHECK_FALSE(d.clean);
      CHECK(namesCause(d, ds));
      if (ratio > 1.5) {
        CHECK(d.unexplained);
        CHECK_FALSE(d.lack_of_fit.unexplained.empty());
      }
      ++tally.datasets;
      tally.within_1_3 += ratio <= 1.3 ? 1 : 0;
    }
  }
}

/// The SSRMS file has no masses: the generator's own assumption (100 kg per metre of link at its
/// middle, 2 kg of payload) given to the robot, so that both the data and the model know the loads.
sim::Arm ssrmsWithMasses() {
  sim::Arm arm = sim::loadArm("builtin:ssrms.yaml");
  const std::vector<Eigen::Isometry3d> frames = sim::chainFrames(arm, Eigen::VectorXd::Zero(arm.numJoints()));
  arm.masses.links.resize(static_cast<std::size_t>(arm.numJoints()));
  for (int j = 0; j < arm.numJoints(); ++j) {
    const Eigen::Vector3d span = frames[static_cast<std::size_t>(j) + 1].translation() - frames[static_cast<std::size_t>(j)].translation();
    arm.masses.links[static_cast<std::size_t>(j)].mass_kg = std::max(1.0, 100.0 * span.norm());
    arm.masses.links[static_cast<std::size_t>(j)].com_m =
        -0.5 * frames[static_cast<std::size_t>(j) + 1].linear().transpose() * span;  // the middle, in the link's frame
  }
  arm.masses.payload_kg = 2.0;
  return arm;
}

}  // namespace

// 80 % within 1.3 x the noise: the held-out RMS of a right model is the noise's plus the estimation
// variance of ~50 parameters from 160 of 200 samples (a few per cent), so a right model lands near 1.0-1.1;
// 1.3 leaves room for chance and a partial model must not pass.
TEST_CASE("diagnose on open-world data: never clean, the cause named, what is left listed (iiwa7)", "[calib][diagnose][open_world][slow]") {
  Tally t;
  diagnoseOpenWorld(sim::loadArm("builtin:iiwa7.yaml"), 101, t);
  CHECK(t.within_1_3 >= 0.8 * t.datasets);
}

TEST_CASE("diagnose on open-world data: never clean, the cause named, what is left listed (SSRMS)", "[calib][diagnose][open_world][slow]") {
  Tally t;
  diagnoseOpenWorld(ssrmsWithMasses(), 201, t);
  CHECK(t.within_1_3 >= 0.8 * t.datasets);
}
