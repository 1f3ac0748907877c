#pragma once
// Helpers shared by the test suites.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <random>
#include <string>

#include "orbcal/sim/arm.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/scene.hpp"

/// Marks the running test case as skipped for `reason` (a stream expression, e.g. a path that is
/// absent): a warning in Catch's output and a line that CTest's SKIP_REGULAR_EXPRESSION (set for every
/// test in tests/CMakeLists.txt) turns into "Skipped" in its summary, so that a skip never reads as a
/// pass. The caller returns right after.
#define ORBCAL_SKIP(reason)                                                   \
  do {                                                                        \
    std::ostringstream orbcal_skip_reason_;                                   \
    orbcal_skip_reason_ << reason;                                            \
    WARN("skipped: " << orbcal_skip_reason_.str());                           \
    std::cout << "orbcal-test-skipped: " << orbcal_skip_reason_.str() << std::endl; \
  } while (0)

namespace orbcal::test {

inline std::string sourcePath(const std::string& relative) { return std::string(ORBCAL_SOURCE_DIR) + "/" + relative; }
inline std::string sharedDataPath(const std::string& relative) {
  return std::string(ORBCAL_SHARED_DATA_DIR) + "/" + relative;
}

/// Where tempDir(name) puts its folder: the system's temporary folder, a name unique to this source tree
/// (several checkouts on one machine may run their suites at the same time without sharing folders).
inline std::string tempPath(const std::string& name) {
  char tree[24];
  std::snprintf(tree, sizeof tree, "%08zx", std::hash<std::string>{}(ORBCAL_SOURCE_DIR) & 0xffffffffu);
  return (std::filesystem::temp_directory_path() / ("orbcal-test-" + std::string(tree) + "-" + name)).string();
}

/// A fresh, empty temporary folder for one test (removed and re-created).
inline std::string tempDir(const std::string& name) {
  const std::filesystem::path p = tempPath(name);
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

/// Writes `text` to `path` as it is (binary: no newline translation).
inline void write(const std::string& path, const std::string& text) { std::ofstream(path, std::ios::binary) << text; }

/// `text` with its first `from` replaced by `to` (which must be there).
inline std::string edited(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  REQUIRE(at != std::string::npos);
  return text.replace(at, from.size(), to);
}

/// The message of the InputError that fn throws, checked to be one line; fails the test if fn throws
/// nothing or something else.
template <class Fn>
std::string inputError(Fn fn) {
  try {
    fn();
  } catch (const orbcal::sim::InputError& e) {
    const std::string msg = e.what();
    CHECK(msg.find('\n') == std::string::npos);  // one line
    return msg;
  }
  FAIL("expected an InputError");
  return "";
}

/// A mass model read back from a robot file equals the one written: every link's mass and COM,
/// gravity, and no payload (the robot files here have none).
inline void checkSameMasses(const sim::MassModel& back, const sim::MassModel& written) {
  REQUIRE(back.links.size() == written.links.size());
  for (std::size_t i = 0; i < written.links.size(); ++i) {
    CHECK(back.links[i].mass_kg == written.links[i].mass_kg);
    CHECK(back.links[i].com_m == written.links[i].com_m);
  }
  CHECK(back.gravity_base == written.gravity_base);
  CHECK(back.payload_kg == 0.0);
}

/// n configurations drawn uniformly within the joint limits (seeded).
inline std::vector<Eigen::VectorXd> randomConfigs(const sim::Arm& arm, int n, std::uint64_t seed) {
  auto rng = sim::makeRng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Eigen::VectorXd> qs;
  for (int k = 0; k < n; ++k) {
    Eigen::VectorXd q(arm.numJoints());
    for (int j = 0; j < arm.numJoints(); ++j) q[j] = arm.lower_rad[j] + u(rng) * (arm.upper_rad[j] - arm.lower_rad[j]);
    qs.push_back(q);
  }
  return qs;
}

/// A camera with every field different from the default and numbers that need all 17 digits (file
/// round trips).
inline sim::Camera oddCamera() {
  sim::Camera c;
  c.width_px = 1288;
  c.height_px = 964;
  c.fx_px = 1401.123456789012;
  c.fy_px = 1399.987654321098;
  c.cx_px = 643.30000000000007;
  c.cy_px = 508.91234567890123;
  c.distortion = {-0.21234567890123, 0.1234567890123456, 1.234567890123e-4, -9.87654321098e-5, -0.0123456789012345};
  return c;
}

/// Same size, and every intrinsic and distortion coefficient within `tol`.
inline void checkSameCamera(const sim::Camera& a, const sim::Camera& b, double tol = 1e-12) {
  CHECK(a.width_px == b.width_px);
  CHECK(a.height_px == b.height_px);
  CHECK(std::abs(a.fx_px - b.fx_px) <= tol);
  CHECK(std::abs(a.fy_px - b.fy_px) <= tol);
  CHECK(std::abs(a.cx_px - b.cx_px) <= tol);
  CHECK(std::abs(a.cy_px - b.cy_px) <= tol);
  for (int i = 0; i < 5; ++i) CHECK(std::abs(a.distortion[i] - b.distortion[i]) <= tol);
}

}  // namespace orbcal::test
