#pragma once
// Helpers shared by the test suites.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <random>
#include <string>

namespace orbcal::test {

inline std::string sourcePath(const std::string& relative) { return std::string(ORBCAL_SOURCE_DIR) + "/" + relative; }
inline std::string sharedDataPath(const std::string& relative) {
  return std::string(ORBCAL_SHARED_DATA_DIR) + "/" + relative;
}

/// A fresh, empty temporary folder for one test (removed and re-created).
inline std::string tempDir(const std::string& name) {
  const auto p = std::filesystem::temp_directory_path() / ("orbcal-test-" + name);
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
  return p.string();
}

/// The whole content of a file ("" when it cannot be read).
inline std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace orbcal::test
