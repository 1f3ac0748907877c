// The one split of measured samples (by configuration) and the held-out gain test (calib/heldout.hpp).
#include <catch2/catch.hpp>
#include <cmath>
#include <random>
#include <algorithm>
#include <optional>
#include <set>

#include "orbcal/calib/heldout.hpp"
#include "orbcal/sim/errors.hpp"

using namespace orbcal;
using calib::MarkerObservation;

namespace {

MarkerObservation at(const Eigen::VectorXd& q, int session = 0) {
  MarkerObservation o;
  o.sample.q_rad = q;
  o.sample.session = session;
  return o;
}

/// n distinct 7-joint configurations (seeded, spread over +-2 rad), each repeated `copies` times, the
/// copies interleaved as a file that repeats its rows would hold them.
std::vector<MarkerObservation> repeated(int n, int copies, std::uint64_t seed, int sessions = 1) {
  std::mt19937_64 rng = sim::makeRng(seed);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  std::vector<Eigen::VectorXd> qs;
  for (int k = 0; k < n; ++k) {
    Eigen::VectorXd q(7);
    for (int j = 0; j < 7; ++j) q[j] = u(rng);
    qs.push_back(q);
  }
  std::vector<MarkerObservation> obs;
  for (int c = 0; c < copies; ++c) {
    for (int k = 0; k < n; ++k) obs.push_back(at(qs[static_cast<std::size_t>(k)], k % sessions));
  }
  return obs;
}

/// P(T > t) for Student's t with `dof` degrees of freedom by Simpson's rule on its density over
/// [t, t + 200] (the tail beyond is below 1e-12 for dof >= 5): independent of the library's incomplete beta.
double studentTail(double t, double dof) {
  const double c = std::exp(std::lgamma(0.5 * (dof + 1.0)) - std::lgamma(0.5 * dof)) / std::sqrt(dof * M_PI);
  const auto f = [&](double x) { return c * std::pow(1.0 + x * x / dof, -0.5 * (dof + 1.0)); };
  const int n = 200000;
  const double h = 200.0 / n;
  double s = f(t) + f(t + 200.0);
  for (int i = 1; i < n; ++i) s += (i % 2 ? 4.0 : 2.0) * f(t + i * h);
  return s * h / 3.0;
}

}  // namespace

TEST_CASE("configurations: readings within 1e-6 rad are one, further apart or in another session are not", "[calib][heldout]") {
  Eigen::VectorXd q(3);
  q << 0.1, -0.2, 0.3;
  const Eigen::VectorXd e = Eigen::VectorXd::Unit(3, 2);
  std::vector<MarkerObservation> obs = {at(q), at(q + 0.6e-6 * e), at(q + 1.2e-6 * e), at(q + 5e-6 * e), at(q, 1), at(q)};
  const auto groups = calib::configurationGroups(obs);
  REQUIRE(groups.size() == 3);
  // 0, 1, 2 and 5 chain within 1e-6 (1 and 2 are 1.2e-6 from 0 but 0.6e-6 from 1); 3 is 5e-6 away; 4 is another session.
  std::set<std::vector<int>> members;
  for (const auto& [key, m] : groups) members.insert(m);
  CHECK(members == std::set<std::vector<int>>{{0, 1, 2, 5}, {3}, {4}});
  CHECK(calib::countConfigurations(obs) == 3);
}

TEST_CASE("splitByConfiguration: copies stay on one side, shares hold per session, equal shares deal round-robin", "[calib][heldout]") {
  const int n = 50;
  const std::vector<MarkerObservation> obs = repeated(n, 3, 5, 2);
  const std::vector<int> part = calib::splitByConfiguration(obs, {0.8, 0.2}, 1);
  REQUIRE(part.size() == obs.size());
  for (int k = 0; k < n; ++k) {
    CHECK(part[static_cast<std::size_t>(k)] == part[static_cast<std::size_t>(k + n)]);
    CHECK(part[static_cast<std::size_t>(k)] == part[static_cast<std::size_t>(k + 2 * n)]);
  }
  // 25 configurations per session: 20 % of them (5) held out in each, to one configuration.
  for (int s = 0; s < 2; ++s) {
    int held = 0;
    for (int k = 0; k < n; ++k) held += (k % 2 == s) && part[static_cast<std::size_t>(k)] == 1;
    CHECK(std::abs(held - 5) <= 1);
  }
  // Folds: sizes differ by at most one configuration; another seed deals differently; the same seed alike.
  const std::vector<int> folds = calib::splitByConfiguration(obs, std::vector<double>(5, 1.0), 3);
  std::vector<int> size(5, 0);
  for (int k = 0; k < n; ++k) ++size[static_cast<std::size_t>(folds[static_cast<std::size_t>(k)])];
  CHECK(*std::max_element(size.begin(), size.end()) - *std::min_element(size.begin(), size.end()) <= 1);
  CHECK(folds == calib::splitByConfiguration(obs, std::vector<double>(5, 1.0), 3));
  CHECK(folds != calib::splitByConfiguration(obs, std::vector<double>(5, 1.0), 4));
  CHECK_THROWS_AS(calib::splitByConfiguration(obs, {1.0, 0.0}, 1), std::invalid_argument);
}

TEST_CASE("heldoutGain: the paired one-sided test of per-configuration squared errors", "[calib][heldout]") {
  // Ten configurations whose loss differentials are d = 1, -1, 2, 0, 1, 1, 0, 2, 1, 3 (m^2): mean 1,
  // sum of squared deviations 12, so t = 1 / sqrt(12 / 9 / 10) = 2.7386 with 9 degrees of freedom.
  const std::vector<double> d = {1, -1, 2, 0, 1, 1, 0, 2, 1, 3};
  std::vector<MarkerObservation> obs = repeated(10, 2, 9);  // each configuration twice: losses are per configuration
  std::vector<Eigen::VectorXd> before, after;
  for (std::size_t k = 0; k < obs.size(); ++k) {
    const double dk = d[k % 10];
    before.push_back(Eigen::Vector3d(std::sqrt(10.0 + dk), 0.0, 0.0));
    after.push_back(Eigen::Vector3d(0.0, std::sqrt(10.0), 0.0));
  }
  const calib::HeldoutGain g = calib::heldoutGain(obs, before, after);
  CHECK(g.configurations == 10);
  CHECK(g.enough);
  CHECK(g.t == Approx(1.0 / std::sqrt(12.0 / 9.0 / 10.0)).epsilon(1e-12));
  CHECK(g.p_value == Approx(studentTail(g.t, 9.0)).epsilon(1e-6));
  // Student's one-sided 1 % point for 9 degrees of freedom is 2.821: t = 2.74 falls just short.
  CHECK(g.p_value > 0.01);
  CHECK_FALSE(g.significant);
  CHECK_THAT(calib::heldoutRefusal(g, 0.2, 50), Catch::Contains("not significant") && Catch::Contains("t = 2.74"));

  // The same differentials over 9 configurations: too few, whatever the gain.
  obs.resize(9);
  before.resize(9);
  after.resize(9);
  for (Eigen::VectorXd& b : before) b = Eigen::Vector3d(100.0, 0.0, 0.0);
  const calib::HeldoutGain few = calib::heldoutGain(obs, before, after);
  CHECK_FALSE(few.enough);
  CHECK(few.p_value < 1e-6);
  CHECK_FALSE(few.significant);
  CHECK_THAT(calib::heldoutRefusal(few, 0.2, 45), Catch::Contains("only 9 of the 45 configurations are held out") &&
                                                      Catch::Contains("at least 50 in all with --holdout 0.2"));
}

TEST_CASE("holdoutSplit: the default holds out 20 %, and the 10 configurations the test needs where as many are left",
          "[calib][heldout]") {
  // Configurations in all -> held out by default: 20 % of 15 is 3 (fewer than 10 are left to fit with
  // 10 out, so 20 % stays and the refusal says so); 20 and 40 hold out 10 (20 % would be 4 and 8); from
  // 50 on 20 % is already 10 or more.
  for (const auto& [n, expected] : std::vector<std::pair<int, int>>{{15, 3}, {19, 4}, {20, 10}, {39, 10}, {40, 10}, {50, 10}, {80, 16}}) {
    CAPTURE(n);
    const std::vector<MarkerObservation> obs = repeated(n, 2, 11);  // two rows per configuration: whole ones held out
    const std::vector<int> part = calib::holdoutSplit(obs, std::nullopt, 3);
    std::set<std::vector<double>> held;
    int rows = 0;
    for (std::size_t k = 0; k < obs.size(); ++k) {
      if (part[k] != 1) continue;
      held.insert(std::vector<double>(obs[k].sample.q_rad.data(), obs[k].sample.q_rad.data() + obs[k].sample.q_rad.size()));
      ++rows;
    }
    CHECK(static_cast<int>(held.size()) == expected);
    CHECK(rows == 2 * expected);
  }
  // A share given is taken as it is; 0 fits everything; outside [0, 1) is refused naming --holdout.
  const std::vector<int> half = calib::holdoutSplit(repeated(40, 1, 11), 0.5, 3);
  CHECK(std::count(half.begin(), half.end(), 1) == 20);
  const std::vector<int> none = calib::holdoutSplit(repeated(40, 1, 11), 0.0, 3);
  CHECK(std::count(none.begin(), none.end(), 1) == 0);
  CHECK_THROWS_WITH(calib::holdoutSplit(repeated(40, 1, 11), 1.0, 3), Catch::StartsWith("--holdout: "));
}

TEST_CASE("heldoutVerdict: worse, too few and not significant are refused, each in its own words", "[calib][heldout]") {
  const std::vector<MarkerObservation> obs = repeated(12, 1, 13);
  std::mt19937_64 rng = sim::makeRng(13);
  std::uniform_real_distribution<double> u(0.5, 1.5);
  std::vector<Eigen::VectorXd> small, large;
  for (std::size_t k = 0; k < obs.size(); ++k) {
    small.push_back(Eigen::Vector3d(1e-4 * u(rng), 0.0, 0.0));  // 0.1 mm
    large.push_back(Eigen::Vector3d(0.0, 1e-2 * u(rng), 0.0));  // 10 mm
  }
  // A gain of 100x on 12 configurations: accepted.
  const calib::HeldoutVerdict gain = calib::heldoutVerdict(obs, large, small, std::nullopt, 60);
  CHECK(gain.refusal.empty());
  CHECK_FALSE(gain.worse);
  CHECK(gain.gain.significant);
  // The same the other way round: worse, and said so.
  const calib::HeldoutVerdict worse = calib::heldoutVerdict(obs, small, large, std::nullopt, 60);
  CHECK(worse.worse);
  CHECK_THAT(worse.refusal, Catch::StartsWith("the calibrated model predicts the 12 held-out configurations worse than the nominal arm"));
  // Worse on 5 configurations says only that 5 are too few to tell, with the default's advice.
  const std::vector<MarkerObservation> five(obs.begin(), obs.begin() + 5);
  const calib::HeldoutVerdict few = calib::heldoutVerdict(five, std::vector<Eigen::VectorXd>(small.begin(), small.begin() + 5),
                                                          std::vector<Eigen::VectorXd>(large.begin(), large.begin() + 5), std::nullopt, 25);
  CHECK(few.worse);
  CHECK_THAT(few.refusal, Catch::StartsWith("only 5 of the 25 configurations are held out") &&
                              Catch::Contains("at least 20 in all: the default hold-out then keeps 10 of them out"));
}
