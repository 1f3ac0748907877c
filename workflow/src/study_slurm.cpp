// Studies on Slurm: submission and task states (study.hpp).
#include "orbcal/workflow/study.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
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
#include "study_detail.hpp"

namespace fs = std::filesystem;

namespace orbcal::workflow {

using sim::InputError;
using namespace study_detail;

// --- Slurm ---------------------------------------------------------------------------------------

std::string arrayRanges(const std::vector<int>& sorted) {
  std::string out;
  for (std::size_t i = 0; i < sorted.size();) {
    std::size_t j = i;
    while (j + 1 < sorted.size() && sorted[j + 1] == sorted[j] + 1) ++j;
    out += (out.empty() ? "" : ",") + std::to_string(sorted[i]) + (j > i ? "-" + std::to_string(sorted[j]) : "");
    i = j + 1;
  }
  return out;
}

namespace {

struct SubmittedJob {
  std::string id;
  int offset = 0;
};

std::vector<SubmittedJob> submittedJobs(const std::string& dir) {
  std::vector<SubmittedJob> jobs;
  const std::string path = dir + "/slurm/jobs.csv";
  if (!exists(path)) return jobs;
  const sim::CsvTable t = sim::CsvTable::parse(sim::readTextSource(path), path);
  const int id = t.requireColumn("job_id"), offset = t.requireColumn("offset");
  for (std::size_t r = 0; r < t.rows(); ++r) jobs.push_back({t.cell(r, id), static_cast<int>(t.number(r, offset))});
  return jobs;
}

/// "1234_5" of the study's jobs -> (the job's place in jobs.csv, task index); (-1, -1) for others.
std::pair<int, int> arrayTask(const std::vector<SubmittedJob>& jobs, const std::string& job_step) {
  const std::size_t us = job_step.find('_');
  if (us == std::string::npos) return {-1, -1};
  const std::string id = job_step.substr(0, us), element = job_step.substr(us + 1);
  if (element.empty() || element.find_first_not_of("0123456789") != std::string::npos) return {-1, -1};  // "[5-9]" etc.
  for (std::size_t j = 0; j < jobs.size(); ++j) {
    if (jobs[j].id == id) return {static_cast<int>(j), jobs[j].offset + std::stoi(element)};
  }
  return {-1, -1};
}


}  // namespace

std::map<int, std::string> slurmTaskStates(const std::string& dir) {
  std::map<int, std::string> states;
  const std::vector<SubmittedJob> jobs = submittedJobs(dir);
  if (jobs.empty()) return states;
  std::string ids;
  for (const SubmittedJob& j : jobs) ids += (ids.empty() ? "" : ",") + j.id;
  // (source, job, task) -> state: sacct (where accounting is on) first, then squeue (live jobs and, for
  // a few minutes, finished ones), each in submission order, so the latest word on a task wins.
  std::map<std::tuple<int, int, int>, std::string> seen;
  std::istringstream acct(slurmQuery("sacct -n -P -X -j " + ids + " -o JobID,State"));
  for (std::string line; std::getline(acct, line);) {
    const std::size_t bar = line.find('|');
    if (bar == std::string::npos) continue;
    const auto [job, task] = arrayTask(jobs, line.substr(0, bar));
    const std::string state = line.substr(bar + 1);
    if (task >= 0) seen[{0, job, task}] = state.substr(0, state.find(' '));  // "CANCELLED by 0"
  }
  std::istringstream queue(slurmQuery("squeue -h -r --states=all -j " + ids + " -o '%i %T'"));
  for (std::string line; std::getline(queue, line);) {
    std::istringstream words(line);
    std::string step, state;
    if (!(words >> step >> state)) continue;
    const auto [job, task] = arrayTask(jobs, step);
    if (task >= 0) seen[{1, job, task}] = state;
  }
  for (const auto& [key, state] : seen) states[std::get<2>(key)] = state;
  return states;
}

std::vector<TaskState> studyTaskStates(const std::string& dir, int count) {
  const std::map<int, std::string> slurm = slurmTaskStates(dir);
  std::vector<TaskState> states;
  for (int i = 0; i < count; ++i) {
    TaskState s = taskStateOnDisk(dir, i);
    const auto it = slurm.find(i);
    if (s != TaskState::kDone && s != TaskState::kRunning && it != slurm.end()) {
      const std::string& q = it->second;
      if (q == "RUNNING" || q == "COMPLETING" || q == "CONFIGURING" || q == "STAGE_OUT") {
        s = TaskState::kRunning;
      } else if (q == "PENDING" || q == "REQUEUED" || q == "RESIZING" || q == "SUSPENDED" || q == "REQUEUE_HOLD") {
        s = TaskState::kQueued;
      } else if (q != "COMPLETED") {
        s = TaskState::kFailed;  // FAILED, CANCELLED, TIMEOUT, OUT_OF_MEMORY, NODE_FAIL, PREEMPTED, ...
      }
    }
    states.push_back(s);
  }
  return states;
}

SlurmSubmission submitStudy(const std::string& dir, const SlurmSubmitOptions& o) {
  const StudySpec s = loadStudyFolder(dir);
  const int count = static_cast<int>(expandStudy(s).size());
  const std::vector<TaskState> states = studyTaskStates(dir, count);
  SlurmSubmission sub;
  for (int i = 0; i < count; ++i) {
    if (states[i] == TaskState::kMissing || states[i] == TaskState::kFailed) sub.tasks.push_back(i);
  }
  if (sub.tasks.empty()) return sub;
  const std::string abs_dir = fs::absolute(dir).lexically_normal().string();
  const std::string program = o.program.empty() ? selfProgram() : o.program;
  sim::makeDirectories(abs_dir + "/slurm/logs");
  int k = 1;
  while (exists(abs_dir + "/slurm/submit-" + std::to_string(k) + ".sh") ||
         exists(abs_dir + "/slurm/submit-" + std::to_string(k) + "-0.sh")) {
    ++k;
  }
  // Slurm caps array indices (MaxArraySize, 1001 by default): a larger study goes in chunks, each
  // array index plus the chunk's offset being the task.
  std::map<int, std::vector<int>> chunks;
  for (int i : sub.tasks) chunks[i / o.max_array_size * o.max_array_size].push_back(i);
  for (const auto& [offset, indices] : chunks) {
    std::vector<int> local;
    for (int i : indices) local.push_back(i - offset);
    const std::string script = abs_dir + "/slurm/submit-" + std::to_string(k) +
                               (chunks.size() > 1 ? "-" + std::to_string(offset / o.max_array_size) : "") + ".sh";
    std::ostringstream sh;
    sh << "#!/bin/bash\n"
       << "# orbcal study " << s.name << ": tasks " << arrayRanges(indices) << " of " << count
       << " (written by `orbcal study submit`; task = array index + " << offset << ")\n"
       << "#SBATCH --job-name=orbcal-" << s.name << "\n"
       << "#SBATCH --array=" << arrayRanges(local) << (s.slurm.throttle > 0 ? "%" + std::to_string(s.slurm.throttle) : "") << "\n"
       << "#SBATCH --time=" << s.slurm.time << "\n"
       << "#SBATCH --mem=" << s.slurm.mem << "\n"
       << "#SBATCH --cpus-per-task=" << s.slurm.cpus_per_task << "\n"
       << "#SBATCH --ntasks=1\n"
       << "#SBATCH --output=" << abs_dir << "/slurm/logs/%A_%a.out\n";
    if (!o.partition.empty()) sh << "#SBATCH --partition=" << o.partition << "\n";
    if (!o.account.empty()) sh << "#SBATCH --account=" << o.account << "\n";
    for (const std::string& e : o.extra) sh << "#SBATCH " << e << "\n";
    sh << "set -euo pipefail\n"
       << "exec " << shellQuote(program) << " study task " << shellQuote(abs_dir) << " --index $((SLURM_ARRAY_TASK_ID + "
       << offset << "))\n";
    sim::writeFileAtomic(script, sh.str());
    ::chmod(script.c_str(), 0755);
    sub.scripts.push_back(script);
    if (o.dry_run) continue;
    std::string cmd = "sbatch --parsable";
    cmd += " " + shellQuote(script) + " 2>&1";
    auto [rc, output] = shellOutput(cmd);
    while (!output.empty() && (output.back() == '\n' || output.back() == ' ')) output.pop_back();
    const std::string id = output.substr(0, output.find(';'));  // "1234" or "1234;cluster"
    if (rc != 0 || id.empty() || id.find_first_not_of("0123456789") != std::string::npos) {
      throw InputError(script + ": sbatch failed: " + sim::printable(output, 300) +
                       " (is Slurm installed and SLURM_CONF set? the script is kept)");
    }
    std::string log = exists(abs_dir + "/slurm/jobs.csv") ? sim::readTextSource(abs_dir + "/slurm/jobs.csv") : "job_id,offset,tasks,script\n";
    std::string tasks_cell = arrayRanges(indices);
    std::replace(tasks_cell.begin(), tasks_cell.end(), ',', ' ');
    log += id + "," + std::to_string(offset) + "," + tasks_cell + "," + fs::path(script).filename().string() + "\n";
    sim::writeFileAtomic(abs_dir + "/slurm/jobs.csv", log);
    sub.job_ids.push_back(id);
  }
  return sub;
}

}  // namespace orbcal::workflow
