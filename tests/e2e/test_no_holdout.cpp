// Safeguards without a hold-out: with --holdout 0 no gain is measured, but a fit whose residuals are far
// above the least-squares fit's is refused all the same (exit 1, no model.yaml) unless --accept-worse,
// and a good fit is accepted.
#include <catch2/catch.hpp>
#include <filesystem>

#include "run_orbcal.hpp"
#include "test_util.hpp"

using namespace orbcal;
using Catch::Matchers::Contains;

TEST_CASE("calibrate --holdout 0: a fit far above the least-squares fit is refused unless --accept-worse",
          "[e2e][calibrate][holdout]") {
  const std::string dir = test::tempDir("no-holdout");
  // DH errors of 1 deg and 5 mm (1-sigma); the description states no noise, so it is estimated from the
  // residuals and no chi-square test can refuse the fit: the comparison with the least-squares fit must.
  REQUIRE(test::runOrbcal(dir, "simulate -o data -n 60 --sessions 1 --seed 6 --error-angle-deg 1 --error-length-mm 5 --quiet").status == 0);
  const std::string desc = dir + "/data/measurements.yaml";
  std::string text = test::slurp(desc);
  const auto noise = text.find("\nnoise:");
  REQUIRE(noise != std::string::npos);
  text.erase(noise + 1, text.find('\n', noise + 1) - noise);
  test::write(desc, text);

  // LM is the least-squares fit: accepted without a hold-out.
  const test::OrbcalRun lm = test::runOrbcal(dir, "calibrate data/measurements.yaml --holdout 0 -o cal-lm");
  CAPTURE(lm.err);
  CHECK(lm.status == 0);
  CHECK(std::filesystem::exists(dir + "/cal-lm/model.yaml"));

  // The EKF as Wang et al. (2023) wrote it (prior 0.01 deg / 0.01 mm, J at the nominal parameters) cannot
  // move the DH parameters by 1 deg and 5 mm: its fit stays near the nominal arm's residuals, 15 mm against LM's 0.08 mm.
  const test::OrbcalRun ekf = test::runOrbcal(dir, "calibrate data/measurements.yaml --method 'EKF (paper)' --holdout 0 -o cal-ekf");
  CHECK(ekf.status == 1);
  CHECK_THAT(ekf.err, Contains("the fit leaves a position RMS of") && Contains("model.yaml not written (--accept-worse writes it)"));
  CHECK_FALSE(std::filesystem::exists(dir + "/cal-ekf/model.yaml"));
  CHECK_THAT(test::slurp(dir + "/cal-ekf/report.md"), Contains("**The calibration is not accepted: the fit leaves"));

  const test::OrbcalRun accepted =
      test::runOrbcal(dir, "calibrate data/measurements.yaml --method 'EKF (paper)' --holdout 0 --accept-worse -o cal-ekf");
  CHECK(accepted.status == 0);
  CHECK(std::filesystem::exists(dir + "/cal-ekf/model.yaml"));
}
