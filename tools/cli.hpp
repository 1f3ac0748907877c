#pragma once
// Shared pieces of the `orbcal` command line: each subcommand lives in its own cmd_*.cpp and
// registers itself through one add*Command function called from orbcal.cpp.
#include <CLI/CLI.hpp>
#include <string>

#include "orbcal/sim/io.hpp"
#include "orbcal/workflow/experiment.hpp"

namespace orbcal::tools {

/// Options every subcommand that needs the arm and the scene takes.
struct ArmSceneOptions {
  std::string robot = "builtin:ssrms.yaml";
  std::string base_link, tip_link;  ///< a URDF robot's chain
  std::string scene = "builtin:default_scene.yaml";
  sim::RobotSource robotSource() const { return {robot, base_link, tip_link}; }
};
void addArmSceneOptions(CLI::App& cmd, ArmSceneOptions& opt);
/// --robot, --base-link and --tip-link alone (what addArmSceneOptions adds before --scene).
void addRobotOptions(CLI::App& cmd, ArmSceneOptions& opt);
/// --robot (`robot`: what the command needs of it, e.g. "with masses for torques"), --base-link and
/// --tip-link into the three strings of a sim::RobotSource.
void addRobotOptions(CLI::App& cmd, std::string& robot, std::string& base_link, std::string& tip_link,
                     const std::string& robot_help = "robot description");

/// The options shared by `orbcal run` and `orbcal experiment` (cmd_experiment.cpp).
void addExperimentOptions(CLI::App& cmd, workflow::ExperimentOptions& o);

/// Subcommands register themselves from their own cmd_*.cpp (no shared list to edit):
///   ORBCAL_COMMAND(30, addRenderCommand);
/// `order` sets their place in `orbcal --help`.
using CommandAdder = void (*)(CLI::App&);
int registerCommand(int order, CommandAdder adder);
void addRegisteredCommands(CLI::App& app);
#define ORBCAL_COMMAND(order, fn) \
  static const int orbcal_command_##fn [[maybe_unused]] = ::orbcal::tools::registerCommand(order, fn)

}  // namespace orbcal::tools
