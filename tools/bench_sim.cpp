#include <thread>

#include "bench.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/jacobian.hpp"

namespace orbcal::tools {

namespace {
void benchSim() {
  const sim::Arm arm = sim::loadArm(sim::kDefaultRobot);
  const sim::Scene scene = sim::loadScene(sim::kDefaultScene);
  sim::GeneratorSettings gen;
  gen.count = 250;
  std::vector<Eigen::VectorXd> configs;
  const auto t_gen = timeRepeats(7, [&] {
    configs = sim::generateConfigurations(arm, scene, gen);
    ++gen.seed;
  });
  printFigure("generate 250 board-visible configurations (" + std::to_string(std::thread::hardware_concurrency()) +
                  " threads)",
              t_gen, "s ", 1.0, "< 1 s");
  // `orbcal render --shard i/N` plans the configurations up to its last sample: shard N-1 of a 20,000-view
  // dataset plans all 20,000 (what its 20,000 / N images must outweigh).
  sim::GeneratorSettings large;
  large.count = 20000;
  const auto t_large = timeRepeats(3, [&] { sim::generateConfigurations(arm, scene, large); });
  printFigure("generate 20,000 configurations (" + std::to_string(std::thread::hardware_concurrency()) +
                  " threads; the last shard's planning)",
              t_large, "s ", 1.0, "");
  sim::Matrix6Xd J(6, arm.numParams());
  double sink = 0.0;
  const auto t_jac = timeRepeats(9, [&] {
    for (int i = 0; i < 10000; ++i) {
      sim::identificationJacobian(arm, configs[i % configs.size()], sim::ErrorFrame::kTool, J);
      sink += J(0, 0);
    }
  });
  printFigure("10,000 identification Jacobians (6x28, tool frame)", t_jac, "ms", 1e3, "< 50 ms");
  if (sink == 0.123) std::printf(" ");  // keep the loop from being optimised away
}

}  // namespace

ORBCAL_BENCH("sim", benchSim);

}  // namespace orbcal::tools
