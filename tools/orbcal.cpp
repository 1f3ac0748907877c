// orbcal: kinematic calibration and model diagnosis of serial arms from tracker or motion-capture data
// or from images of an eye-in-hand camera; rendered datasets and the papers' experiments. Subcommands
// are git style: `orbcal <cmd> --help`.
#include <iostream>

#include "cli.hpp"
#include "interrupt.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/cores.hpp"

#include <opencv2/core/utility.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <vector>

namespace orbcal::tools {
namespace {
std::vector<std::pair<int, CommandAdder>>& registry() {
  static std::vector<std::pair<int, CommandAdder>> r;
  return r;
}
}  // namespace
int registerCommand(int order, CommandAdder adder) {
  registry().emplace_back(order, adder);
  return 0;
}
namespace {
/// The check every option value of every command gets: a value that reads as a number is finite (CLI11's
/// Range compares, and every comparison with NaN is false, so NaN passed them), and a --seed is not
/// negative (it would wrap to a huge unsigned seed). Study files' option values go through it too.
std::string finiteNumber(const CLI::Option& o, const std::string& value) {
  char* end = nullptr;
  const double v = std::strtod(value.c_str(), &end);
  if (value.empty() || end != value.c_str() + value.size()) return "";  // not a number: the option's own check
  if (!std::isfinite(v)) return "'" + value + "' is not a finite number";
  if (o.check_name("--seed") && v < 0.0) return "'" + value + "': a seed is a whole number from 0";
  return "";
}

void checkNumbersOf(CLI::App& cmd) {
  for (CLI::Option* o : cmd.get_options()) {
    if (o->get_expected_max() == 0) continue;  // a flag
    o->check(CLI::Validator([o](std::string& value) { return finiteNumber(*o, value); }, ""));
  }
  for (CLI::App* sub : cmd.get_subcommands({})) checkNumbersOf(*sub);
}
}  // namespace

void addRegisteredCommands(CLI::App& app) {
  auto r = registry();
  std::stable_sort(r.begin(), r.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& [order, adder] : r) adder(app);
  checkNumbersOf(app);
}
void addArmSceneOptions(CLI::App& cmd, ArmSceneOptions& opt) {
  addRobotOptions(cmd, opt);
  cmd.add_option("--scene", opt.scene, "scene (YAML; or builtin:default_scene.yaml)")->capture_default_str();
}
void addRobotOptions(CLI::App& cmd, ArmSceneOptions& opt) { addRobotOptions(cmd, opt.robot, opt.base_link, opt.tip_link); }
void addRobotOptions(CLI::App& cmd, std::string& robot, std::string& base_link, std::string& tip_link,
                     const std::string& robot_help) {
  cmd.add_option("--robot", robot, robot_help + ": a robot YAML (or builtin:NAME) or a URDF (.urdf)")->capture_default_str();
  cmd.add_option("--base-link", base_link, "URDF robot: the link the arm's chain starts from (default: the root link)");
  cmd.add_option("--tip-link", tip_link, "URDF robot: the link the chain ends at, the flange (default: the only leaf link)");
}

}  // namespace orbcal::tools

int main(int argc, char** argv) {
  CLI::App app{"orbcal " ORBCAL_VERSION
               ": kinematic calibration of serial robot arms (a robot YAML in DH or a URDF).\n"
               "From a laser tracker's or motion-capture system's CSV files, described by a small YAML: `orbcal calibrate "
               "DESC.yaml` (geometry, the unknown tracker and marker frames, effects such as joint compliance), `orbcal "
               "diagnose DESC.yaml` (what the model misses, and its physical cause), `orbcal evaluate` (a model on other "
               "data); `orbcal simulate` writes such data to try them.\n"
               "From images of a calibration board seen by a camera on the arm: `orbcal render` (datasets with known "
               "errors), `orbcal calibrate DATASET_DIR`; `orbcal run` is the main job on the built-in SSRMS arm and scene.\n"
               "`orbcal <command> --help` for each command.",
               "orbcal"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("orbcal ") + ORBCAL_VERSION);
  orbcal::tools::addRegisteredCommands(app);
  // OpenCV's threads (distortion maps, remaps, detection) on the cores this process may use: a Slurm
  // task given 2 CPUs of a 64-core node uses 2.
  cv::setNumThreads(orbcal::sim::availableCores());
  orbcal::tools::installInterruptHandler("orbcal");  // Ctrl-C / SIGTERM: one line on where things stand
  try {
    app.parse(argc, argv);
  } catch (const CLI::RuntimeError& e) {
    return e.get_exit_code();  // the command said why (e.g. a calibration that would make the arm worse)
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);  // prints help or the usage error
    return code == 0 ? 0 : 2;
  } catch (const std::exception& e) {
    // Bad input, unreachable poses, I/O failures: one line naming the file and the field.
    std::cerr << "orbcal: " << orbcal::sim::printable(e.what()) << "\n";
    return 1;
  }
  return 0;
}
