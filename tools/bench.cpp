#include <cstring>
#include <iostream>
#include <map>

#include "bench.hpp"

namespace orbcal::tools {
namespace {
std::map<std::string, void (*)()>& sections() {
  static std::map<std::string, void (*)()> s;
  return s;
}
std::map<std::string, int (*)(int, char**)>& sectionsWithOptions() {
  static std::map<std::string, int (*)(int, char**)> s;
  return s;
}
}  // namespace
int registerBench(const char* name, void (*fn)()) {
  sections()[name] = fn;
  return 0;
}
int registerBenchWithOptions(const char* name, int (*fn)(int, char**)) {
  sectionsWithOptions()[name] = fn;
  return 0;
}
}  // namespace orbcal::tools

int main(int argc, char** argv) {
  const auto& sections = orbcal::tools::sections();
  const auto& with_options = orbcal::tools::sectionsWithOptions();
  if (argc > 1 && (!std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h"))) {
    std::cout << "orbcal-bench [section...]: prints speed figures (median of repeated runs).\nsections:";
    for (const auto& [name, fn] : sections) std::cout << " " << name;
    std::cout << "\nwith options, run only when named first (orbcal-bench SECTION --help):";
    for (const auto& [name, fn] : with_options) std::cout << " " << name;
    std::cout << "\n";
    return 0;
  }
  try {
    if (argc > 1 && with_options.count(argv[1])) return with_options.at(argv[1])(argc - 1, argv + 1);
    for (const auto& [name, fn] : sections) {
      bool wanted = argc == 1;
      for (int i = 1; i < argc; ++i) wanted |= name == argv[i];
      if (!wanted) continue;
      std::cout << "[" << name << "]\n";
      fn();
    }
  } catch (const std::exception& e) {
    std::cerr << "orbcal-bench: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
