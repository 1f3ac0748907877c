#pragma once
// The end-to-end tests' one way to run the `orbcal` program (ORBCAL_BINARY, set by tests/CMakeLists.txt).
#include <sys/wait.h>

#include <cstdlib>
#include <string>

#include "test_util.hpp"

namespace orbcal::test {

struct OrbcalRun {
  int status = -1;       ///< exit status (-1: killed by a signal)
  std::string out, err;  ///< stdout, stderr
};

/// `orbcal args` run in `dir` (relative paths are from there); stdout and stderr kept apart in
/// dir/stdout.txt and dir/stderr.txt.
inline OrbcalRun runOrbcal(const std::string& dir, const std::string& args) {
  const std::string out = dir + "/stdout.txt", err = dir + "/stderr.txt";
  const int rc = std::system(("cd '" + dir + "' && '" + std::string(ORBCAL_BINARY) + "' " + args + " >'" + out + "' 2>'" + err + "'").c_str());
  return {WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, slurp(out), slurp(err)};
}

}  // namespace orbcal::test
