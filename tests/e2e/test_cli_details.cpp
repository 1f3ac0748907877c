// Details of the command line: a study file in another folder with a relative -o.
#include <sys/wait.h>

#include <catch2/catch.hpp>
#include <filesystem>

#include "test_util.hpp"

using namespace orbcal;
namespace fs = std::filesystem;

namespace {
/// `orbcal args` run in `dir`; stdout and stderr into dir/stdout.txt and dir/stderr.txt.
int runOrbcal(const std::string& dir, const std::string& args) {
  const int rc = std::system(("cd '" + dir + "' && '" + std::string(ORBCAL_BINARY) + "' " + args + " >'" + dir +
                              "/stdout.txt' 2>'" + dir + "/stderr.txt'").c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}
}  // namespace

TEST_CASE("orbcal study run sub/study.yaml -o out: a relative -o with the study file in another folder", "[study]") {
  const std::string dir = test::tempDir("study-relative");
  fs::create_directories(dir + "/sub");
  test::write(dir + "/sub/study.yaml",
              "format: orbcal-study-1\nname: relative\njob: experiment\npreset: floor\n"
              "options: {repetitions: 1, valid: 5, quiet: true}\nseeds: [1, 2]\n");
  REQUIRE(runOrbcal(dir, "study run sub/study.yaml -o out -j 2 --no-plots") == 0);
  INFO(test::slurp(dir + "/stderr.txt"));
  for (const char* task : {"task-000000", "task-000001"}) {
    CHECK(fs::exists(dir + "/out/shards/" + task + "/log.txt"));
    CHECK(fs::exists(dir + "/out/shards/" + task + "/out/floor/floor.csv"));
  }
  CHECK(fs::exists(dir + "/out/merged/floor/floor.csv"));
  CHECK(test::slurp(dir + "/stderr.txt").empty());
}
