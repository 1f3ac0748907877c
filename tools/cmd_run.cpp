// `orbcal run`: the main job on the built-in default arm and scene (or given ones).
#include <cstdio>
#include <iostream>

#include "cli.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/identifiability.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "progress.hpp"

namespace orbcal::tools {

namespace {
void addRunCommand(CLI::App& app) {
  struct Opts {
    ArmSceneOptions as;
    sim::GeneratorSettings gen;
    std::string out = "orbcal-out";
  };
  auto opt = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand(
      "run", "The main job: arm, board-visible configuration set and its identifiability report");
  addArmSceneOptions(*cmd, opt->as);
  cmd->add_option("-n,--count", opt->gen.count, "identification configurations")->capture_default_str()->check(CLI::Range(1, 100000));
  cmd->add_option("--seed", opt->gen.seed, "random seed")->capture_default_str();
  cmd->add_option("-o,--out", opt->out, "output folder")->capture_default_str();
  cmd->callback([opt] {
    const sim::Arm arm = sim::loadArm(opt->as.robot);
    const sim::Scene scene = sim::loadScene(opt->as.scene);
    std::printf("Arm: %s (%s), %d revolute joints, %s DH, %d parameter errors\n", arm.name.c_str(), arm.source.c_str(),
                arm.numJoints(), arm.convention == sim::DhConvention::kModified ? "modified (Craig)" : "standard",
                arm.numParams());
    std::printf("Scene: %s (%s): camera %dx%d px, board %dx%d inner corners of %.1f mm\n", scene.name.c_str(),
                scene.source.c_str(), scene.camera.width_px, scene.camera.height_px, scene.board.corners_x,
                scene.board.corners_y, scene.board.square_m * 1e3);
    sim::makeDirectories(opt->out);
    sim::GeneratorStats stats;
    Progress bar("configurations", opt->gen.count);
    const auto configs = sim::generateConfigurations(arm, scene, opt->gen, &stats, [&](int d, int) { bar.update(d); });
    bar.finish();
    const std::string configs_path = opt->out + "/configurations.csv";
    sim::writeFileAtomic(configs_path, sim::formatConfigurationsCsv(configs));
    std::printf("Configurations: %d board-visible (%d attempts: IK failed %d, singular %d, board not visible %d) -> %s\n",
                stats.accepted, stats.attempts, stats.ik_failed, stats.singular, stats.not_visible, configs_path.c_str());
    const std::string report = sim::formatIdentifiability(sim::analyzeIdentifiability(arm, configs));
    sim::writeFileAtomic(opt->out + "/identifiability.txt", report);
    std::cout << report;
  });
}

}  // namespace

ORBCAL_COMMAND(10, addRunCommand);

}  // namespace orbcal::tools
