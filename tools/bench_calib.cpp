#include <filesystem>

#include "bench.hpp"
#include "orbcal/workflow/experiment.hpp"
#include "orbcal/calib/estimators.hpp"
#include "orbcal/calib/observability.hpp"
#include "orbcal/calib/synthetic.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/io.hpp"

namespace orbcal::tools {

namespace {

void benchCalib() {
  const sim::Arm arm = sim::loadArm(sim::kDefaultRobot);
  const sim::Scene scene = sim::loadScene(sim::kDefaultScene);
  const Eigen::VectorXd y_true = sim::paperTable3Errors();
  sim::GeneratorSettings g;
  g.count = 50;
  const double joint_sigma = 0.01 * sim::kDegToRad;
  auto rng = sim::makeRng(1);
  const calib::PlantSamples plant =
      calib::simulatePlant(calib::calibratedArm(arm, y_true), sim::generateConfigurations(arm, scene, g), joint_sigma, rng);
  const auto obs = calib::syntheticObservations(plant, 0.1e-3, 0.01 * sim::kDegToRad, rng);
  calib::PoseNoiseModel noise;
  noise.joint_noise_sigma_rad = joint_sigma;
  const calib::MarkerPoseModel model = calib::poseModel(arm, obs, noise);
  // Each estimator times itself (Estimate::seconds: the estimation, not the final cost evaluation).
  const auto timed = [&](const std::string& name, auto run, int repeats, const std::string& target) {
    std::vector<double> t;
    for (int i = 0; i < repeats; ++i) t.push_back(run().seconds);
    std::sort(t.begin(), t.end());
    printFigure(name, t, "ms", 1e3, target);
  };
  calib::EkfOptions paper = calib::EkfOptions::paperLiteral();
  timed("EKF pass, 50 configurations, Jacobians included (paper)", [&] { return calib::runEkf(model, paper); }, 21, "< 1 ms");
  timed("EKF pass, 50 configurations (re-linearized, default)", [&] { return calib::runEkf(model, {}); }, 21, "< 1 ms");
  calib::LseOptions lse;
  lse.weighted = true;
  timed("LSE (weighted, Gauss-Newton to convergence), 50 configurations", [&] { return calib::runLse(model, lse); }, 11, "");
  timed("LM (Ceres), 50 configurations", [&] { return calib::runLm(model, {}); }, 11, "");

  // Pose selection: 50 of 1000 board-visible configurations by O3 (26 identifiable parameters).
  {
    sim::GeneratorSettings pg;
    pg.count = 1000;
    calib::PoseNoiseModel pn;
    pn.joint_noise_sigma_rad = joint_sigma;
    const calib::MarkerPoseModel pool = calib::posePlanningModel(arm, sim::generateConfigurations(arm, scene, pg), pn);
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(pool.numParams());
    const auto blocks = calib::observabilityBlocks(pool, zero, calib::unidentifiableToFix(pool, zero));
    std::vector<double> ts;
    for (int i = 0; i < 3; ++i) ts.push_back(calib::selectConfigurations(blocks, 50, {}).seconds);
    std::sort(ts.begin(), ts.end());
    printFigure("select 50 of 1000 configurations by O3 (greedy + DETMAX + exchanges, 26 parameters)", ts, "s ", 1.0, "< 10 s");
  }

  // The whole table4 preset: 50 + 200 images rendered (fresh folder), measured, 9 estimators, report.
  workflow::ExperimentOptions o;
  o.out = (std::filesystem::temp_directory_path() / "orbcal-bench-table4").string();
  o.quiet = true;
  o.plots = false;
  std::vector<double> t;
  for (int i = 0; i < 3; ++i) {
    std::filesystem::remove_all(o.out);
    t.push_back(workflow::runTable4(o).seconds);
  }
  std::sort(t.begin(), t.end());
  printFigure("table4 preset: 250 rendered 1280x1024 images, 9 estimators", t, "s ", 1.0, "< 60 s");
  std::filesystem::remove_all(o.out);
}

}  // namespace

ORBCAL_BENCH("calib", benchCalib);

}  // namespace orbcal::tools
