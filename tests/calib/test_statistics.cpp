// The distributions and the multiple-testing control diagnose's tests rest on, against tabulated values.
#include <catch2/catch.hpp>

#include "orbcal/calib/diagnose.hpp"

using namespace orbcal::calib;

TEST_CASE("chi-square and F survival functions match statistical tables", "[statistics]") {
  // Chi-square critical values (any statistics table): P(X > x) = 0.05 and 0.01.
  CHECK(chiSquareSurvival(3.841459, 1) == Approx(0.05).epsilon(1e-5));
  CHECK(chiSquareSurvival(5.991465, 2) == Approx(0.05).epsilon(1e-5));
  CHECK(chiSquareSurvival(23.209251, 10) == Approx(0.01).epsilon(1e-5));
  CHECK(chiSquareSurvival(0.0, 3) == 1.0);
  // F critical values: F(1, 30) 4.170877 and F(4, 100) 2.462615 at 0.05; F(6, 1000) 2.818 at 0.01.
  CHECK(fSurvival(4.170877, 1, 30) == Approx(0.05).epsilon(1e-4));
  CHECK(fSurvival(2.462615, 4, 100) == Approx(0.05).epsilon(1e-4));
  CHECK(fSurvival(2.818, 6, 1000) == Approx(0.01).epsilon(5e-3));
  // F(d1, inf) -> chi-square(d1) / d1.
  CHECK(fSurvival(3.841459, 1, 1e7) == Approx(0.05).epsilon(1e-3));
}

TEST_CASE("Holm's step-down adjustment", "[statistics]") {
  // Hand-worked: sorted p (0.01, 0.02, 0.03, 0.04) x (4, 3, 2, 1) = (0.04, 0.06, 0.06, 0.04) -> monotone (0.04, 0.06, 0.06, 0.06).
  const std::vector<double> adj = holmAdjust({0.03, 0.01, 0.04, 0.02});
  CHECK(adj[1] == Approx(0.04));
  CHECK(adj[3] == Approx(0.06));
  CHECK(adj[0] == Approx(0.06));
  CHECK(adj[2] == Approx(0.06));
  CHECK(holmAdjust({0.5, 0.9})[1] == 1.0);
}

TEST_CASE("Student's t critical values match statistical tables", "[statistics]") {
  // Two-sided 95 % and 99 % critical values (t tables to 6 decimals).
  CHECK(studentTCritical(0.05, 1) == Approx(12.706205).epsilon(1e-5));
  CHECK(studentTCritical(0.05, 2) == Approx(4.302653).epsilon(1e-5));
  CHECK(studentTCritical(0.05, 10) == Approx(2.228139).epsilon(1e-5));
  CHECK(studentTCritical(0.05, 99) == Approx(1.984217).epsilon(1e-5));
  CHECK(studentTCritical(0.01, 20) == Approx(2.845340).epsilon(1e-5));
  CHECK(studentTCritical(0.05, 1e7) == Approx(1.959964).epsilon(1e-5));  // the normal's 1.96
}
