// `orbcal calibrate <dataset>`: the parameter errors from a dataset's images and joint readings.
#include <cstdio>

#include "calibrate.hpp"
#include "cli.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::tools {

namespace {

void addCalibrateCommand(CLI::App& app) {
  auto o = std::make_shared<CalibrateOptions>();
  CLI::App* cmd = app.add_subcommand(
      "calibrate",
      "Identify the arm's parameter errors from a dataset (rendered or real images with joint readings) and write "
      "the calibrated robot file; the gain is measured on held-out samples");
  cmd->add_option("dataset", o->dataset, "dataset folder (layout: README, 'Dataset layout')")->required();
  cmd->add_option("--method", o->method, "estimator: EKF, IEKF, LM, LM (Huber), LSE (weighted), LSE (paper), EKF (paper), ...")
      ->capture_default_str();
  cmd->add_option_function<double>(
         "--joint-noise-deg", [o](double d) { o->joint_noise_sigma_rad = d * sim::kDegToRad; },
         "joint noise carried into R, 1 sigma [deg] (default: the manifest's, else 0.01)")
      ->check(CLI::Range(0.0, 10.0));
  cmd->add_option("--holdout", o->holdout, "fraction of the usable samples kept out for validation")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 0.9));
  cmd->add_option("--seed", o->seed, "seed of the hold-out draw")->capture_default_str();
  cmd->add_option("-o,--out", o->out, "output folder (default: <dataset>/calibration)");
  cmd->add_flag("--quiet", o->quiet, "no progress output");
  cmd->callback([o] {
    const CalibrateResult r = runCalibrate(*o);
    std::printf("%d images, %d usable: %d for identification, %d held out\n", r.images, r.usable, r.identification,
                r.held_out);
    if (r.held_out > 0) {
      std::printf("held-out average position error against the measured poses: %.3f mm -> %.3f mm (%.1f%%)\n",
                  r.before.position_avg_m * 1e3, r.after.position_avg_m * 1e3,
                  100.0 * calib::improvement(r.before.position_avg_m, r.after.position_avg_m));
    }
    if (r.has_truth) {
      std::printf("held-out average position error against the true poses: %.3f mm -> %.3f mm\n",
                  r.truth_before.position_avg_m * 1e3, r.truth_after.position_avg_m * 1e3);
    }
    std::printf("calibrated robot: %s\nreport: %s\n", r.robot_path.c_str(), r.report_path.c_str());
  });
}

}  // namespace

ORBCAL_COMMAND(45, addCalibrateCommand);

}  // namespace orbcal::tools
