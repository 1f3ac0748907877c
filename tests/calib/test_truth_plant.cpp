// The validation plant and the floor of a true arm with effects (sim::TrueArm): the floor is the true
// model, effects included, and a plant without effects is the geometric one bit for bit.
#include <catch2/catch.hpp>

#include "orbcal/calib/experiment.hpp"
#include "orbcal/calib/validation.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/sim/truth.hpp"

using namespace orbcal;

namespace {

std::vector<Eigen::VectorXd> configs(const sim::Arm& arm, const sim::Scene& scene, int n, std::uint64_t seed) {
  sim::GeneratorSettings g;
  g.count = n;
  g.seed = seed;
  return sim::generateConfigurations(arm, scene, g);
}

/// Table 3 + a cyclic error of 0.05 deg on joint 2 (a1) and 0.02 deg (b2) + 0.03 deg of backlash on joint 3.
sim::TrueArm geared(const sim::Arm& nominal) {
  return sim::parseTrueArm(nominal, R"(format: orbcal-errors-1
geometry: table3
effects:
  - {spec: "cyclic:2", parameters: {cyclic2_sin1: 8.7266e-4, cyclic2_cos1: 0, cyclic2_sin2: 0, cyclic2_cos2: 3.4907e-4}}
  - {spec: "backlash:3", parameters: {b3: 5.236e-4}}
)", "geared.yaml");
}

}  // namespace

TEST_CASE("a plant without effects is the geometric plant, bit for bit, draws included", "[calib][truth]") {
  const sim::Arm nominal = sim::loadArm(sim::kDefaultRobot);
  const auto q = configs(nominal, sim::loadScene(sim::kDefaultScene), 30, 5);
  const Eigen::VectorXd y = sim::paperTable3Errors();
  auto rng_a = sim::makeRng(3), rng_b = sim::makeRng(3);
  const calib::PlantSamples a = calib::simulatePlant(sim::withErrors(nominal, y), q, 0.01 * sim::kDegToRad, rng_a);
  const calib::PlantSamples b = calib::simulatePlant(sim::geometricTrueArm(nominal, y), q, 0.01 * sim::kDegToRad, rng_b);
  REQUIRE(b.base_T_flange_true.size() == q.size());
  for (std::size_t k = 0; k < q.size(); ++k) {
    CHECK(a.q_true[k] == b.q_true[k]);
    CHECK(a.base_T_flange_true[k].matrix() == b.base_T_flange_true[k].matrix());
  }
  CHECK(rng_a() == rng_b());
  // The floor: the same numbers through either form.
  const calib::PoseErrors geometric = calib::poseErrors(sim::withErrors(nominal, y), a);
  const calib::PoseErrors through_truth = calib::poseErrors(sim::geometricTrueArm(nominal, y), a);
  CHECK(geometric.position_m == through_truth.position_m);
}

TEST_CASE("the floor of a plant with effects is its true model with the effects", "[calib][truth]") {
  const sim::Arm nominal = sim::loadArm(sim::kDefaultRobot);
  const sim::TrueArm truth = geared(nominal);
  const auto q = configs(nominal, sim::loadScene(sim::kDefaultScene), 40, 6);
  const sim::Arm geometric = sim::withErrors(nominal, truth.geometryErrors());

  // Without control noise the true model predicts the plant exactly; the DH errors alone do not.
  auto rng = sim::makeRng(4);
  const calib::PlantSamples exact = calib::simulatePlant(truth, q, 0.0, rng);
  REQUIRE(exact.commanded_samples.size() == q.size());
  const calib::ErrorSummary floor = calib::summarize(calib::poseErrors(truth, exact));
  const calib::ErrorSummary without = calib::summarize(calib::poseErrors(geometric, exact));
  CAPTURE(floor.position_avg_m, without.position_avg_m);
  CHECK(floor.position_max_m < 1e-9);
  CHECK(without.position_avg_m > 1e-3);  // 0.05 deg on joint 2 of the SSRMS: millimetres at the flange
  // Each true pose is the geometric arm at q + dq, by the formulas: the harmonics of q2, and b3 times
  // the direction joint 3 came from (none for the first sample).
  for (std::size_t k = 0; k < q.size(); ++k) {
    Eigen::VectorXd turned = q[k];
    turned[1] += 8.7266e-4 * std::sin(q[k][1]) + 3.4907e-4 * std::cos(2 * q[k][1]);
    if (k > 0) turned[2] += 5.236e-4 * (q[k][2] > q[k - 1][2] ? 1.0 : -1.0);
    CHECK((exact.base_T_flange_true[k].matrix() - sim::forwardKinematics(geometric, turned).matrix()).cwiseAbs().maxCoeff() < 1e-12);
  }

  // With control noise: compareMethods' floor is the true model's (below the geometric part's), and a
  // plant filtered to some samples keeps their covariates (revalidate).
  auto rng_noise = sim::makeRng(5);
  const calib::PlantSamples noisy = calib::simulatePlant(truth, q, 0.01 * sim::kDegToRad, rng_noise);
  const calib::Comparison c = calib::compareMethods(nominal, truth, {}, noisy, {});
  CHECK(c.floor.position_avg_m == calib::summarize(calib::poseErrors(truth, noisy)).position_avg_m);
  CHECK(c.floor.position_avg_m < 0.8 * calib::summarize(calib::poseErrors(geometric, noisy)).position_avg_m);
  calib::PlantSamples odd;
  for (std::size_t k = 1; k < q.size(); k += 2) {
    odd.q_commanded.push_back(exact.q_commanded[k]);
    odd.q_true.push_back(exact.q_true[k]);
    odd.base_T_flange_true.push_back(exact.base_T_flange_true[k]);
    odd.commanded_samples.push_back(exact.commanded_samples[k]);
  }
  CHECK(calib::revalidate(c, nominal, truth, odd).floor.position_max_m < 1e-9);
  // Without them, the filtered plant's directions would come from its own order: wrong.
  odd.commanded_samples.clear();
  CHECK(calib::revalidate(c, nominal, truth, odd).floor.position_max_m > 1e-4);
}
