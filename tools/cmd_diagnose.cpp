// `orbcal diagnose`: what the model gets wrong, the physical cause, the extended model and its gain.
#include <cstdio>
#include <optional>

#include "cli.hpp"
#include "figures.hpp"
#include "orbcal/workflow/diagnose.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::tools {

namespace {

void addDiagnoseCommand(CLI::App& app) {
  auto o = std::make_shared<workflow::DiagnoseRunOptions>();
  CLI::App* cmd = app.add_subcommand(
      "diagnose",
      "From measured data (a measurement description, .yaml) or an image dataset (folder): does the geometry + "
      "registration model leave structure in its cross-validated residuals, which cause of the catalog explains it "
      "(compliance and stiffening compliance, cyclic, scale, backlash, thermal, drift, mount, coupling, link_bending; on "
      "image datasets also the lens distortion), with which parameters, how much better the extended model predicts "
      "held-out data, and what is left above the noise (verdict clean, effects or unexplained; empirical corrections "
      "where no cause fits). Writes report.md and report.html (verdict first), diagnosis.json, model.yaml + robot.yaml, "
      "residuals.csv, figures (the list: docs/reports.md).");
  cmd->add_option("input", o->input, "measurement description (.yaml) or image dataset folder")->required();
  cmd->add_option("-o,--out", o->out, "output folder (default: diagnosis/ beside the input)");
  cmd->add_option("--folds", o->diagnose.folds, "cross-validation folds")->capture_default_str()->check(CLI::Range(2, 20));
  cmd->add_option("--seed", o->diagnose.seed, "seed of the folds")->capture_default_str();
  cmd->add_option("--alpha", o->diagnose.alpha, "family-wise error rate of each step's candidate tests (Holm)")
      ->capture_default_str()
      ->check(CLI::Range(1e-6, 0.5));
  cmd->add_option("--penalty", o->diagnose.penalty_per_param,
                  "held-out whitened squared error an added parameter must save")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 100.0));
  cmd->add_option("--max-effects", o->diagnose.max_effects, "effects added at most")->capture_default_str()->check(CLI::Range(1, 10));
  cmd->add_option("--max-order", o->diagnose.max_order,
                  "highest order searched: cyclic harmonics, the degree of empirical corrections")
      ->capture_default_str()
      ->check(CLI::Range(1, 8));
  cmd->add_option("--noise-observations", o->diagnose.noise_observations,
                  "where the noise is estimated (not stated): on a seeded random subset of this many observations "
                  "(0: all; never fewer than its flexible model needs); its relative standard error is about "
                  "sqrt(2 / rows)")
      ->capture_default_str()
      ->check(CLI::Range(0, 100000000));
  cmd->add_option("--selection-observations", o->diagnose.selection_observations,
                  "the effects are selected (score tests, cross-validated gains) on a seeded random subset of this many "
                  "observations (0: all); the selected model is fitted and judged on all")
      ->capture_default_str()
      ->check(CLI::Range(0, 100000000));
  cmd->add_flag("--no-empirical", [o](std::int64_t) { o->diagnose.empirical = false; },
                "name physical causes only: no empirical correction where none fits");
  cmd->add_option_function<double>(
         "--joint-noise-deg", [o](double d) { o->diagnose.joint_noise_sigma_rad = d * sim::kDegToRad; },
         "joint readings vs true angles, 1 sigma [deg] (images: default the manifest's, else 0.01; measured data: "
         "estimated from the residuals beside the tracker's noise)")
      ->check(CLI::Range(0.0, 10.0));
  cmd->add_flag("--no-plots", [o](std::int64_t) { o->plots = false; }, "skip the PNG figures");
  cmd->add_flag("--quiet", o->quiet, "no progress output");
  cmd->callback([o] {
    workflow::DiagnoseRunOptions options = *o;
    // Two drawers (one matplotlib import): its figures are drawn two at a time once the analysis is done.
    options.callbacks = terminalCallbacks(options.plots, 2);
    const workflow::DiagnoseRunResult r = workflow::runDiagnose(options);
    std::printf("%s\n", r.diagnosis.verdict.c_str());
    for (const calib::ConfoundedSet& c : r.diagnosis.confounded) {
      std::printf("confounded in this data:");
      for (const sim::Effect& e : c.effects) std::printf(" %s", sim::formatEffect(e).c_str());
      if (c.with_geometry) std::printf(" geometry");
      std::printf(" (to separate them: %s)\n", c.separate_by.c_str());
    }
    std::printf("report: %s\ndiagnosis: %s\nmodel: %s\n", r.report_path.c_str(), r.json_path.c_str(), r.model_path.c_str());
  });
}

void addStudyCommand(CLI::App& app) {
  auto o = std::make_shared<workflow::StudyOptions>();
  CLI::App* cmd = app.add_subcommand(
      "diagnose-study",
      "The power of orbcal diagnose: N seeded simulated tracker datasets per catalog effect (random joint; each "
      "parameter's magnitude uniform in [0.5, 2] x its typical value, random sign; random DH errors and frames; 200 "
      "samples, two sessions at 0 and 1.25 kg) and N clean ones, each diagnosed; prints the confusion table.");
  addRobotOptions(*cmd, o->robot, o->base_link, o->tip_link, "robot with masses");
  cmd->add_option("-n,--per-effect", o->per_effect, "datasets per effect")->capture_default_str()->check(CLI::Range(1, 10000));
  cmd->add_option("--clean", o->clean, "clean datasets")->capture_default_str()->check(CLI::Range(0, 10000));
  cmd->add_option("--samples", o->samples, "samples per dataset")->capture_default_str()->check(CLI::Range(20, 100000));
  cmd->add_option("--seed", o->seed, "seed of the draws")->capture_default_str();
  cmd->add_option("--effects", o->effects, "effects to inject (catalog names)")->capture_default_str();
  cmd->add_flag("--quiet", o->quiet, "no progress output");
  cmd->add_option("-o,--out", o->out, "also write the confusion table to DIR/diagnose_study.csv and DIR/report.md (and report.html)");
  cmd->callback([o] {
    workflow::StudyOptions options = *o;
    options.callbacks = terminalCallbacks(false);  // the study draws no figures
    const workflow::StudyResult r = workflow::runDiagnoseStudy(options);
    std::printf("%s\n%.1f s\n", workflow::formatStudy(r).c_str(), r.seconds);
  });
}

}  // namespace

ORBCAL_COMMAND(48, addDiagnoseCommand);
ORBCAL_COMMAND(49, addStudyCommand);

}  // namespace orbcal::tools
