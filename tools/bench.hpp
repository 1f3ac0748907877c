#pragma once
// orbcal-bench: speed figures, printed, never asserted (these machines are shared and noisy).
// Each library contributes one bench_*.cpp section; `orbcal-bench [section...]` runs them.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

namespace orbcal::tools {

/// Runs `fn` `repeats` times and returns the wall times in seconds, sorted.
inline std::vector<double> timeRepeats(int repeats, const std::function<void()>& fn) {
  std::vector<double> t;
  for (int i = 0; i < repeats; ++i) {
    const auto a = std::chrono::steady_clock::now();
    fn();
    t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count());
  }
  std::sort(t.begin(), t.end());
  return t;
}

/// "name: median X (min Y, max Z) [target T]"
/// `label` precedes `target` (e.g. "target " for a goal; "" for a note such as "(notes measured ...)").
inline void printFigure(const std::string& name, const std::vector<double>& s, const char* unit, double scale,
                        const std::string& target, const char* label = "target ") {
  std::printf("  %-58s median %9.3f %s  (min %.3f, max %.3f; %zu runs)%s%s%s\n", name.c_str(), s[s.size() / 2] * scale,
              unit, s.front() * scale, s.back() * scale, s.size(), target.empty() ? "" : "  ", target.empty() ? "" : label,
              target.c_str());
}

/// Sections register themselves from their own bench_*.cpp:  ORBCAL_BENCH("render", benchRender);
int registerBench(const char* name, void (*fn)());
#define ORBCAL_BENCH(name, fn) static const int orbcal_bench_##fn [[maybe_unused]] = ::orbcal::tools::registerBench(name, fn)

/// Sections with options (`orbcal-bench open-world --seeds 1`): run only when named as the first
/// argument, which gets the rest (argv[0] is the section's name); returns the exit code.
///   ORBCAL_BENCH_WITH_OPTIONS("open-world", benchOpenWorld);
int registerBenchWithOptions(const char* name, int (*fn)(int argc, char** argv));
#define ORBCAL_BENCH_WITH_OPTIONS(name, fn) \
  static const int orbcal_bench_##fn [[maybe_unused]] = ::orbcal::tools::registerBenchWithOptions(name, fn)

}  // namespace orbcal::tools
