// `orbcal experiment --preset table4|table5|fig8|floor`
#include <iostream>

#include "cli.hpp"
#include "figures.hpp"
#include "interrupt.hpp"
#include "orbcal/workflow/experiment.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::tools {

void addExperimentOptions(CLI::App& cmd, workflow::ExperimentOptions& o) {
  addRobotOptions(cmd, o.robot, o.base_link, o.tip_link);
  cmd.add_option("--scene", o.scene, "scene (YAML; or builtin:default_scene.yaml)")->capture_default_str();
  cmd.add_option("-o,--out", o.out, "output folder (reports under <out>/<preset>, datasets under <out>/datasets)")
      ->capture_default_str();
  cmd.add_option("--errors", o.errors.name,
                 "injected error set: table3 (Wang et al. 2023, Table 3), zero, random, or an error-set file (YAML: DH errors + effects)")
      ->capture_default_str();
  cmd.add_option("--error-seed", o.errors.seed, "seed of --errors random")->capture_default_str();
  cmd.add_option_function<double>(
         "--error-angle-sigma-deg", [&o](double d) { o.errors.angle_sigma_rad = d * sim::kDegToRad; },
         "spread of random theta/alpha errors [deg] (default 0.3)")
      ->check(CLI::Range(0.0, 90.0));
  cmd.add_option_function<double>(
         "--error-length-sigma-mm", [&o](double mm) { o.errors.length_sigma_m = mm * 1e-3; },
         "spread of random a/d errors [mm] (default 1)")
      ->check(CLI::Range(0.0, 1000.0));
  cmd.add_option("--seed", o.seed, "random seed (configurations, noise, images)")->capture_default_str();
  cmd.add_option("--ident", o.identification, "identification configurations")->capture_default_str()->check(CLI::Range(1, 100000));
  cmd.add_option("--valid", o.validation, "validation configurations")->capture_default_str()->check(CLI::Range(1, 100000));
  cmd.add_flag("--no-plots", [&o](std::int64_t) { o.plots = false; }, "do not draw the PNG figures");
  cmd.add_flag("--quiet", o.quiet, "no progress output");
  auto* jn = cmd.add_option_function<double>(
      "--joint-noise-deg", [&o](double d) { o.joint_noise_sigma_rad = d * sim::kDegToRad; },
      "joint control noise, 1 sigma [deg] (default 0.01, Wang et al. 2023)");
  jn->check(CLI::Range(0.0, 10.0));
  cmd.add_option("--methods", o.methods,
                 "estimators to compare, by name (repeatable; table4, table5, fig8 and run; default: the preset's own): " +
                     calib::methodNames());
}

namespace {

/// A preset whose protocol fixes some options refuses them when given, rather than ignoring them.
void refuseUnused(const CLI::App& cmd, const std::string& preset, std::initializer_list<const char*> options) {
  for (const char* option : options) {
    if (cmd.count(option) > 0) {
      throw sim::InputError(std::string(option) + ": not used by --preset " + preset + " (its protocol fixes it)");
    }
  }
}

void addExperimentCommand(CLI::App& app) {
  struct Opts {
    workflow::ExperimentOptions e;
    std::string preset;
  };
  auto opt = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand("experiment",
                                     "Calibration experiments: Wang et al. 2023's Table 4, Table 5, Fig. 8 (and the other papers' protocols), and the control-noise floor");
  cmd->add_option("--preset", opt->preset,
                  "table4: Table 3 errors, 50 + 200 configurations, rendered images, every estimator;\n"
                  "table5: four synthetic noise levels + images, repeated;\n"
                  "fig8: identification set size 10..200 (--ident) in steps of 10, repeated;\n"
                  "floor: the validation error of the true parameters (control noise alone);\n"
                  "selection: configurations chosen by O3 / O1 against random ones at 15, 25, 50 measurements for the pose, "
                  "position and dr models, and in the main job's rendered setting (x floor), repeated;\n"
                  "jia2019: Jia et al. 2019, distance / D&R / absolute models on the hemisphere, board-to-base change sweep\n"
                  "  (pose level; robot default builtin:ssrms_hayati.yaml; --scene, --errors, --ident, --valid unused);\n"
                  "liu2012: Liu et al. 2012, laser ranger to a plane: 50 and 100 of 101 configurations by O3, 20 validation\n"
                  "  (--valid), repeated; robot default builtin:puma_hayati.yaml; --scene, --errors, --ident, --joint-noise-deg unused)")
      ->required()
      ->check(CLI::IsMember(workflow::kExperimentPresets));
  addExperimentOptions(*cmd, opt->e);
  cmd->add_option("-r,--repetitions", opt->e.repetitions, "repetitions (table5, fig8, floor, selection, jia2019, liu2012)")
      ->capture_default_str()
      ->check(CLI::Range(1, 10000));
  cmd->add_option("--source", opt->e.source, "fig8 measurements: images or synthetic (0.3 mm / 0.5 deg)")
      ->capture_default_str()
      ->check(CLI::IsMember({"images", "synthetic"}));
  cmd->callback([opt, cmd] {
    workflow::ExperimentOptions e = opt->e;
    e.callbacks = terminalCallbacks(e.plots);
    setInterruptNote("the datasets and images rendered so far are kept under " + e.out +
                     "/datasets: rerun the same command to resume from them");
    if (opt->preset == "table4") {
      const workflow::Table4Result r = workflow::runTable4(e);
      std::cout << workflow::table4Headline(r);
    } else if (opt->preset == "table5") {
      workflow::runTable5(e);
    } else if (opt->preset == "fig8") {
      if (cmd->count("--ident") == 0) e.identification = 200;  // the paper's range: 10 to 200
      workflow::runFig8(e);
    } else if (opt->preset == "selection") {
      refuseUnused(*cmd, "selection", {"--methods"});
      workflow::runSelection(e);
    } else if (opt->preset == "jia2019") {
      refuseUnused(*cmd, "jia2019", {"--scene", "--errors", "--ident", "--valid", "--methods"});
      if (cmd->count("--robot") == 0) e.robot = "builtin:ssrms_hayati.yaml";  // Jia et al. 2019's Hayati model
      workflow::runJia2019(e);
    } else if (opt->preset == "liu2012") {
      refuseUnused(*cmd, "liu2012", {"--scene", "--errors", "--ident", "--joint-noise-deg", "--methods"});
      if (cmd->count("--robot") == 0) e.robot = "builtin:puma_hayati.yaml";
      if (cmd->count("--valid") == 0) e.validation = 20;  // the paper's 20 validation configurations
      workflow::runLiu2012(e);
    } else {
      refuseUnused(*cmd, "floor", {"--methods"});
      workflow::runFloor(e);
    }
  });
}

}  // namespace

ORBCAL_COMMAND(50, addExperimentCommand);

}  // namespace orbcal::tools
