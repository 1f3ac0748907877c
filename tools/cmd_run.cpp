// `orbcal run`: the main job. Default arm and scene -> rendered images -> corners and board poses ->
// estimators (EKF and the others) -> validation report, with its headline printed at the end.
#include <cstdio>
#include <iostream>

#include "cli.hpp"
#include "figures.hpp"
#include "interrupt.hpp"
#include "orbcal/workflow/experiment.hpp"
#include "orbcal/sim/io.hpp"

namespace orbcal::tools {

namespace {

void addRunCommand(CLI::App& app) {
  auto opt = std::make_shared<workflow::ExperimentOptions>();
  CLI::App* cmd = app.add_subcommand(
      "run",
      "The main job: render the identification and validation views of the arm with injected errors, "
      "measure the board poses, identify the errors (EKF, LSE, LM) and report the validation errors");
  addExperimentOptions(*cmd, *opt);
  cmd->callback([opt] {
    setInterruptNote("the datasets and images rendered so far are kept under " + opt->out +
                     "/datasets: rerun the same command to resume from them");
    const sim::Arm arm = sim::loadArm(opt->robotSource());
    const sim::Scene scene = sim::loadScene(opt->scene);
    std::printf("Arm: %s (%s), %d revolute joints, %s DH, %d parameter errors\n", arm.name.c_str(), arm.source.c_str(),
                arm.numJoints(), arm.convention == sim::DhConvention::kModified ? "modified (Craig)" : sim::conventionName(arm.convention),
                arm.numParams());
    std::printf("Scene: %s (%s): camera %dx%d px, board %dx%d inner corners of %.1f mm\n", scene.name.c_str(),
                scene.source.c_str(), scene.camera.width_px, scene.camera.height_px, scene.board.corners_x,
                scene.board.corners_y, scene.board.square_m * 1e3);
    std::printf("Errors: %s; %d identification + %d validation configurations; output %s/\n", opt->errors.name.c_str(),
                opt->identification, opt->validation, opt->out.c_str());
    std::fflush(stdout);
    workflow::ExperimentOptions e = *opt;
    e.callbacks = terminalCallbacks(e.plots);
    const workflow::Table4Result r = workflow::runTable4(e, "main");
    std::cout << "\n" << workflow::table4Headline(r);
  });
}

}  // namespace

ORBCAL_COMMAND(10, addRunCommand);

}  // namespace orbcal::tools
