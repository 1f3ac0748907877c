#pragma once
// Studies: one orbcal job (an `experiment` preset, `run`, `diagnose-study` or `render`)
// over a grid of option values crossed with a list of seeds, run as independent tasks, locally or as a
// Slurm job array, and merged into one report. Every task is `orbcal study task DIR --index I`, the
// same program on the same inputs wherever it runs, so a merged result does not depend on where or
// when its tasks ran.
//
// A study folder DIR:
//   DIR/study.yaml            the study file, copied verbatim (a rerun with another file is refused)
//   DIR/study-origin.yaml     where relative paths in it resolve (the study file's folder), the program
//   DIR/tasks.csv             one row per task: index, cell, replicate, shard, seed, grid values, command
//   DIR/shards/task-NNNNNN/   a finished task: task.yaml (its inputs, exit code, wall time, host),
//                             log.txt (the job's output), out/ (the job's -o folder)
//   DIR/shards/task-NNNNNN.tmp/     a task being written (locked by sim::FolderLock while it runs; an
//                             unlocked one was killed and is run again)
//   DIR/shards/task-NNNNNN.failed/  a task whose job exited non-zero (task.yaml, log.txt)
//   DIR/slurm/                sbatch scripts, submitted job ids (jobs.csv), Slurm's logs
//   DIR/merged/               `orbcal study merge`: the merged CSVs, summaries, report.md, report.html
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "orbcal/workflow/callbacks.hpp"

namespace orbcal::workflow {

inline constexpr const char* kStudyFormat = "orbcal-study-1";

/// Which columns of a job's CSV identify a row (keys) and which are averaged over seeds (values).
struct StudySummarySpec {
  std::string file;  ///< relative to the job's -o folder, e.g. "table5/table5.csv"
  std::vector<std::string> keys, values;
};

struct StudySlurm {
  int throttle = 0;               ///< most array tasks running at once (0: no limit)
  std::string time = "01:00:00";  ///< per task, sbatch --time
  std::string mem = "4G";         ///< per task, sbatch --mem
  int cpus_per_task = 1;
};

struct StudySpec {
  std::string source;  ///< the file, for messages
  std::string text;    ///< its bytes
  std::string name;    ///< `name:` or the file's stem; the Slurm job name
  std::string job;     ///< experiment | run | diagnose-study | render
  std::string preset;  ///< experiment only
  /// Fixed options: long name without "--" -> its values (one argument each); a flag (given as `true`) has none.
  std::vector<std::pair<std::string, std::vector<std::string>>> options;
  /// Crossed options: long name -> its values, in file order; the cells are every combination.
  std::vector<std::pair<std::string, std::vector<std::string>>> grid;
  std::vector<std::uint64_t> seeds;
  bool common_seeds = false;   ///< seed_derivation: common (the listed seed in every cell) or per-task
  int shards = 1;              ///< render: shards per dataset (`orbcal render --shard i/N`)
  bool keep_datasets = false;  ///< experiment / run: keep each task's rendered datasets
  StudySlurm slurm;
  std::vector<StudySummarySpec> summaries;  ///< `summary:`, else the job's built-in ones
  std::string origin;  ///< loadStudyFolder: the folder its relative paths resolve against (study-origin.yaml)
};

struct StudyTask {
  int index = 0;
  int cell = 0;       ///< index into the grid's combinations (row-major, the first key slowest)
  int replicate = 0;  ///< index into seeds
  int shard = 0;      ///< render: shard of the dataset
  std::vector<std::string> cell_values;  ///< one per grid key
  std::uint64_t seed = 0;                ///< the job's --seed
  std::vector<std::string> args;         ///< orbcal's arguments, without -o
};

/// Checks that `option` (long name without "--") is an option of `job` and that `values` (its arguments;
/// empty: the name alone) pass the option's own checks (type, range, choices), so that a bad value is
/// refused before any task runs; returns "" when they do, else what is wrong in one line (e.g. "not an
/// option of orbcal experiment"). `flag`: given as `true` (no value).
using StudyOptionCheck = std::function<std::string(const std::string& job, const std::string& option, bool flag,
                                                   const std::vector<std::string>& values)>;

/// Parses a study file; errors name the file and the key (sim::InputError). `check` validates option
/// names against the program's commands (empty: not checked).
StudySpec parseStudy(const std::string& text, const std::string& source, const StudyOptionCheck& check = {});
/// Every task, in index order: cells x seeds (x shards), the last varying fastest.
std::vector<StudyTask> expandStudy(const StudySpec& s);
/// A task's seed: `seed` itself when seeds are common, else a hash of (seed, the cell's values).
std::uint64_t deriveSeed(std::uint64_t seed, const std::vector<std::string>& cell_values);
/// "experiment table5 ident=20": what a cell is, for people.
std::string describeCell(const StudySpec& s, const StudyTask& t);

/// Creates DIR (or checks that it holds the same study), writes study.yaml, study-origin.yaml and
/// tasks.csv. `origin` is the folder relative paths in the study resolve against.
void initStudyFolder(const StudySpec& s, const std::string& dir, const std::string& origin);
/// The study of a study folder (DIR/study.yaml), not re-checked against the program's options.
StudySpec loadStudyFolder(const std::string& dir);

enum class TaskState { kDone, kRunning, kQueued, kFailed, kMissing };
const char* taskStateName(TaskState s);
std::string taskFolder(const std::string& dir, int index);  ///< DIR/shards/task-NNNNNN

/// What the shard folders say: done, failed (job exited non-zero, or killed: an unlocked .tmp folder),
/// running (a locked .tmp folder) or missing.
TaskState taskStateOnDisk(const std::string& dir, int index);

/// Runs task `index` (the work of `orbcal study task`): locks DIR/shards/task-N.tmp, runs `orbcal`
/// (`program`) with the task's arguments and -o .tmp/out in the study's origin folder, its output into
/// log.txt, then renames the folder to task-N (exit 0) or task-N.failed. A finished task is not run
/// again. Returns the job's exit status (0: done). Throws InputError when the task is running elsewhere.
int runStudyTask(const std::string& dir, int index, const std::string& program);

/// Starts `program args...` in `cwd` with stdout and stderr appended to `log` (empty: inherited); the
/// child is killed when this process dies. Relative paths in `args` resolve from `cwd`; a relative
/// `log` from this process's folder. Returns its pid.
int spawnProcess(const std::string& program, const std::vector<std::string>& args, const std::string& cwd,
                 const std::string& log);
/// Waits for pid; its exit status (128 + signal when killed).
int waitProcess(int pid);

/// This program's path (/proc/self/exe).
std::string selfProgram();

// --- Running here --------------------------------------------------------------------------------
/// Reads a study file, checks it (`check`: option names and values, as parseStudy), and creates or checks
/// its folder DIR (relative paths in the study resolve against the study file's folder).
StudySpec prepareStudy(const std::string& study_file, const std::string& dir, const StudyOptionCheck& check = {});
/// The tasks of DIR not done yet, in index order; InputError naming DIR and the task when one is running or
/// queued elsewhere (Slurm or another process).
std::vector<int> tasksToRun(const std::string& dir, int count);
/// Runs the tasks `todo` of DIR, `jobs` at once, each as runStudyTask with `program`; progress as the
/// stage "study tasks" of `count`, counting those done before. Returns one line per failed task (its exit
/// status and log, or its error).
std::vector<std::string> runStudyTasks(const std::string& dir, int count, const std::vector<int>& todo, int jobs,
                                       const std::string& program, const ProgressFn& progress = {});
/// Polls DIR's task states (studyTaskStates) every 2 s until none is running or queued, with progress as
/// the stage "study tasks"; returns the last states.
std::vector<TaskState> waitForStudy(const std::string& dir, int count, const ProgressFn& progress = {});
/// Task indices by state.
std::map<TaskState, std::vector<int>> tasksByState(const std::vector<TaskState>& states);
/// What `orbcal study status` prints: the counts per state, the tasks of each unfinished state, the done
/// tasks' wall times (what slurm.time must cover) and where the first failed task's output is.
std::string formatStudyStatus(const std::string& dir, const std::vector<TaskState>& states);

// --- Slurm ---------------------------------------------------------------------------------------
struct SlurmSubmitOptions {
  std::string partition, account;
  std::string program;              ///< orbcal's path on the compute nodes (default: this program's)
  std::vector<std::string> extra;   ///< more sbatch arguments, verbatim (#SBATCH lines of the script)
  bool wait = false;                ///< sbatch --wait: return when the array has finished
  bool dry_run = false;             ///< write the scripts, do not submit
  int max_array_size = 1000;        ///< Slurm's MaxArraySize - 1 by default: larger studies go in chunks
};
struct SlurmSubmission {
  std::vector<std::string> scripts;   ///< written
  std::vector<std::string> job_ids;   ///< submitted
  std::vector<int> tasks;             ///< the task indices submitted
};
/// "0-3,7,9-12": task indices (sorted) as an sbatch --array list.
std::string arrayRanges(const std::vector<int>& sorted);
/// Writes DIR/slurm/submit-K.sh for the tasks that are neither done nor running or queued, and runs
/// sbatch on it (unless dry_run). Throws InputError with sbatch's message when it fails.
SlurmSubmission submitStudy(const std::string& dir, const SlurmSubmitOptions& o);
/// The Slurm state of the study's submitted array tasks (squeue, then sacct where accounting is on):
/// task index -> RUNNING, PENDING, FAILED, CANCELLED, ... Empty where Slurm is not reachable.
std::map<int, std::string> slurmTaskStates(const std::string& dir);
/// taskStateOnDisk, refined by the Slurm states (queued, running, failed when cancelled or timed out).
std::vector<TaskState> studyTaskStates(const std::string& dir, int count);

// --- Merge ---------------------------------------------------------------------------------------
struct MergeReport {
  std::vector<std::string> files;  ///< written, relative to the output folder
  std::string report_path;
};
/// Merges the finished tasks of DIR into `out` (default DIR/merged): every CSV of the jobs' outputs
/// concatenated in task order with the task's columns first (task, cell, replicate, seed, grid values);
/// per summary spec the mean, standard deviation and 95 % confidence interval (Student's t) of each value
/// over the seeds, per cell and key; render studies: each dataset's shards merged into one dataset with
/// one manifest. The merged files depend only on the tasks' results. Throws InputError naming the tasks
/// not done.
MergeReport mergeStudy(const std::string& dir, const std::string& out, bool plots, const Callbacks& callbacks = {});

}  // namespace orbcal::workflow
