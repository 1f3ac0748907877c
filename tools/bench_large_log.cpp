// `orbcal-bench large-log`: calib::diagnose on a simulated tracker log of growing size (10^3, 10^4,
// 10^5 samples by default): the wall time, the peak memory (the resident set's high-water mark,
// getrusage's ru_maxrss, of a child process per size: sizes do not inherit each other's peak) and the
// verdict. Every size is a subsample (every k-th row) of one seeded log of the largest size, so a
// size's verdict can be compared with the next larger one's, of which it is a 10x subsample.
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "bench.hpp"
#include "orbcal/calib/diagnose.hpp"
#include "orbcal/calib/measured_fit.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/model.hpp"
#include "orbcal/sim/simulate.hpp"

namespace orbcal::tools {

namespace {

struct LargeLogOptions {
  std::vector<int> sizes{1000, 10000, 100000};
  std::string inject = "compliance:2";  ///< hidden in the simulated log ("none": clean)
  std::uint64_t seed = 1;
  calib::DiagnoseOptions diagnose;  ///< as orbcal diagnose's defaults, but for --noise-observations and --selection-observations
};

void printLargeLogHelp(std::ostream& os) {
  os << "orbcal-bench large-log [options]: calib::diagnose on a simulated iiwa7 tracker log per size: wall\n"
        "time, peak memory (ru_maxrss of a child process per size) and the verdict.\n"
        "  --sizes LIST   samples, comma-separated (default 1000,10000,100000); each size is every k-th row\n"
        "                 of one log of the largest size\n"
        "  --inject SPEC  effect hidden in the log (default compliance:2; 'none': clean)\n"
        "  --seed N       the log's seed (default 1)\n"
        "  --noise-observations N  diagnose's (default 20000; 0: the noise estimated on every observation)\n"
        "  --selection-observations N  diagnose's (default 20000; 0: the effects selected on every observation)\n"
        "The diagnosis's own CPU time (the simulation excluded) is printed beside its wall time, and so is\n"
        "each of its phases' (calib::kDiagnosePhases).\n"
        "The log: two sessions (0 and 1.25 kg payload), the tracker noise stated as the simulation's, the\n"
        "joint readings' noise not stated (diagnose estimates it).\n";
}

std::string verdictLine(const calib::Diagnosis& d) {
  std::string s = d.clean ? "clean" : "";
  for (const sim::Effect& e : d.selected) s += (s.empty() ? "" : " ") + sim::formatEffect(e);
  if (d.unexplained) s += s.empty() ? "unexplained" : " + unexplained";
  return s.empty() ? "(nothing selected)" : s;
}

/// Every `step`-th row of `data`.
sim::MeasuredData subsample(const sim::MeasuredData& data, int step) {
  sim::MeasuredData out = data;
  out.poses.clear();
  for (std::size_t i = 0; i < data.poses.size(); i += static_cast<std::size_t>(step)) out.poses.push_back(data.poses[i]);
  return out;
}

/// In the child: simulate the log, keep `n` of its rows, diagnose; prints the time and the verdict.
int runSize(const LargeLogOptions& o, int largest, int n) {
  const sim::Arm arm = sim::loadArm(std::string(ORBCAL_SOURCE_DIR) + "/scenes/iiwa7.yaml");
  sim::SimulationSpec spec;
  spec.samples = largest;
  spec.sessions = 2;
  spec.payload_kg = {0.0, 1.25};
  spec.seed = o.seed;
  if (o.inject != "none" && !o.inject.empty()) spec.effects = {sim::parseEffect(o.inject, arm.numJoints(), "--inject")};
  const sim::MeasuredData data = subsample(sim::simulateMeasured(arm, spec).data, std::max(1, largest / n));
  const auto cpu = [] {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);  // every thread of this child
    return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
  };
  const double c0 = cpu();
  const auto t0 = std::chrono::steady_clock::now();
  const auto wall = [&t0] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  std::vector<std::pair<double, double>> starts;  // each phase's start: wall, CPU (s)
  calib::DiagnoseOptions options = o.diagnose;
  options.progress = [&](int, int) { starts.emplace_back(wall(), cpu() - c0); };
  const std::vector<calib::MarkerObservation> obs = calib::observationsFrom(data, true);
  const calib::Diagnosis d = calib::diagnose(data, obs, options);
  const double s = wall();
  std::printf("  %7zu samples  %8.2f s (CPU %.1f s)", obs.size(), s, cpu() - c0);
  std::printf("  verdict: %s\n", verdictLine(d).c_str());
  for (std::size_t k = 0; k + 1 < starts.size() && k < calib::kDiagnosePhases.size(); ++k) {
    std::printf("           %-45s %7.2f s (CPU %.1f s)\n", calib::kDiagnosePhases[k], starts[k + 1].first - starts[k].first,
                starts[k + 1].second - starts[k].second);
  }
  std::fflush(stdout);
  return 0;
}

std::vector<int> parseSizeList(const std::string& text) {
  std::vector<int> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) {
    const int v = std::stoi(item);
    if (v < 10 || v > 1000000) throw std::invalid_argument("large-log: --sizes: out of range (10..1000000): " + item);
    out.push_back(v);
  }
  if (out.empty()) throw std::invalid_argument("large-log: --sizes: empty");
  return out;
}

int benchLargeLog(int argc, char** argv) {
  LargeLogOptions o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument("large-log: " + a + " needs a value");
      return argv[++i];
    };
    if (a == "--help" || a == "-h") {
      printLargeLogHelp(std::cout);
      return 0;
    } else if (a == "--sizes") {
      o.sizes = parseSizeList(value());
    } else if (a == "--inject") {
      o.inject = value();
    } else if (a == "--noise-observations") {
      o.diagnose.noise_observations = std::stoi(value());
      if (o.diagnose.noise_observations < 0) throw std::invalid_argument("large-log: --noise-observations: negative");
    } else if (a == "--selection-observations") {
      o.diagnose.selection_observations = std::stoi(value());
      if (o.diagnose.selection_observations < 0) throw std::invalid_argument("large-log: --selection-observations: negative");
    } else if (a == "--seed") {
      o.seed = static_cast<std::uint64_t>(std::stoull(value()));
    } else {
      printLargeLogHelp(std::cerr);
      throw std::invalid_argument("large-log: unknown option " + a);
    }
  }
  const int largest = *std::max_element(o.sizes.begin(), o.sizes.end());
  double load[3] = {0, 0, 0};
  if (getloadavg(load, 3) > 0) std::printf("[large-log] load average at start %.2f\n", load[0]);
  for (const int n : o.sizes) {
    std::fflush(stdout);
    const pid_t child = fork();
    if (child < 0) throw std::runtime_error("large-log: fork failed");
    if (child == 0) {
      int code = 1;
      try {
        code = runSize(o, largest, n);
      } catch (const std::exception& e) {
        std::fprintf(stderr, "orbcal-bench: large-log: %d samples: %s\n", n, e.what());
      }
      std::fflush(stdout);
      _exit(code);
    }
    int status = 0;
    rusage use{};
    wait4(child, &status, 0, &use);
    std::printf("  %7d samples  peak memory %.0f MB, CPU %.1f s (user + system)%s\n", n, use.ru_maxrss / 1024.0,
                static_cast<double>(use.ru_utime.tv_sec + use.ru_stime.tv_sec) + 1e-6 * static_cast<double>(use.ru_utime.tv_usec + use.ru_stime.tv_usec),
                WIFEXITED(status) && WEXITSTATUS(status) == 0 ? "" : " (failed)");
  }
  if (getloadavg(load, 3) > 0) std::printf("[large-log] load average at end %.2f\n", load[0]);
  return 0;
}

}  // namespace

ORBCAL_BENCH_WITH_OPTIONS("large-log", benchLargeLog);

}  // namespace orbcal::tools
