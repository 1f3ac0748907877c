// `orbcal study run|submit|status|merge|task`: a grid of orbcal jobs over seeds, locally or on Slurm (study.hpp).
#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "cli.hpp"
#include "figures.hpp"
#include "interrupt.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/cores.hpp"
#include "orbcal/sim/fileio.hpp"
#include "progress.hpp"
#include "orbcal/workflow/study.hpp"

namespace fs = std::filesystem;

namespace orbcal::tools {

namespace {

/// The message of CLI11's own checks (type, range, choices) of `values` given to option `o`, or "".
/// The values go through the option as parsing would put them there (its validators and its conversion
/// into the probe's own variables), and are cleared again.
std::string optionValueError(CLI::Option& o, const std::vector<std::string>& values) {
  o.clear();
  o.add_result(values);
  std::string why;
  try {
    o.run_callback();
  } catch (const CLI::Error& e) {
    why = sim::printable(e.what());
  }
  o.clear();
  return why;
}

/// Checks a study's option names and values against this program's own commands.
workflow::StudyOptionCheck programOptions() {
  auto probe = std::make_shared<CLI::App>();  // built once, asked for every option of the study
  addRegisteredCommands(*probe);
  return [probe](const std::string& job, const std::string& option, bool flag, const std::vector<std::string>& values) -> std::string {
    CLI::App* sub = nullptr;
    for (CLI::App* c : probe->get_subcommands({})) {
      if (c->get_name() == job) sub = c;
    }
    CLI::Option* o = sub ? sub->get_option_no_throw("--" + option) : nullptr;
    if (!o) return "not an option of orbcal " + job + " (see orbcal " + job + " --help)";
    if (flag && o->get_expected_max() != 0) return "--" + option + " takes a value, not true";
    if (!flag && o->get_expected_max() == 0) return "--" + option + " is a flag: give true or false";
    if (values.empty()) return "";
    const std::string why = optionValueError(*o, values);  // CLI11's message names the option and the value
    return why.empty() ? "" : why + " (orbcal " + job + " would refuse it)";
  };
}

/// Reads the study file and prepares its folder; returns the number of tasks.
int prepare(const std::string& study_file, const std::string& dir) {
  return static_cast<int>(workflow::expandStudy(workflow::prepareStudy(study_file, dir, programOptions())).size());
}

int doneCount(const std::vector<workflow::TaskState>& states) {
  return static_cast<int>(std::count(states.begin(), states.end(), workflow::TaskState::kDone));
}

void mergeAndPrint(const std::string& dir, const std::string& out, bool plots) {
  const workflow::MergeReport r = workflow::mergeStudy(dir, out, plots, terminalCallbacks(plots));
  std::printf("merged: %zu files; report: %s\n", r.files.size(), r.report_path.c_str());
}

/// `orbcal study run`: every task here, several at once, then the merge.
void addStudyRun(CLI::App* study) {
  struct RunOpts {
    std::string file, dir;
    int jobs = sim::availableCores();
    bool merge = true, plots = true;
  };
  auto ro = std::make_shared<RunOpts>();
  CLI::App* run = study->add_subcommand(
      "run", "Run every task of STUDY.yaml here, several at once; each task's result goes atomically into its shard folder. "
             "Rerunning resumes: only missing and failed tasks run. Merges when all are done.");
  run->add_option("study", ro->file, "the study file (YAML, format orbcal-study-1)")->required();
  run->add_option("-o,--out", ro->dir, "the study folder (created; a rerun resumes it)")->required();
  run->add_option("-j,--jobs", ro->jobs, "tasks at once (default: the cores this process may use)")->capture_default_str()->check(CLI::Range(1, 4096));
  run->add_flag("--no-merge", [ro](std::int64_t) { ro->merge = false; }, "do not merge when every task is done");
  run->add_flag("--no-plots", [ro](std::int64_t) { ro->plots = false; }, "merge without drawing figures");
  run->callback([ro] {
    const int n = prepare(ro->file, ro->dir);
    sim::FolderLock lock(ro->dir, "orbcal study run");
    setInterruptNote("finished tasks are kept in " + ro->dir + "/shards: rerun the same command to run the missing and failed ones");
    const std::vector<int> todo = workflow::tasksToRun(ro->dir, n);
    std::printf("%s: %d tasks, %d done before, %zu to run, %d at once\n", ro->dir.c_str(), n, n - static_cast<int>(todo.size()),
                todo.size(), std::max(1, std::min<int>(ro->jobs, static_cast<int>(todo.size()))));
    std::fflush(stdout);
    const std::vector<std::string> failures =
        workflow::runStudyTasks(ro->dir, n, todo, ro->jobs, workflow::selfProgram(), terminalProgress());
    for (const std::string& f : failures) std::fprintf(stderr, "orbcal: %s\n", f.c_str());
    if (!failures.empty()) {
      std::fprintf(stderr, "orbcal: %zu of %d tasks failed; rerun the same command to run them again\n", failures.size(), n);
      throw CLI::RuntimeError(1);
    }
    if (ro->merge) mergeAndPrint(ro->dir, "", ro->plots);
  });
}

/// `orbcal study submit`: an sbatch job array of the tasks not done.
void addStudySubmit(CLI::App* study) {
  struct SubmitOpts {
    std::string file, dir;
    workflow::SlurmSubmitOptions slurm;
    bool wait = false;
  };
  auto so = std::make_shared<SubmitOpts>();
  CLI::App* submit = study->add_subcommand(
      "submit", "Write an sbatch job-array script for the tasks of STUDY.yaml that are missing or failed (array index = task; "
                "throttle, time and memory from the study's slurm: section) and submit it. Resubmitting runs only what is "
                "missing or failed. The study folder must be on a filesystem the compute nodes share.");
  submit->add_option("study", so->file, "the study file (YAML)")->required();
  submit->add_option("-o,--out", so->dir, "the study folder (created; shared with the compute nodes)")->required();
  submit->add_option("--partition", so->slurm.partition, "Slurm partition (sbatch --partition)");
  submit->add_option("--account", so->slurm.account, "Slurm account (sbatch --account)");
  submit->add_option("--sbatch-arg", so->slurm.extra, "one more sbatch argument, verbatim (repeatable), e.g. --sbatch-arg=--qos=long")
      ->allow_extra_args(false);  // one value per --sbatch-arg, so the study file after it stays positional
  submit->add_option("--program", so->slurm.program, "orbcal's path on the compute nodes (default: this program's path)");
  submit->add_flag("--dry-run", so->slurm.dry_run, "write the script, do not submit it");
  submit->add_flag("--wait", so->wait, "wait until the submitted tasks have finished (progress from the shard folders)");
  submit->callback([so] {
    const int n = prepare(so->file, so->dir);
    workflow::SlurmSubmission sub;
    {
      sim::FolderLock lock(so->dir, "orbcal study submit");
      sub = workflow::submitStudy(so->dir, so->slurm);
    }
    if (sub.tasks.empty()) {
      std::printf("%s: nothing to submit (every task is done, running or queued)\n", so->dir.c_str());
    }
    for (std::size_t k = 0; k < sub.scripts.size(); ++k) {
      std::printf("%s%s%s\n", sub.scripts[k].c_str(), k < sub.job_ids.size() ? ": submitted as job " : " (not submitted)",
                  k < sub.job_ids.size() ? sub.job_ids[k].c_str() : "");
    }
    if (!sub.tasks.empty()) std::printf("tasks %s of %d\n", workflow::arrayRanges(sub.tasks).c_str(), n);
    std::fflush(stdout);
    if (!so->wait || so->slurm.dry_run) return;
    setInterruptNote("the Slurm jobs go on; `orbcal study status " + so->dir + "` shows where they stand");
    const std::vector<workflow::TaskState> states = workflow::waitForStudy(so->dir, n, terminalProgress());
    std::printf("%s", workflow::formatStudyStatus(so->dir, states).c_str());
    if (doneCount(states) != n) throw CLI::RuntimeError(1);
  });
}

/// `orbcal study status`: where each task stands.
void addStudyStatus(CLI::App* study) {
  auto status_dir = std::make_shared<std::string>();
  CLI::App* status = study->add_subcommand(
      "status", "Per task: done, running, queued, failed or missing, from the shard folders and from Slurm (squeue, and sacct "
                "where accounting is on). Exit status 0 when every task is done, 3 otherwise.");
  status->add_option("dir", *status_dir, "the study folder")->required();
  status->callback([status_dir] {
    const workflow::StudySpec s = workflow::loadStudyFolder(*status_dir);
    const std::vector<workflow::TaskState> states = workflow::studyTaskStates(*status_dir, static_cast<int>(workflow::expandStudy(s).size()));
    std::printf("%s", workflow::formatStudyStatus(*status_dir, states).c_str());
    if (doneCount(states) != static_cast<int>(states.size())) throw CLI::RuntimeError(3);
  });
}

/// `orbcal study merge`: the merged report of a finished study.
void addStudyMerge(CLI::App* study) {
  struct MergeOpts {
    std::string dir, out;
    bool plots = true;
  };
  auto mo = std::make_shared<MergeOpts>();
  CLI::App* merge = study->add_subcommand(
      "merge", "Merge a finished study: its jobs' CSVs concatenated (task, cell, replicate, seed, grid values first), per cell "
               "the mean, standard deviation and 95 % confidence interval over the seeds, the presets' figures per cell; a render "
               "study's shards as one dataset with one manifest. The same whether the tasks ran here or on a cluster.");
  merge->add_option("dir", mo->dir, "the study folder")->required();
  merge->add_option("-o,--out", mo->out, "output folder (default DIR/merged; replaced atomically)");
  merge->add_flag("--no-plots", [mo](std::int64_t) { mo->plots = false; }, "do not draw the figures");
  merge->callback([mo] {
    sim::FolderLock lock(mo->dir, "orbcal study merge");
    mergeAndPrint(mo->dir, mo->out, mo->plots);
  });
}

/// `orbcal study task`: one task (what each Slurm array task and local worker runs).
void addStudyTask(CLI::App* study) {
  struct TaskOpts {
    std::string dir;
    int index = -1;
  };
  auto to = std::make_shared<TaskOpts>();
  CLI::App* task = study->add_subcommand(
      "task", "Run one task of a study folder (what each Slurm array task and each local worker runs): its job's output goes "
              "to DIR/shards/task-NNNNNN/ when it succeeds, .failed/ when not. A done task is not run again.");
  task->add_option("dir", to->dir, "the study folder")->required();
  task->add_option("--index", to->index, "the task (0-based; tasks.csv)")->required()->check(CLI::NonNegativeNumber);
  task->callback([to] {
    const int status = workflow::runStudyTask(to->dir, to->index, workflow::selfProgram());
    if (status != 0) {
      std::fprintf(stderr, "orbcal: task %d failed (exit status %d): %s.failed/log.txt\n", to->index, status,
                   workflow::taskFolder(to->dir, to->index).c_str());
      throw CLI::RuntimeError(1);
    }
  });
}

void addStudyCommand(CLI::App& app) {
  CLI::App* study = app.add_subcommand(
      "study",
      "Studies: one job (an experiment preset, run, diagnose-study or render) over a grid of options and a list of seeds, "
      "as independent tasks run locally on every core or as a Slurm job array, merged into one report (docs/studies-and-clusters.md)");
  study->require_subcommand(1);
  addStudyRun(study);
  addStudySubmit(study);
  addStudyStatus(study);
  addStudyMerge(study);
  addStudyTask(study);
}

}  // namespace

ORBCAL_COMMAND(60, addStudyCommand);

}  // namespace orbcal::tools
