// Studies: running tasks as child processes (study.hpp).
#include "orbcal/workflow/study.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <mutex>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <set>
#include <sstream>
#include <thread>
#include <tuple>

#include "orbcal/workflow/experiment.hpp"
#include "orbcal/calib/diagnose.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/workflow/callbacks.hpp"
#include "study_detail.hpp"

namespace fs = std::filesystem;

namespace orbcal::workflow {

using sim::InputError;
using namespace study_detail;

// --- processes -----------------------------------------------------------------------------------

int spawnProcess(const std::string& program, const std::vector<std::string>& args, const std::string& cwd,
                 const std::string& log) {
  std::vector<std::string> argv_s{program};
  argv_s.insert(argv_s.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : argv_s) argv.push_back(a.data());
  argv.push_back(nullptr);
  const std::string no_cwd = "orbcal: cannot enter the task's working folder " + cwd + "\n";  // built before the fork
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) throw InputError(program + ": cannot start: fork failed");
  if (pid == 0) {
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);  // a killed task takes its job with it
    if (::getppid() != parent) ::_exit(137);
    // The log first: a relative `log` names a file from the caller's folder, not from `cwd`.
    if (!log.empty()) {
      const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
      if (fd < 0) ::_exit(126);
      ::dup2(fd, 1);
      ::dup2(fd, 2);
      ::close(fd);
      const int in = ::open("/dev/null", O_RDONLY);
      if (in >= 0) ::dup2(in, 0);
    }
    if (!cwd.empty() && ::chdir(cwd.c_str()) != 0) {
      [[maybe_unused]] const ssize_t w = ::write(2, no_cwd.data(), no_cwd.size());
      ::_exit(126);
    }
    ::execv(program.c_str(), argv.data());
    const char msg[] = "orbcal: cannot execute the task's program\n";
    [[maybe_unused]] const ssize_t w = ::write(2, msg, sizeof msg - 1);
    ::_exit(127);
  }
  return pid;
}

int waitProcess(int pid) {
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) return 255;
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

std::string selfProgram() {
  std::error_code ec;
  const fs::path p = fs::read_symlink("/proc/self/exe", ec);
  if (ec) throw InputError("/proc/self/exe: cannot find this program's path: " + ec.message());
  return p.string();
}

// --- one task ------------------------------------------------------------------------------------

int runStudyTask(const std::string& dir, int index, const std::string& program) {
  const StudySpec s = loadStudyFolder(dir);
  const std::vector<StudyTask> tasks = expandStudy(s);
  if (index < 0 || index >= static_cast<int>(tasks.size())) {
    throw InputError("--index: " + std::to_string(index) + " is outside the study's tasks 0.." +
                     std::to_string(tasks.size() - 1) + " (" + dir + "/tasks.csv)");
  }
  const StudyTask& t = tasks[index];
  const std::string final_dir = taskFolder(dir, index), tmp = final_dir + ".tmp";
  if (exists(final_dir + "/task.yaml")) return 0;  // done earlier (a resubmitted array may hold it again)
  sim::makeDirectories(tmp);
  // Throws when the task runs elsewhere. `study status` (and `submit --wait`, every 2 s) probes the lock
  // for a moment: a few tries within a second tell that probe from a task that holds it.
  std::unique_ptr<sim::FolderLock> lock;
  for (int attempt = 0; !lock; ++attempt) {
    try {
      lock = std::make_unique<sim::FolderLock>(tmp, "orbcal study task " + std::to_string(index));
    } catch (const InputError&) {
      if (attempt == 20) throw;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }
  for (const auto& entry : fs::directory_iterator(tmp)) {  // what a killed attempt left
    if (entry.path().filename() != sim::kFolderLockName) removeAll(entry.path().string());
  }
  const std::string out = fs::absolute(tmp + "/out").lexically_normal().string();
  std::vector<std::string> args = t.args;
  args.insert(args.end(), {"-o", out});
  const auto t0 = std::chrono::steady_clock::now();
  const int status = waitProcess(spawnProcess(program, args, s.origin, tmp + "/log.txt"));
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (status == 0 && !s.keep_datasets && s.job != "render") removeAll(out + "/datasets");
  char host[256] = "";
  ::gethostname(host, sizeof host - 1);
  std::ostringstream y;
  y << "index: " << t.index << "\ncell: " << t.cell << "\nreplicate: " << t.replicate << "\nshard: " << t.shard
    << "\nseed: " << t.seed << "\ngrid: {";
  for (std::size_t k = 0; k < s.grid.size(); ++k) y << (k ? ", " : "") << s.grid[k].first << ": " << yamlQuote(t.cell_values[k]);
  y << "}\ncommand: " << yamlQuote(joinArgs({program}) + " " + joinArgs(args)) << "\nexit_status: " << status
    << "\nseconds: " << formatNumber("%.3f", seconds) << "\nhost: " << yamlQuote(host) << "\n";
  const char* job_id = std::getenv("SLURM_JOB_ID");
  if (job_id) y << "slurm_job: " << yamlQuote(job_id) << "\n";
  sim::writeFileAtomic(tmp + "/task.yaml", y.str());
  const std::string target = status == 0 ? final_dir : final_dir + ".failed";
  removeAll(target);
  if (std::rename(tmp.c_str(), target.c_str()) != 0) {
    throw InputError(tmp + ": cannot rename to " + target + ": " + std::strerror(errno));
  }
  ::unlink((target + "/" + sim::kFolderLockName).c_str());
  if (status == 0) removeAll(final_dir + ".failed");
  return status;
}

}  // namespace orbcal::workflow

namespace orbcal::workflow {

// --- running here ---------------------------------------------------------------------------------

StudySpec prepareStudy(const std::string& study_file, const std::string& dir, const StudyOptionCheck& check) {
  const StudySpec s = parseStudy(sim::readTextSource(study_file), study_file, check);
  const std::string origin = fs::absolute(fs::path(study_file)).parent_path().lexically_normal().string();
  initStudyFolder(s, dir, origin);
  return s;
}

std::vector<int> tasksToRun(const std::string& dir, int count) {
  std::vector<int> todo;
  const std::vector<TaskState> before = studyTaskStates(dir, count);
  for (int i = 0; i < count; ++i) {
    if (before[i] == TaskState::kRunning || before[i] == TaskState::kQueued) {
      throw InputError(dir + ": task " + std::to_string(i) + " is " + taskStateName(before[i]) +
                       " elsewhere (Slurm or another process); wait for it, see `orbcal study status " + dir + "`");
    }
    if (before[i] != TaskState::kDone) todo.push_back(i);
  }
  return todo;
}

std::vector<std::string> runStudyTasks(const std::string& dir, int count, const std::vector<int>& todo, int jobs,
                                       const std::string& program, const ProgressFn& progress) {
  Progress bar(progress, "study tasks", count);
  std::atomic<int> next{0}, done{count - static_cast<int>(todo.size())};
  std::mutex m;
  std::vector<std::string> failures;
  bar.update(done);
  std::vector<std::thread> workers;
  for (int w = 0; w < std::min<int>(jobs, static_cast<int>(todo.size())); ++w) {
    workers.emplace_back([&] {
      for (int k; (k = next++) < static_cast<int>(todo.size());) {
        std::string failure;
        try {
          const int status = runStudyTask(dir, todo[k], program);
          if (status != 0) failure = "task " + std::to_string(todo[k]) + ": exit status " + std::to_string(status) + ", see " +
                                     taskFolder(dir, todo[k]) + ".failed/log.txt";
        } catch (const std::exception& e) {
          failure = "task " + std::to_string(todo[k]) + ": " + e.what();
        }
        const std::lock_guard<std::mutex> g(m);
        if (!failure.empty()) failures.push_back(failure);
        bar.update(++done);
      }
    });
  }
  for (std::thread& t : workers) t.join();
  return failures;
}

std::map<TaskState, std::vector<int>> tasksByState(const std::vector<TaskState>& states) {
  std::map<TaskState, std::vector<int>> by_state;
  for (std::size_t i = 0; i < states.size(); ++i) by_state[states[i]].push_back(static_cast<int>(i));
  return by_state;
}

std::vector<TaskState> waitForStudy(const std::string& dir, int count, const ProgressFn& progress) {
  Progress bar(progress, "study tasks", count);
  for (;;) {
    std::vector<TaskState> states = studyTaskStates(dir, count);
    const auto by_state = tasksByState(states);
    bar.update(by_state.count(TaskState::kDone) ? static_cast<int>(by_state.at(TaskState::kDone).size()) : 0);
    if (!by_state.count(TaskState::kRunning) && !by_state.count(TaskState::kQueued)) return states;
    std::this_thread::sleep_for(std::chrono::seconds(2));
  }
}

namespace {

/// The done tasks' wall times (task.yaml): what the study's slurm.time must cover.
std::string doneWallTimes(const std::string& dir, const std::vector<int>& done) {
  double total = 0, longest = 0;
  int longest_task = 0;
  for (int i : done) {
    const double t = sim::ConfigNode::load(taskFolder(dir, i) + "/task.yaml")["seconds"].asDouble();
    total += t;
    if (t > longest) longest = t, longest_task = i;
  }
  char line[200];
  std::snprintf(line, sizeof line, "  done tasks' wall time: mean %.1f s, longest %.1f s (task %d), sum %.1f s\n",
                total / static_cast<double>(done.size()), longest, longest_task, total);
  return line;
}

}  // namespace

std::string formatStudyStatus(const std::string& dir, const std::vector<TaskState>& states) {
  const auto by_state = tasksByState(states);
  std::string out = dir + ": " + std::to_string(states.size()) + " tasks:";
  for (TaskState s : {TaskState::kDone, TaskState::kRunning, TaskState::kQueued, TaskState::kFailed, TaskState::kMissing}) {
    const auto it = by_state.find(s);
    out += " " + std::to_string(it == by_state.end() ? 0 : it->second.size()) + " " + taskStateName(s) +
           (s == TaskState::kMissing ? "\n" : ",");
  }
  for (TaskState s : {TaskState::kRunning, TaskState::kQueued, TaskState::kFailed, TaskState::kMissing}) {
    const auto it = by_state.find(s);
    if (it != by_state.end()) out += std::string("  ") + taskStateName(s) + ": " + arrayRanges(it->second) + "\n";
  }
  if (by_state.count(TaskState::kDone)) out += doneWallTimes(dir, by_state.at(TaskState::kDone));
  if (by_state.count(TaskState::kFailed)) {
    const std::string folder = taskFolder(dir, by_state.at(TaskState::kFailed).front());
    const bool killed = !fs::exists(folder + ".failed") && fs::exists(folder + ".tmp");
    out += "  the first failed task's output: " + folder + (killed ? ".tmp" : ".failed") + "/log.txt" +
           (killed ? ", killed while running" : "") + " (Slurm's logs: " + dir + "/slurm/logs)\n";
  }
  return out;
}

}  // namespace orbcal::workflow
