// Studies: the study file, its tasks and its folder (study.hpp); running, Slurm and merging are in study_run.cpp, study_slurm.cpp, study_merge.cpp.
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

namespace {

using sim::InputError;
using namespace study_detail;

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

}  // namespace

namespace study_detail {

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
  if (ec) throw sim::InputError(p + ": cannot remove: " + ec.message());
}

}  // namespace study_detail

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

}  // namespace orbcal::workflow
