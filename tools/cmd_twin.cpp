// `orbcal twin`: real views beside their rendered twins, and the camera profile fitted from them.
#include <cstdio>

#include "cli.hpp"
#include "orbcal/workflow/twin.hpp"

namespace orbcal::tools {

namespace {

void addTwinCommand(CLI::App& app) {
  auto o = std::make_shared<workflow::TwinOptions>();
  CLI::App* cmd = app.add_subcommand(
      "twin",
      "Render the twin of every real view of a description of images (the same board, camera and pose) and compare them, "
      "statistic by statistic: corner scatter and its repeatable part, corners and markers detected, black and white "
      "levels, tone curve, vignetting, noise, edge width and overshoot, background; each with its uncertainty and "
      "whether real and rendered differ significantly. Writes twin.json, camera_profile.yaml (a camera profile fitted "
      "from the differences), report.md and report.html (docs/twins.md).");
  cmd->add_option("description", o->description, "measurement description (.yaml) with images:")->required();
  cmd->add_option("-o,--out", o->out, "output folder (default: <description's folder>/twin)");
  cmd->add_option("--profile", o->profile, "camera_profile.yaml to apply to the twins (their `profiled` column)");
  cmd->add_option("--seed", o->seed, "seed of the profile's noise")->capture_default_str();
  cmd->callback([o] {
    const workflow::TwinResult r = workflow::runTwin(*o);
    const workflow::TwinComparison& c = r.comparison;
    std::printf("%zu of %d views compared with their twins (%.1f s, of which rendering and comparing %.1f s)\n", c.views.size(), r.rows,
                r.seconds, c.seconds);
    std::printf("%-52s %12s %12s %12s\n", "statistic", "real", "rendered", c.profiled ? "profiled" : "");
    for (const workflow::TwinStatistic& s : c.statistics) {
      std::printf("%-52s %12.4g %12.4g", s.label.c_str(), s.real.value, s.rendered.value);
      if (c.profiled) std::printf(" %12.4g", s.profiled.value);
      std::printf("%s\n", s.significant ? "  (differs)" : "");
    }
    std::printf("twin: %s\nprofile: %s\nreport: %s\n", r.json_path.c_str(), r.profile_path.c_str(), r.report_path.c_str());
  });
}

}  // namespace

ORBCAL_COMMAND(44, addTwinCommand);

}  // namespace orbcal::tools
