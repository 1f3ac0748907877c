// Studies: the study file, its tasks and seeds, running them locally (resuming after kill -9),
// failed tasks, and the merge (its statistics recomputed here from the merged rows). The Slurm side is
// tests/slurm/ (a real one-node cluster).
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <regex>
#include <set>
#include <thread>

#include "orbcal/calib/diagnose.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/workflow/study.hpp"
#include "test_util.hpp"

namespace fs = std::filesystem;
using namespace orbcal;
using orbcal::test::inputError;

namespace {

/// `orbcal args...` through the shell, stdout and stderr into files; returns the exit status.
int runOrbcal(const std::string& args, const std::string& log) {
  const int rc = std::system((std::string(ORBCAL_BINARY) + " " + args + " >" + log + " 2>&1").c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

const char* kFloorStudy =
    "format: orbcal-study-1\n"
    "name: floor-grid\n"
    "job: experiment\n"
    "preset: floor\n"
    "options: {repetitions: 2, quiet: true}\n"
    "grid:\n"
    "  valid: [20, 40]\n"
    "  joint-noise-deg: [0.01, 0.02]\n"
    "seeds: {first: 1, count: 3}\n";

}  // namespace

TEST_CASE("a study file's grid and seeds give one task per cell and seed, each with its own seed", "[study]") {
  const workflow::StudySpec s = workflow::parseStudy(kFloorStudy, "floor.yaml");
  const std::vector<workflow::StudyTask> tasks = workflow::expandStudy(s);
  REQUIRE(tasks.size() == 2 * 2 * 3);
  // The first grid key varies slowest, the seeds fastest.
  CHECK(tasks[0].cell_values == std::vector<std::string>{"20", "0.01"});
  CHECK(tasks[3].cell_values == std::vector<std::string>{"20", "0.02"});
  CHECK(tasks[6].cell_values == std::vector<std::string>{"40", "0.01"});
  CHECK(tasks[4].replicate == 1);
  CHECK(tasks[4].cell == 1);
  const std::vector<std::string> expected{"experiment", "--preset", "floor", "--repetitions", "2", "--quiet", "--valid", "20",
                                          "--joint-noise-deg", "0.02", "--seed", std::to_string(tasks[4].seed)};
  CHECK(tasks[4].args == expected);
  // Per-task seeds: a function of (listed seed, cell) only, all different here, and in 1 .. 2^31 - 1.
  std::set<std::uint64_t> seeds;
  for (const auto& t : tasks) {
    seeds.insert(t.seed);
    CHECK(t.seed == workflow::deriveSeed(s.seeds[t.replicate], t.cell_values));
    CHECK(t.seed >= 1);
    CHECK(t.seed < (1ULL << 31));
  }
  CHECK(seeds.size() == tasks.size());
  CHECK(workflow::deriveSeed(1, {"20", "0.01"}) != workflow::deriveSeed(1, {"20", "0.02"}));
  // seed_derivation: common: the listed seeds themselves, the same in every cell.
  const workflow::StudySpec c = workflow::parseStudy(std::string(kFloorStudy) + "seed_derivation: common\n", "c.yaml");
  for (const auto& t : workflow::expandStudy(c)) CHECK(t.seed == 1 + static_cast<std::uint64_t>(t.replicate));
  CHECK(workflow::arrayRanges({0, 1, 2, 3, 7, 9, 10, 11}) == "0-3,7,9-11");
  CHECK(workflow::arrayRanges({5}) == "5");
}

TEST_CASE("a bad study file is refused at its own key", "[study]") {
  const auto error = [](const std::string& text) { return inputError([&] { workflow::parseStudy(text, "s.yaml"); }); };
  const std::string head = "format: orbcal-study-1\njob: experiment\npreset: floor\n";
  CHECK(error(head + "seeds: [1]\nbogus: 1\n").find("s.yaml: bogus: unknown key") == 0);
  CHECK(error("format: orbcal-study-1\njob: paint\nseeds: [1]\n").find("s.yaml: job: expected experiment") == 0);
  CHECK(error("format: orbcal-study-1\njob: experiment\npreset: table9\nseeds: [1]\n").find("s.yaml: preset: not a preset") == 0);
  CHECK(error(head + "seeds: [1, 2, 1]\n") == "s.yaml: seeds: a seed given twice");
  CHECK(error(head + "seeds: [1]\noptions: {seed: 3}\n").find("s.yaml: options.seed: set by the study itself") == 0);
  CHECK(error(head + "seeds: [1]\noptions: {valid: 3}\ngrid: {valid: [1, 2]}\n").find("s.yaml: grid.valid: also in options") == 0);
  CHECK(error(head + "seeds: [1]\ngrid: {valid: [1, 1]}\n") == "s.yaml: grid.valid: a value given twice");
  CHECK(error(head + "seeds: [1]\nshards: 4\n") == "s.yaml: shards: only a render study is split into shards");
  CHECK(error(head + "seeds: [1]\nslurm: {mem: lots}\n").find("s.yaml: slurm.mem: expected sbatch's --mem") == 0);
  CHECK(error(head + "seeds: [1]\ngrid: {errors: ['a,b']}\n").find("s.yaml: grid.errors[0]: a value may not hold a comma") == 0);
  CHECK(error(head + "seeds:\n") == "s.yaml: line 4: seeds: empty value");  // never a default
}

TEST_CASE("orbcal study run: every task, resumable, merged the same on one or two workers", "[study]") {
  const std::string dir = test::tempDir("study-floor");
  test::write(dir + "/floor.yaml", kFloorStudy);
  REQUIRE(runOrbcal("study run " + dir + "/floor.yaml -o " + dir + "/a -j 2 --no-plots", dir + "/a.log") == 0);
  REQUIRE(runOrbcal("study run " + dir + "/floor.yaml -o " + dir + "/b -j 1 --no-plots", dir + "/b.log") == 0);
  const std::string merged = test::slurp(dir + "/a/merged/floor/floor.csv");
  CHECK(merged == test::slurp(dir + "/b/merged/floor/floor.csv"));
  CHECK(test::slurp(dir + "/a/merged/summary/floor.csv") == test::slurp(dir + "/b/merged/summary/floor.csv"));

  // A task is the job run by hand with the task's seed: its CSV rows are that run's, after the task columns.
  const workflow::StudySpec s = workflow::parseStudy(kFloorStudy, "floor.yaml");
  const auto tasks = workflow::expandStudy(s);
  const workflow::StudyTask& t = tasks[7];
  std::string args;
  for (const std::string& a : t.args) args += a + " ";
  REQUIRE(runOrbcal(args + "-o " + dir + "/by-hand", dir + "/hand.log") == 0);
  const sim::CsvTable by_hand = sim::CsvTable::parse(test::slurp(dir + "/by-hand/floor/floor.csv"), "by hand");
  const sim::CsvTable m = sim::CsvTable::parse(merged, "merged");
  REQUIRE(m.rows() == tasks.size() * 2);  // two repetitions per task
  const int avg = m.requireColumn("avg_position_mm");
  for (std::size_t r = 0; r < 2; ++r) {
    const std::size_t row = 7 * 2 + r;
    CHECK(m.cell(row, m.requireColumn("task")) == "7");
    CHECK(m.cell(row, m.requireColumn("seed")) == std::to_string(t.seed));
    CHECK(m.cell(row, m.requireColumn("valid")) == "40");
    CHECK(m.cell(row, m.requireColumn("joint-noise-deg")) == "0.01");  // task 7 = cell 2 = (40, 0.01), seed 2
    CHECK(m.cell(row, avg) == by_hand.cell(r, by_hand.requireColumn("avg_position_mm")));
  }

  // The summary, recomputed here: per cell, mean, sample std and mean +- t(0.975, n-1) std / sqrt(n).
  const sim::CsvTable sum = sim::CsvTable::parse(test::slurp(dir + "/a/merged/summary/floor.csv"), "summary");
  REQUIRE(sum.rows() == 4);
  for (std::size_t c = 0; c < 4; ++c) {
    std::vector<double> x;
    for (std::size_t r = 0; r < m.rows(); ++r) {
      if (m.cell(r, m.requireColumn("cell")) == std::to_string(c)) x.push_back(m.number(r, avg));
    }
    REQUIRE(x.size() == 6);
    double mean = 0, var = 0;
    for (double v : x) mean += v / 6;
    for (double v : x) var += (v - mean) * (v - mean) / 5;
    const double half = calib::studentTCritical(0.05, 5) * std::sqrt(var / 6);
    CHECK(sum.number(c, sum.requireColumn("n")) == 6);
    CHECK(sum.number(c, sum.requireColumn("avg_position_mm_mean")) == Approx(mean).epsilon(1e-8));
    CHECK(sum.number(c, sum.requireColumn("avg_position_mm_std")) == Approx(std::sqrt(var)).epsilon(1e-8));
    CHECK(sum.number(c, sum.requireColumn("avg_position_mm_ci95_low")) == Approx(mean - half).epsilon(1e-8));
    CHECK(sum.number(c, sum.requireColumn("avg_position_mm_ci95_high")) == Approx(mean + half).epsilon(1e-8));
  }
  // report.md rounds to the spread: the standard deviation to two significant digits, the mean and the
  // interval to its decimal place (within half a unit of it of the CSV's values).
  const std::string report = test::slurp(dir + "/a/merged/report.md");
  const std::regex cell(R"((-?[0-9.]+) \+- ([0-9.]+) \[(-?[0-9.]+), (-?[0-9.]+)\])");  // mean, sd, interval
  const auto decimalsOf = [](const std::string& number) {
    const std::size_t point = number.find('.');
    return point == std::string::npos ? std::size_t{0} : number.size() - point - 1;
  };
  int cells = 0;
  for (auto it = std::sregex_iterator(report.begin(), report.end(), cell); it != std::sregex_iterator(); ++it, ++cells) {
    const std::smatch& c = *it;
    const std::size_t decimals = decimalsOf(c[2].str());  // the standard deviation's
    for (const int k : {1, 3, 4}) CHECK(decimalsOf(c[k].str()) == decimals);
    std::string digits = c[2].str();
    digits.erase(std::remove(digits.begin(), digits.end(), '.'), digits.end());
    digits.erase(0, digits.find_first_not_of('0'));
    CHECK(digits.size() == 2);
  }
  CHECK(cells >= 4);
  for (std::size_t c = 0; c < 4; ++c) {  // each cell's mean is shown, rounded
    const double mean = sum.number(c, sum.requireColumn("avg_position_mm_mean"));
    bool shown = false;
    for (auto it = std::sregex_iterator(report.begin(), report.end(), cell); it != std::sregex_iterator(); ++it) {
      const double half_unit = 0.5 * std::pow(10.0, -static_cast<double>(decimalsOf((*it)[1].str()))) * (1 + 1e-9);
      shown = shown || std::abs(std::stod((*it)[1].str()) - mean) <= half_unit;
    }
    CHECK(shown);
  }
  // Doubling the joint noise doubles the floor (cell 1 against cell 0: same valid count, 0.02 vs 0.01 deg).
  CHECK(sum.number(1, sum.requireColumn("avg_position_mm_mean")) / sum.number(0, sum.requireColumn("avg_position_mm_mean")) ==
        Approx(2.0).epsilon(0.35));

  // Rerunning a finished study runs nothing and keeps the result; status says all done (exit 0).
  const auto before = fs::last_write_time(dir + "/a/shards/task-000000/task.yaml");
  REQUIRE(runOrbcal("study run " + dir + "/floor.yaml -o " + dir + "/a --no-plots", dir + "/a2.log") == 0);
  CHECK(test::slurp(dir + "/a2.log").find("12 done before, 0 to run") != std::string::npos);
  CHECK(fs::last_write_time(dir + "/a/shards/task-000000/task.yaml") == before);
  CHECK(runOrbcal("study status " + dir + "/a", dir + "/st.log") == 0);
  CHECK(test::slurp(dir + "/st.log").find("12 tasks: 12 done, 0 running, 0 queued, 0 failed, 0 missing") != std::string::npos);
  CHECK(test::slurp(dir + "/st.log").find("done tasks' wall time: mean ") != std::string::npos);  // for slurm.time

  // Another study into the same folder is refused, naming both files.
  test::write(dir + "/other.yaml", std::string(kFloorStudy) + "seed_derivation: common\n");
  CHECK(runOrbcal("study run " + dir + "/other.yaml -o " + dir + "/a", dir + "/o.log") == 1);
  CHECK(test::slurp(dir + "/o.log") == "orbcal: " + dir + "/a/study.yaml: this folder holds another study (its study.yaml differs from " +
                                           dir + "/other.yaml); give another -o, or delete the folder\n");
  // An option the job does not have is refused before anything runs.
  test::write(dir + "/bad.yaml", "format: orbcal-study-1\njob: experiment\npreset: floor\nseeds: [1]\noptions: {colour: red}\n");
  CHECK(runOrbcal("study run " + dir + "/bad.yaml -o " + dir + "/bad", dir + "/bad.log") == 1);
  CHECK(test::slurp(dir + "/bad.log") == "orbcal: " + dir + "/bad.yaml: options.colour: not an option of orbcal experiment (see orbcal experiment --help)\n");
  CHECK_FALSE(fs::exists(dir + "/bad"));
}

TEST_CASE("orbcal study: a failed task is named, the merge refuses, and a killed run resumes to the same result", "[study][slow]") {
  const std::string dir = test::tempDir("study-kill");
  // Failing tasks: one cell's error set does not exist.
  test::write(dir + "/fails.yaml",
              "format: orbcal-study-1\njob: experiment\npreset: floor\noptions: {quiet: true}\n"
              "grid: {errors: [table3, no-such-errors.yaml]}\nseeds: [1, 2]\n");
  CHECK(runOrbcal("study run " + dir + "/fails.yaml -o " + dir + "/f", dir + "/f.log") == 1);
  const std::string log = test::slurp(dir + "/f.log");
  CHECK(log.find("orbcal: 2 of 4 tasks failed; rerun the same command to run them again") != std::string::npos);
  CHECK(test::slurp(dir + "/f/shards/task-000002.failed/log.txt").find("no-such-errors.yaml") != std::string::npos);
  CHECK(runOrbcal("study status " + dir + "/f", dir + "/fs.log") == 3);
  CHECK(test::slurp(dir + "/fs.log").find("4 tasks: 2 done, 0 running, 0 queued, 2 failed, 0 missing") != std::string::npos);
  CHECK(runOrbcal("study merge " + dir + "/f", dir + "/fm.log") == 1);
  CHECK(test::slurp(dir + "/fm.log").find(dir + "/f: 2 of 4 tasks are not done (failed: 2-3)") != std::string::npos);
  CHECK_FALSE(fs::exists(dir + "/f/merged"));
  // A merge that fails half-way (a summary of a column no task wrote) leaves no folder behind.
  test::write(dir + "/badsum.yaml", "format: orbcal-study-1\njob: experiment\npreset: floor\noptions: {quiet: true}\nseeds: [1]\n"
                                    "summary: [{file: floor/floor.csv, values: [no_such_column]}]\n");
  CHECK(runOrbcal("study run " + dir + "/badsum.yaml -o " + dir + "/b", dir + "/b.log") == 1);
  CHECK(test::slurp(dir + "/b.log").find("summary floor/floor.csv: no column 'no_such_column'") != std::string::npos);
  for (const auto& e : fs::directory_iterator(dir + "/b")) CHECK(e.path().filename().string().rfind("merged", 0) != 0);

  // kill -9 of the runner mid-study: its tasks die with it (a task's job is killed with its parent);
  // the rerun runs the killed and the missing tasks, and the merged CSVs equal an uninterrupted run's.
  test::write(dir + "/t5.yaml",
              "format: orbcal-study-1\njob: experiment\npreset: table5\n"
              "options: {ident: 25, valid: 25, repetitions: 1, quiet: true, no-plots: true}\nseeds: {first: 1, count: 6}\n");
  REQUIRE(runOrbcal("study run " + dir + "/t5.yaml -o " + dir + "/clean -j 2 --no-plots", dir + "/clean.log") == 0);
  const pid_t pid = ::fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    ::setpgid(0, 0);
    const std::string out = dir + "/run.log";
    std::freopen(out.c_str(), "w", stdout);
    std::freopen(out.c_str(), "a", stderr);
    const std::string study = dir + "/t5.yaml", target = dir + "/killed";
    ::execl(ORBCAL_BINARY, ORBCAL_BINARY, "study", "run", study.c_str(), "-o", target.c_str(), "-j", "2", "--no-plots",
            static_cast<char*>(nullptr));
    ::_exit(127);
  }
  // Kill once a task is under way and at least one has finished (bounded wait).
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  bool killed_mid_run = false;
  while (std::chrono::steady_clock::now() < until) {
    bool running = false, finished = false;
    for (int i = 0; i < 6; ++i) {
      running = running || fs::exists(workflow::taskFolder(dir + "/killed", i) + ".tmp/log.txt");
      finished = finished || fs::exists(workflow::taskFolder(dir + "/killed", i) + "/task.yaml");
    }
    if (running && finished) {
      ::kill(-pid, SIGKILL);  // the runner (its job processes die with it)
      killed_mid_run = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  REQUIRE(killed_mid_run);
  CHECK(runOrbcal("study status " + dir + "/killed", dir + "/ks.log") == 3);  // something failed (killed) or missing
  CHECK(test::slurp(dir + "/ks.log").find("failed:") != std::string::npos);
  REQUIRE(runOrbcal("study run " + dir + "/t5.yaml -o " + dir + "/killed --no-plots", dir + "/resume.log") == 0);
  CHECK(test::slurp(dir + "/killed/merged/table5/table5.csv") == test::slurp(dir + "/clean/merged/table5/table5.csv"));
  CHECK(test::slurp(dir + "/killed/merged/summary/table5.csv") == test::slurp(dir + "/clean/merged/summary/table5.csv"));
  // The rendered datasets of finished tasks were removed (keep_datasets: false); the results kept.
  CHECK_FALSE(fs::exists(dir + "/clean/shards/task-000000/out/datasets"));
  CHECK(fs::exists(dir + "/clean/shards/task-000000/out/table5/table5.csv"));
}

TEST_CASE("orbcal study: a render study in shards merges into the dataset one render writes", "[study]") {
  const std::string dir = test::tempDir("study-render");
  const std::string scene = test::sourcePath("scenes/quick_scene.yaml");
  test::write(dir + "/render.yaml", "format: orbcal-study-1\njob: render\noptions: {scene: '" + scene +
                                        "', count: 7, errors: random}\nseeds: [4]\nshards: 3\n");
  REQUIRE(runOrbcal("study run " + dir + "/render.yaml -o " + dir + "/s -j 2", dir + "/s.log") == 0);
  const workflow::StudySpec s = workflow::parseStudy(test::slurp(dir + "/render.yaml"), "render.yaml");
  const auto tasks = workflow::expandStudy(s);
  REQUIRE(tasks.size() == 3);
  CHECK(tasks[2].args.back() == "2/3");
  CHECK(tasks[0].seed == tasks[2].seed);  // the shards of one dataset share its seed
  // The same dataset rendered in one go, by hand: every file the same, byte for byte.
  REQUIRE(runOrbcal("render --scene " + scene + " --count 7 --errors random --seed " + std::to_string(tasks[0].seed) + " -o " +
                        dir + "/one",
                    dir + "/one.log") == 0);
  const std::string merged = dir + "/s/merged/datasets/cell-0-seed-" + std::to_string(tasks[0].seed);
  int files = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir + "/one")) {
    if (!e.is_regular_file()) continue;
    const std::string rel = fs::relative(e.path(), dir + "/one").string();
    INFO(rel);
    CHECK(test::slurp(e.path().string()) == test::slurp(merged + "/" + rel));
    ++files;
  }
  CHECK(files >= 7 + 4);  // 7 images, manifest, samples, robot, scene
  CHECK(test::slurp(dir + "/s/merged/report.md").find("| 3 | 7 |") != std::string::npos);
}

TEST_CASE("orbcal study submit --dry-run: array scripts, in chunks past the array size limit", "[study]") {
  const std::string dir = test::tempDir("study-dry");
  const std::string text = "format: orbcal-study-1\nname: dry\njob: experiment\npreset: floor\nseeds: {first: 1, count: 7}\n"
                           "slurm: {throttle: 2, time: \"00:05:00\", mem: 1G}\n";
  const workflow::StudySpec s = workflow::parseStudy(text, dir + "/dry.yaml");
  workflow::initStudyFolder(s, dir + "/s", dir);
  workflow::SlurmSubmitOptions o;
  o.dry_run = true;
  o.max_array_size = 3;  // Slurm's MaxArraySize - 1, made small: 7 tasks go in arrays of 3, 3 and 1
  o.program = "/opt/orbcal/bin/orbcal";
  o.partition = "batch";
  o.extra = {"--qos=long"};
  const workflow::SlurmSubmission sub = workflow::submitStudy(dir + "/s", o);
  CHECK(sub.tasks == std::vector<int>{0, 1, 2, 3, 4, 5, 6});
  CHECK(sub.job_ids.empty());
  REQUIRE(sub.scripts.size() == 3);
  const std::string second = test::slurp(sub.scripts[1]);
  CHECK(second.find("#SBATCH --array=0-2%2\n") != std::string::npos);
  CHECK(second.find("#SBATCH --time=00:05:00\n#SBATCH --mem=1G\n") != std::string::npos);
  CHECK(second.find("#SBATCH --partition=batch\n") != std::string::npos);
  CHECK(second.find("#SBATCH --qos=long\n") != std::string::npos);
  CHECK(second.find("exec '/opt/orbcal/bin/orbcal' study task '" + fs::absolute(dir + "/s").lexically_normal().string() +
                    "' --index $((SLURM_ARRAY_TASK_ID + 3))") != std::string::npos);
  CHECK(test::slurp(sub.scripts[2]).find("#SBATCH --array=0%2\n") != std::string::npos);  // task 6 = 0 + 6
  // Tasks done are not submitted again: after task 4 is done, the chunk of 3..5 holds 3 and 5.
  fs::create_directories(workflow::taskFolder(dir + "/s", 4));
  test::write(workflow::taskFolder(dir + "/s", 4) + "/task.yaml", "index: 4\n");
  const workflow::SlurmSubmission again = workflow::submitStudy(dir + "/s", o);
  CHECK(again.tasks == std::vector<int>{0, 1, 2, 3, 5, 6});
  REQUIRE(again.scripts.size() == 3);
  CHECK(test::slurp(again.scripts[1]).find("#SBATCH --array=0,2%2\n") != std::string::npos);
  // Without `name:`, the job is named after the study file, not after the folder's copy of it.
  const workflow::StudySpec unnamed = workflow::parseStudy("format: orbcal-study-1\njob: experiment\npreset: floor\nseeds: [1]\n",
                                                     dir + "/my-floor.yaml");
  workflow::initStudyFolder(unnamed, dir + "/u", dir);
  CHECK(test::slurp(workflow::submitStudy(dir + "/u", o).scripts.at(0)).find("#SBATCH --job-name=orbcal-my-floor\n") !=
        std::string::npos);
}
