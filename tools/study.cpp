// Studies: parsing, tasks, running one task, Slurm submission and state, merging (study.hpp).
#include "study.hpp"

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

#include "experiment.hpp"
#include "orbcal/calib/diagnose.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/fileio.hpp"

namespace fs = std::filesystem;

namespace orbcal::tools {

namespace {

using sim::InputError;

const std::vector<std::string> kJobs{"experiment", "run", "diagnose-study", "render"};
/// Options the study sets itself on every task.
const std::set<std::string> kReserved{"o", "out", "seed", "shard", "preset", "help", "h"};

/// A scalar that becomes one command-line argument or one CSV cell.
std::string cellValue(const sim::ConfigNode& n) {
  if (!n.isScalar()) n.fail("expected a single value (a number or a word)");
  const std::string v = n.asString();
  if (v.find_first_of(",\n\r\"") != std::string::npos) n.fail("a value may not hold a comma, quote or line break");
  return v;
}

bool isTrue(const std::string& v) { return v == "true" || v == "yes" || v == "on"; }
bool isFalse(const std::string& v) { return v == "false" || v == "no" || v == "off"; }

std::string checkedOption(const sim::ConfigNode& n, const std::string& key, const std::string& job, bool flag,
                          const std::vector<std::string>& values, const StudyOptionCheck& check) {
  if (kReserved.count(key)) {
    n.fail("set by the study itself (-o, --seed, --shard and --preset come from the study's folder, seeds, shards and preset)");
  }
  if (check) {
    const std::string why = check(job, key, flag, values);
    if (!why.empty()) n.fail(why);
  }
  return key;
}

std::vector<std::string> stringList(const sim::ConfigNode& n) {
  if (!n.isSequence()) n.fail("expected a list");
  std::vector<std::string> out;
  for (std::size_t i = 0; i < n.size(); ++i) out.push_back(cellValue(n[i]));
  return out;
}

/// Built-in summaries: the result table of each job, its identifying columns and its figures of merit.
std::vector<StudySummarySpec> builtinSummaries(const StudySpec& s) {
  const std::string p = s.job == "run" ? "main" : s.preset;
  if (s.job == "run" || p == "table4") {
    return {{p + "/summary.csv", {"method"}, {"avg_position_mm", "max_position_mm", "x_floor"}}};
  }
  if (p == "table5") return {{"table5/table5.csv", {"column", "method"}, {"avg_position_mm", "max_position_mm", "floor_avg_mm"}}};
  if (p == "fig8") return {{"fig8/fig8.csv", {"method", "n"}, {"avg_position_mm", "max_position_mm", "floor_mm"}}};
  if (p == "floor") return {{"floor/floor.csv", {}, {"avg_position_mm", "max_position_mm"}}};
  if (p == "selection") {
    return {{"selection/synthetic.csv", {"kind", "n", "chooser"}, {"avg_position_mm"}},
            {"selection/rendered.csv", {"chooser", "method"}, {"avg_position_mm", "x_floor"}}};
  }
  if (p == "jia2019") {
    return {{"jia2019/runs.csv", {"frame_change_mm", "model"}, {"position_mean_mm", "local_position_mean_mm", "orientation_mean_deg"}}};
  }
  if (p == "liu2012") return {{"liu2012/liu2012_runs.csv", {"model", "size"}, {"pos_rms_x_mm", "pos_rms_y_mm", "pos_rms_z_mm"}}};
  if (s.job == "diagnose-study") {
    return {{"diagnose_study.csv", {"injected"}, {"named_rate", "wrong_joint_rate", "other_rate", "clean_rate", "extra_rate"}}};
  }
  return {};
}

/// Figures redrawn per cell from the merged rows: (CSV, plot_report.py kind).
std::vector<std::pair<std::string, std::string>> builtinFigures(const StudySpec& s) {
  if (s.job == "run") return {{"main/validation_errors.csv", "boxplot"}};
  if (s.preset == "table4") return {{"table4/validation_errors.csv", "boxplot"}};
  if (s.preset == "table5") return {{"table5/validation_errors.csv", "boxplot"}};
  if (s.preset == "fig8") return {{"fig8/fig8.csv", "curve"}};
  return {};
}

std::string taskName(int index) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "task-%06d", index);
  return buf;
}

/// Columns that hold wall times, not results: left out of merged CSVs (they differ from run to run).
bool isTiming(const std::string& column) {
  return column == "seconds" || (column.size() > 8 && column.compare(column.size() - 8, 8, "_seconds") == 0);
}

std::string shellQuote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

/// A command line as a shell reads it back: arguments with other characters than [A-Za-z0-9_./:=+-] quoted.
std::string joinArgs(const std::vector<std::string>& args) {
  std::string out;
  for (const std::string& a : args) {
    const bool plain = !a.empty() && a.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_./:=+-") ==
                                         std::string::npos;
    out += (out.empty() ? "" : " ") + (plain ? a : shellQuote(a));
  }
  return out;
}

/// A YAML double-quoted scalar.
std::string yamlQuote(const std::string& text) {
  std::string out = "\"";
  for (char c : text) out += c == '"' || c == '\\' ? std::string("\\") + c : std::string(1, c);
  return out + "\"";
}

std::string joinList(const std::vector<std::string>& items) {
  std::string out;
  for (const std::string& a : items) out += (out.empty() ? "" : ", ") + a;
  return out;
}

/// What a Slurm query printed; empty where Slurm is not there or refuses (sacct without accounting).
std::string slurmQuery(const std::string& command) {
  auto [status, out] = shellOutput(command + " 2>/dev/null");
  return status == 0 ? out : std::string();
}

bool exists(const std::string& p) {
  std::error_code ec;
  return fs::exists(p, ec);
}

void removeAll(const std::string& p) {
  std::error_code ec;
  fs::remove_all(p, ec);
  if (ec) throw InputError(p + ": cannot remove: " + ec.message());
}

}  // namespace

// --- the study file ------------------------------------------------------------------------------

StudySpec parseStudy(const std::string& text, const std::string& source, const StudyOptionCheck& check) {
  const sim::ConfigNode root = sim::ConfigNode::parse(text, source);
  root.requireOnlyKeys({"format", "name", "job", "preset", "options", "grid", "seeds", "seed_derivation", "shards",
                        "keep_datasets", "slurm", "summary"});
  StudySpec s;
  s.source = source;
  s.text = text;
  if (root["format"].asString() != kStudyFormat) root["format"].fail(std::string("expected ") + kStudyFormat);
  s.job = root["job"].asString();
  if (std::find(kJobs.begin(), kJobs.end(), s.job) == kJobs.end()) {
    root["job"].fail("expected experiment, run, diagnose-study or render, got " + sim::quoteInput(s.job));
  }
  s.name = root.has("name") ? cellValue(root["name"]) : fs::path(source).stem().string();
  if (s.name.empty() || s.name.find_first_of(" /\t") != std::string::npos) {
    root["name"].fail("a name without spaces or slashes (it names the Slurm job)");
  }
  if (s.job == "experiment") {
    s.preset = root["preset"].asString();
    if (std::find(kExperimentPresets.begin(), kExperimentPresets.end(), s.preset) == kExperimentPresets.end()) {
      root["preset"].fail("not a preset of orbcal experiment: " + sim::quoteInput(s.preset));
    }
  } else if (root.has("preset")) {
    root["preset"].fail("only an experiment has a preset");
  }
  if (root.has("options")) {
    const sim::ConfigNode opts = root["options"];
    for (const std::string& key : opts.keys()) {
      const sim::ConfigNode v = opts[key];
      if (v.isSequence()) {  // an option that takes several values
        const std::vector<std::string> values = stringList(v);
        s.options.emplace_back(checkedOption(v, key, s.job, false, values, check), values);
        continue;
      }
      const std::string value = cellValue(v);
      if (isFalse(value)) continue;  // a flag left off
      const std::vector<std::string> values = isTrue(value) ? std::vector<std::string>{} : std::vector<std::string>{value};
      s.options.emplace_back(checkedOption(v, key, s.job, isTrue(value), values, check), values);
    }
  }
  if (root.has("grid")) {
    const sim::ConfigNode grid = root["grid"];
    for (const std::string& key : grid.keys()) {
      const sim::ConfigNode v = grid[key];
      checkedOption(v, key, s.job, false, {}, check);
      for (const auto& [name, value] : s.options) {
        if (name == key) v.fail("also in options: give an option either fixed or in the grid");
      }
      std::vector<std::string> values = stringList(v);
      for (std::size_t i = 0; i < values.size(); ++i) checkedOption(v[i], key, s.job, false, {values[i]}, check);
      if (values.empty()) v.fail("an empty list leaves the study without cells");
      if (std::set<std::string>(values.begin(), values.end()).size() != values.size()) v.fail("a value given twice");
      s.grid.emplace_back(key, std::move(values));
    }
  }
  const sim::ConfigNode seeds = root["seeds"];
  if (seeds.isMap()) {
    seeds.requireOnlyKeys({"first", "count"});
    const int first = seeds["first"].asInt(), count = seeds["count"].asInt();
    if (first < 0) seeds["first"].fail("a seed is a non-negative integer");
    if (count < 1 || count > 1000000) seeds["count"].fail("expected 1 to 1000000");
    for (int i = 0; i < count; ++i) s.seeds.push_back(static_cast<std::uint64_t>(first) + i);
  } else {
    for (std::size_t i = 0; i < seeds.size(); ++i) {
      const int v = seeds[i].asInt();
      if (v < 0) seeds[i].fail("a seed is a non-negative integer");
      s.seeds.push_back(static_cast<std::uint64_t>(v));
    }
    if (s.seeds.empty()) seeds.fail("no seeds");
    if (std::set<std::uint64_t>(s.seeds.begin(), s.seeds.end()).size() != s.seeds.size()) seeds.fail("a seed given twice");
  }
  const std::string derivation = root.optional("seed_derivation").asString("per-task");
  if (derivation != "per-task" && derivation != "common") root["seed_derivation"].fail("expected per-task or common");
  s.common_seeds = derivation == "common";
  s.shards = root.optional("shards").asInt(1);
  if (s.shards < 1 || s.shards > 100000) root["shards"].fail("expected 1 to 100000");
  if (s.shards > 1 && s.job != "render") root["shards"].fail("only a render study is split into shards");
  s.keep_datasets = root.optional("keep_datasets").asBool(false);
  if (root.has("slurm")) {
    const sim::ConfigNode sl = root["slurm"];
    sl.requireOnlyKeys({"throttle", "time", "mem", "cpus_per_task"});
    s.slurm.throttle = sl.optional("throttle").asInt(0);
    if (sl.has("throttle") && s.slurm.throttle < 1) sl["throttle"].fail("expected 1 or more (leave it out for no limit)");
    s.slurm.time = sl.optional("time").asString(s.slurm.time);
    if (s.slurm.time.find_first_not_of("0123456789:-") != std::string::npos) {
      sl["time"].fail("expected sbatch's --time: MINUTES, HH:MM:SS or D-HH:MM:SS");
    }
    s.slurm.mem = sl.optional("mem").asString(s.slurm.mem);
    if (s.slurm.mem.empty() || s.slurm.mem.find_first_not_of("0123456789KMGT") != std::string::npos ||
        !std::isdigit(static_cast<unsigned char>(s.slurm.mem[0]))) {
      sl["mem"].fail("expected sbatch's --mem, e.g. 4G or 4000M");
    }
    s.slurm.cpus_per_task = sl.optional("cpus_per_task").asInt(1);
    if (s.slurm.cpus_per_task < 1 || s.slurm.cpus_per_task > 4096) sl["cpus_per_task"].fail("expected 1 to 4096");
  }
  if (root.has("summary")) {
    const sim::ConfigNode list = root["summary"];
    for (std::size_t i = 0; i < list.size(); ++i) {
      const sim::ConfigNode e = list[i];
      e.requireOnlyKeys({"file", "keys", "values"});
      StudySummarySpec spec{e["file"].asString(), e.has("keys") ? stringList(e["keys"]) : std::vector<std::string>{},
                            stringList(e["values"])};
      if (spec.values.empty()) e["values"].fail("name at least one column to average");
      s.summaries.push_back(std::move(spec));
    }
  } else {
    s.summaries = builtinSummaries(s);
  }
  return s;
}

std::uint64_t deriveSeed(std::uint64_t seed, const std::vector<std::string>& cell_values) {
  std::string key = std::to_string(seed);
  for (const std::string& v : cell_values) key += '\0' + v;
  std::uint64_t z = fingerprint(key) + 0x9e3779b97f4a7c15ULL;  // splitmix64's finaliser spreads the bits
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  z ^= z >> 31;
  return 1 + z % 2147483646ULL;  // 1 .. 2^31 - 1: a seed any option parser takes
}

std::vector<StudyTask> expandStudy(const StudySpec& s) {
  std::size_t cells = 1;
  for (const auto& [key, values] : s.grid) cells *= values.size();
  std::vector<StudyTask> tasks;
  for (std::size_t c = 0; c < cells; ++c) {
    std::vector<std::string> values;
    std::size_t rest = c;
    for (std::size_t k = s.grid.size(); k-- > 0;) {  // the last key varies fastest
      values.insert(values.begin(), s.grid[k].second[rest % s.grid[k].second.size()]);
      rest /= s.grid[k].second.size();
    }
    for (std::size_t r = 0; r < s.seeds.size(); ++r) {
      for (int shard = 0; shard < s.shards; ++shard) {
        StudyTask t;
        t.index = static_cast<int>(tasks.size());
        t.cell = static_cast<int>(c);
        t.replicate = static_cast<int>(r);
        t.shard = shard;
        t.cell_values = values;
        t.seed = s.common_seeds ? s.seeds[r] : deriveSeed(s.seeds[r], values);
        t.args.push_back(s.job);
        if (!s.preset.empty()) t.args.insert(t.args.end(), {"--preset", s.preset});
        for (const auto& [key, values] : s.options) {
          t.args.push_back("--" + key);
          t.args.insert(t.args.end(), values.begin(), values.end());
        }
        for (std::size_t k = 0; k < s.grid.size(); ++k) t.args.insert(t.args.end(), {"--" + s.grid[k].first, values[k]});
        t.args.insert(t.args.end(), {"--seed", std::to_string(t.seed)});
        if (s.shards > 1) t.args.insert(t.args.end(), {"--shard", std::to_string(shard) + "/" + std::to_string(s.shards)});
        tasks.push_back(std::move(t));
      }
    }
  }
  return tasks;
}

std::string describeCell(const StudySpec& s, const StudyTask& t) {
  std::string out;
  for (std::size_t k = 0; k < s.grid.size(); ++k) out += (out.empty() ? "" : ", ") + s.grid[k].first + " " + t.cell_values[k];
  return out.empty() ? "(one cell)" : out;
}

// --- the study folder ----------------------------------------------------------------------------

void initStudyFolder(const StudySpec& s, const std::string& dir, const std::string& origin) {
  sim::makeDirectories(dir + "/shards");
  const std::string copy = dir + "/study.yaml";
  if (exists(copy) && sim::readTextSource(copy) != s.text) {
    throw InputError(copy + ": this folder holds another study (its study.yaml differs from " + s.source +
                     "); give another -o, or delete the folder");
  }
  if (!exists(copy)) sim::writeFileAtomic(copy, s.text);
  sim::writeFileAtomic(dir + "/study-origin.yaml", "# where the study's relative paths resolve, and its name\norigin: " +
                                                     yamlQuote(origin) + "\nname: " + yamlQuote(s.name) + "\n");
  std::ostringstream csv;
  csv << "index,cell,replicate,shard,seed";
  for (const auto& [key, values] : s.grid) csv << "," << key;
  csv << ",command\n";
  for (const StudyTask& t : expandStudy(s)) {
    csv << t.index << "," << t.cell << "," << t.replicate << "," << t.shard << "," << t.seed;
    for (const std::string& v : t.cell_values) csv << "," << v;
    csv << ",orbcal " << joinArgs(t.args) << "\n";
  }
  sim::writeFileAtomic(dir + "/tasks.csv", csv.str());
}

StudySpec loadStudyFolder(const std::string& dir) {
  const std::string path = dir + "/study.yaml";
  if (!exists(path)) throw InputError(dir + ": not a study folder (no study.yaml): start it with `orbcal study run` or `orbcal study submit`");
  StudySpec s = parseStudy(sim::readTextSource(path), path);
  const sim::ConfigNode origin = sim::ConfigNode::load(dir + "/study-origin.yaml");
  s.origin = origin["origin"].asString();
  // Without a `name:` the name is the original file's stem, not "study".
  if (origin.has("name")) s.name = origin["name"].asString();
  return s;
}

const char* taskStateName(TaskState s) {
  switch (s) {
    case TaskState::kDone: return "done";
    case TaskState::kRunning: return "running";
    case TaskState::kQueued: return "queued";
    case TaskState::kFailed: return "failed";
    case TaskState::kMissing: return "missing";
  }
  return "?";
}

std::string taskFolder(const std::string& dir, int index) { return dir + "/shards/" + taskName(index); }

TaskState taskStateOnDisk(const std::string& dir, int index) {
  const std::string folder = taskFolder(dir, index);
  if (exists(folder + "/task.yaml")) return TaskState::kDone;
  if (exists(folder + ".tmp")) {
    try {
      sim::FolderLock probe(folder + ".tmp", "orbcal study status");
    } catch (const InputError&) {
      return TaskState::kRunning;  // locked: its task process is alive
    }
    return TaskState::kFailed;  // unlocked: the task was killed
  }
  if (exists(folder + ".failed")) return TaskState::kFailed;
  return TaskState::kMissing;
}

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

// --- merge ---------------------------------------------------------------------------------------

namespace {

struct MergedTable {
  std::vector<std::string> header;                 ///< the job's columns (timings left out)
  std::vector<int> source_columns;                 ///< their columns in the job's file
  std::vector<std::pair<int, std::vector<std::string>>> rows;  ///< (task, cells)
};

void collectCsvs(const fs::path& root, const fs::path& here, std::set<std::string>& out) {
  std::vector<fs::path> entries;
  for (const auto& e : fs::directory_iterator(here)) entries.push_back(e.path());
  std::sort(entries.begin(), entries.end());
  for (const fs::path& p : entries) {
    if (fs::is_directory(p)) {
      if (p.filename() != "datasets") collectCsvs(root, p, out);
    } else if (p.extension() == ".csv") {
      out.insert(fs::relative(p, root).generic_string());
    }
  }
}

std::string prefixHeader(const StudySpec& s) {
  std::string h = "task,cell,replicate,seed";
  for (const auto& [key, values] : s.grid) h += "," + key;
  return h;
}

std::string prefixCells(const StudyTask& t) {
  std::string h = std::to_string(t.index) + "," + std::to_string(t.cell) + "," + std::to_string(t.replicate) + "," +
                  std::to_string(t.seed);
  for (const std::string& v : t.cell_values) h += "," + v;
  return h;
}

/// "2.432 +- 0.093 [2.414, 2.451]": the standard deviation to two significant digits, the mean and the
/// interval to the same decimal place (a spread of 0 or a single seed: four significant digits).
std::string markdownCell(double mean, double sd, double half, std::size_t n) {
  if (n == 0) return "-";
  if (!(sd > 0.0) || !std::isfinite(sd)) return formatNumber("%.4g", mean) + (sd == 0.0 && n > 1 ? " +- 0" : "");
  const int decimals = std::clamp(1 - static_cast<int>(std::floor(std::log10(sd))), 0, 12);
  const std::string f = "%." + std::to_string(decimals) + "f";
  return formatNumber(f.c_str(), mean) + " +- " + formatNumber(f.c_str(), sd) + " [" + formatNumber(f.c_str(), mean - half) +
         ", " + formatNumber(f.c_str(), mean + half) + "]";
}

/// One summary: per cell and key, n, mean, std and the 95 % t interval of each value; CSV and markdown.
std::pair<std::string, std::string> summarize(const StudySpec& s, const std::vector<StudyTask>& tasks,
                                              const StudySummarySpec& spec, const MergedTable& t) {
  auto col = [&](const std::string& name) {
    const auto it = std::find(t.header.begin(), t.header.end(), name);
    if (it == t.header.end()) {
      throw InputError(s.source + ": summary " + spec.file + ": no column '" + name + "' in the jobs' " + spec.file);
    }
    return static_cast<int>(it - t.header.begin());
  };
  std::vector<int> keys, values;
  for (const std::string& k : spec.keys) keys.push_back(col(k));
  for (const std::string& v : spec.values) values.push_back(col(v));
  // Groups in order of first appearance, each with its first row's task (whose cell values it shows).
  std::vector<std::pair<std::pair<int, std::vector<std::string>>, int>> order;
  std::map<std::pair<int, std::vector<std::string>>, std::vector<std::vector<double>>> groups;
  for (const auto& [task, cells] : t.rows) {
    std::pair<int, std::vector<std::string>> g{tasks[task].cell, {}};
    for (int k : keys) g.second.push_back(cells[k]);
    auto [it, fresh] = groups.try_emplace(g, std::vector<std::vector<double>>(values.size()));
    if (fresh) order.emplace_back(g, task);
    for (std::size_t v = 0; v < values.size(); ++v) {
      const std::string& c = cells[values[v]];
      if (c.empty()) continue;  // a value the job left empty on this row
      char* end = nullptr;
      const double x = std::strtod(c.c_str(), &end);
      if (end == c.c_str() || *end != '\0' || !std::isfinite(x)) {
        throw InputError(spec.file + ": task " + std::to_string(task) + ": " + spec.values[v] + ": expected a number, got " +
                         sim::quoteInput(c));
      }
      it->second[v].push_back(x);
    }
  }
  std::ostringstream csv, md;
  csv << "cell";
  for (const auto& [key, vals] : s.grid) csv << "," << key;
  for (const std::string& k : spec.keys) csv << "," << k;
  csv << ",n";
  for (const std::string& v : spec.values) csv << "," << v << "_mean," << v << "_std," << v << "_ci95_low," << v << "_ci95_high";
  csv << "\n";
  md << "### " << spec.file << "\n\nPer cell" << (spec.keys.empty() ? "" : " and " + joinList(spec.keys))
     << ": mean +- standard deviation over the seeds [95 % confidence interval of the mean, Student's t]; n rows.\n\n|";
  for (const auto& [key, vals] : s.grid) md << " " << key << " |";
  for (const std::string& k : spec.keys) md << " " << k << " |";
  md << " n |";
  for (const std::string& v : spec.values) md << " " << v << " |";
  md << "\n|";
  for (std::size_t i = 0; i < s.grid.size() + spec.keys.size() + 1 + spec.values.size(); ++i) md << "---|";
  md << "\n";
  for (const auto& [g, first] : order) {
    const auto& data = groups[g];
    csv << g.first;
    md << "|";
    for (const std::string& v : tasks[first].cell_values) {
      csv << "," << v;
      md << " " << v << " |";
    }
    for (const std::string& k : g.second) {
      csv << "," << k;
      md << " " << k << " |";
    }
    const std::size_t n = data.empty() ? 0 : data[0].size();
    csv << "," << n;
    md << " " << n << " |";
    for (const std::vector<double>& x : data) {
      const auto [mean, sd] = meanAndStd(x);
      const double half = x.size() > 1 ? calib::studentTCritical(0.05, x.size() - 1.0) * sd / std::sqrt(double(x.size())) : 0.0;
      if (x.empty()) {
        csv << ",,,,";
      } else {
        csv << "," << formatNumber("%.9g", mean) << "," << formatNumber("%.9g", sd) << "," << formatNumber("%.9g", mean - half)
            << "," << formatNumber("%.9g", mean + half);
      }
      md << " " << markdownCell(mean, sd, half, x.size()) << " |";
    }
    csv << "\n";
    md << "\n";
  }
  return {csv.str(), md.str()};
}

}  // namespace

MergeReport mergeStudy(const std::string& dir, const std::string& out_arg, bool plots) {
  const StudySpec s = loadStudyFolder(dir);
  const std::vector<StudyTask> tasks = expandStudy(s);
  const std::vector<TaskState> states = studyTaskStates(dir, static_cast<int>(tasks.size()));
  std::map<TaskState, std::vector<int>> not_done;
  for (std::size_t i = 0; i < states.size(); ++i) {
    if (states[i] != TaskState::kDone) not_done[states[i]].push_back(static_cast<int>(i));
  }
  if (!not_done.empty()) {
    std::string what;
    std::size_t total = 0;
    for (const auto& [state, list] : not_done) {
      what += (what.empty() ? "" : "; ") + std::string(taskStateName(state)) + ": " + arrayRanges(list);
      total += list.size();
    }
    throw InputError(dir + ": " + std::to_string(total) + " of " + std::to_string(tasks.size()) + " tasks are not done (" +
                     what + "); run `orbcal study run` or `orbcal study submit` again, then merge");
  }
  const std::string out = out_arg.empty() ? dir + "/merged" : out_arg;
  sim::StagedFolder staged(out);  // a merge that fails leaves no half-built folder behind
  const std::string& tmp = staged.path();
  MergeReport report;
  std::ostringstream md;
  std::size_t cells = 1;
  for (const auto& [key, values] : s.grid) cells *= values.size();
  md << "# Study " << s.name << ": orbcal " << s.job << (s.preset.empty() ? "" : " --preset " + s.preset) << "\n\n"
     << cells << " cell" << (cells > 1 ? "s" : "") << " x " << s.seeds.size() << " seed" << (s.seeds.size() > 1 ? "s" : "")
     << (s.shards > 1 ? " x " + std::to_string(s.shards) + " shards" : "") << " = " << tasks.size()
     << " tasks, each run as `orbcal study task` (locally or as a Slurm array task); seeds "
     << (s.common_seeds ? "as listed, the same in every cell" : "derived from each listed seed and the cell's values")
     << " (`tasks.csv` has every task's command).\n\n";
  if (!s.options.empty()) {
    md << "Fixed options:";
    for (const auto& [key, values] : s.options) md << " `--" << key << (values.empty() ? "" : " " + joinList(values)) << "`";
    md << "\n\n";
  }
  for (const auto& [key, values] : s.grid) md << "- grid `--" << key << "`: " << joinArgs(values) << "\n";
  if (!s.grid.empty()) md << "\n";

  if (s.job == "render") {
    // One dataset per (cell, seed): its shards merged into one folder with one manifest.
    md << "## Datasets\n\n| dataset | cell | seed | shards | samples |\n|---|---|---|---|---|\n";
    for (std::size_t first = 0; first < tasks.size(); first += s.shards) {
      const StudyTask& t = tasks[first];
      std::vector<std::string> shard_dirs;
      for (int k = 0; k < s.shards; ++k) shard_dirs.push_back(taskFolder(dir, t.index + k) + "/out");
      const std::string name = "datasets/cell-" + std::to_string(t.cell) + "-seed-" + std::to_string(t.seed);
      sim::makeDirectories(tmp + "/datasets");
      const int samples = sim::mergeDatasetShards(shard_dirs, tmp + "/" + name).samples;
      report.files.push_back(name);
      md << "| `" << name << "` | " << describeCell(s, t) << " | " << t.seed << " | " << s.shards << " | " << samples << " |\n";
    }
  } else {
    std::set<std::string> relpaths;
    for (const StudyTask& t : tasks) {
      const fs::path root = taskFolder(dir, t.index) + "/out";
      if (fs::is_directory(root)) collectCsvs(root, root, relpaths);
    }
    std::map<std::string, MergedTable> tables;
    for (const std::string& rel : relpaths) {
      MergedTable& m = tables[rel];
      std::vector<std::string> full_header;
      std::ostringstream csv;
      for (const StudyTask& t : tasks) {
        const std::string path = taskFolder(dir, t.index) + "/out/" + rel;
        if (!exists(path)) continue;
        const sim::CsvTable table = sim::CsvTable::parse(sim::readTextSource(path), path);
        if (full_header.empty() && m.rows.empty()) {
          full_header = table.header();
          for (std::size_t c = 0; c < full_header.size(); ++c) {
            if (isTiming(full_header[c])) continue;
            m.header.push_back(full_header[c]);
            m.source_columns.push_back(static_cast<int>(c));
          }
          csv << prefixHeader(s);
          for (const std::string& h : m.header) csv << "," << h;
          csv << "\n";
        } else if (table.header() != full_header) {
          throw InputError(path + ": header differs from the other tasks' " + rel);
        }
        for (std::size_t r = 0; r < table.rows(); ++r) {
          std::vector<std::string> cells;
          csv << prefixCells(t);
          for (int c : m.source_columns) {
            cells.push_back(table.cell(r, c));
            csv << "," << table.cell(r, c);
          }
          csv << "\n";
          m.rows.emplace_back(t.index, std::move(cells));
        }
      }
      sim::makeDirectories(fs::path(tmp + "/" + rel).parent_path().string());
      sim::writeFileAtomic(tmp + "/" + rel, csv.str());
      report.files.push_back(rel);
    }
    md << "## Summaries\n\n";
    for (const StudySummarySpec& spec : s.summaries) {
      const auto it = tables.find(spec.file);
      if (it == tables.end()) throw InputError(s.source + ": summary: no task wrote " + spec.file);
      const auto [csv, table] = summarize(s, tasks, spec, it->second);
      const std::string name = "summary/" + fs::path(spec.file).stem().string() + ".csv";
      sim::makeDirectories(tmp + "/summary");
      sim::writeFileAtomic(tmp + "/" + name, csv);
      report.files.push_back(name);
      md << table << "\nFile: `" << name << "`.\n\n";
    }
    // The presets' figures, per cell, from the merged rows of that cell.
    const auto figures = builtinFigures(s);
    if (!figures.empty()) md << "## Figures\n\n";
    ExperimentOptions plot_options;
    plot_options.plots = plots;
    for (const auto& [file, kind] : figures) {
      const auto it = tables.find(file);
      if (it == tables.end()) continue;
      for (std::size_t c = 0; c < cells; ++c) {
        std::ostringstream csv;
        for (std::size_t i = 0; i < it->second.header.size(); ++i) csv << (i ? "," : "") << it->second.header[i];
        csv << "\n";
        const StudyTask* first = nullptr;
        for (const auto& [task, row] : it->second.rows) {
          if (tasks[task].cell != static_cast<int>(c)) continue;
          first = first ? first : &tasks[task];
          for (std::size_t i = 0; i < row.size(); ++i) csv << (i ? "," : "") << row[i];
          csv << "\n";
        }
        if (!first) continue;
        const std::string stem = fs::path(file).stem().string() + "-cell-" + std::to_string(c);
        sim::makeDirectories(tmp + "/figures");
        sim::writeFileAtomic(tmp + "/figures/" + stem + ".csv", csv.str());
        md << (s.grid.empty() ? std::string("All seeds pooled") : "Cell " + std::to_string(c) + " (" + describeCell(s, *first) + "), all seeds pooled")
           << ":\n\n"
           << drawFigure(plot_options, tmp, kind + " '" + tmp + "/figures/" + stem + ".csv'", "figures/" + stem + ".png", stem)
           << "\n";
      }
    }
  }
  md << "\nFiles: the jobs' CSVs merged under their own names (columns task, cell, replicate, seed and the grid's first; "
        "wall-time columns left out), `summary/`, `figures/`, `tasks.csv`.\n";
  sim::writeFileAtomic(tmp + "/tasks.csv", sim::readTextSource(dir + "/tasks.csv"));
  sim::writeFileAtomic(tmp + "/report.md", md.str());
  staged.commit(/*replace=*/true);
  report.report_path = out + "/report.md";
  return report;
}

}  // namespace orbcal::tools
