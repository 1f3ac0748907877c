// Details of the command line: a study file in another folder with a relative -o, the built-in
// iiwa7's joint limits against KUKA's data sheet, simulate's --quiet, every effect of the catalog in
// --help and the manual, and what `orbcal --help` says orbcal is for.
#include <sys/wait.h>

#include <catch2/catch.hpp>
#include <filesystem>

#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/effect_syntax.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/measured.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/workflow/callbacks.hpp"
#include "orbcal/workflow/experiment.hpp"
#include "run_orbcal.hpp"
#include "test_util.hpp"

using namespace orbcal;
using Catch::Matchers::Contains;
namespace fs = std::filesystem;

namespace {
int runOrbcal(const std::string& dir, const std::string& args) { return test::runOrbcal(dir, args).status; }
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

TEST_CASE("the built-in iiwa7's joint limits are KUKA's data sheet's for the LBR iiwa 7 R800", "[e2e][iiwa7]") {
  // KUKA LBR iiwa 7 R800 data sheet, axis data: A1, A3, A5 +-170 deg; A2, A4, A6 +-120 deg; A7 +-175 deg.
  const double sheet_deg[7] = {170, 120, 170, 120, 170, 120, 175};
  for (const std::string& robot : {std::string("builtin:iiwa7.yaml"), test::sourcePath("tests/data/iiwa7.urdf")}) {
    const sim::Arm arm = sim::loadArm(robot);
    REQUIRE(arm.numJoints() == 7);
    for (int j = 0; j < 7; ++j) {
      INFO(robot << " A" << j + 1);
      CHECK(arm.upper_rad[j] == Approx(sheet_deg[j] * sim::kDegToRad).epsilon(1e-15));
      CHECK(arm.lower_rad[j] == Approx(-sheet_deg[j] * sim::kDegToRad).epsilon(1e-15));
    }
  }
  // Real readings of joint 7 between 170 and 175 deg are taken; past 175 deg by at most 2% of the range
  // (7 deg: sim/joint_limits.hpp) taken with a warning, and further out refused at the cell.
  const std::string dir = test::tempDir("iiwa7-a7");
  const auto data = [&](double q7_deg) {
    test::write(dir + "/a7.csv", "q1,q2,q3,q4,q5,q6,q7,x,y,z\n0,10,0,-20,0,30," + sim::formatNumber("%.1f", q7_deg) +
                                     ",0.1,0.2,1.2\n0,-10,0,20,0,-30,0,0.1,0.2,1.1\n");
    test::write(dir + "/a7.yaml", "format: orbcal-measurements-1\nrobot: builtin:iiwa7.yaml\nfiles: [a7.csv]\n"
                                  "joints: {columns: [q1, q2, q3, q4, q5, q6, q7], unit: deg}\n"
                                  "pose: {position: [x, y, z], length_unit: m}\nregistration: {base: shared, marker: shared}\n");
    return dir + "/a7.yaml";
  };
  CHECK(sim::loadMeasuredData(data(173.0)).poses[0].sample.q_rad[6] == Approx(173.0 * sim::kDegToRad));
  CHECK(sim::loadMeasuredData(data(176.0)).poses[0].sample.q_rad[6] == Approx(176.0 * sim::kDegToRad));
  CHECK_THAT(test::inputError([&] { sim::loadMeasuredData(data(183.0)); }),
             Contains(dir + "/a7.csv: line 2: q7: 183 deg") && Contains("[-175, 175] deg"));
}

TEST_CASE("orbcal simulate --quiet: as the other commands take it, the same data", "[e2e][measured]") {
  const std::string dir = test::tempDir("simulate-quiet");
  REQUIRE(runOrbcal(dir, "simulate -o loud -n 20 --sessions 1 --seed 2") == 0);
  REQUIRE(runOrbcal(dir, "simulate -o quiet -n 20 --sessions 1 --seed 2 --quiet") == 0);
  CHECK(test::slurp(dir + "/stderr.txt").empty());
  CHECK(test::slurp(dir + "/quiet/session_1.csv") == test::slurp(dir + "/loud/session_1.csv"));
  CHECK(test::slurp(dir + "/quiet/truth/model.yaml") == test::slurp(dir + "/loud/truth/model.yaml"));
}

TEST_CASE("figure arguments are quoted for the shell whatever they hold (a label with an apostrophe)", "[e2e][figures]") {
  // A revealing variable's label such as "link 3's load" once ended the plot script's quoted argument.
  for (const std::string word : {"link 3's load (N)", "it's 'quoted'", "plain", "", "a\"b $HOME `x`"}) {
    const auto [status, out] = orbcal::workflow::shellOutput("printf %s " + orbcal::workflow::shellQuote(word));
    CAPTURE(word);
    CHECK(status == 0);
    CHECK(out == word);
  }
}

TEST_CASE("every effect of the catalog is in calibrate's and simulate's --help and in the manual's effect table", "[e2e][effects]") {
  const std::string dir = test::tempDir("effects-help");
  const std::string calibrate = (test::runOrbcal(dir, "calibrate --help"), test::slurp(dir + "/stdout.txt"));
  const std::string simulate = (test::runOrbcal(dir, "simulate --help"), test::slurp(dir + "/stdout.txt"));
  const std::string manual = test::slurp(test::sourcePath("docs/own-robot-and-measured-data.md"));
  REQUIRE(sim::catalog().size() >= 11);  // the catalog as this test was written; more may come, never fewer
  for (const sim::EffectKind* k : sim::catalog()) {
    const std::string syntax = sim::effectSyntax(*k);
    CAPTURE(k->name(), syntax);
    CHECK_THAT(syntax, Catch::StartsWith(k->name()));
    CHECK_THAT(calibrate, Contains(" " + syntax + " ") || Contains(" " + syntax + " ("));
    CHECK_THAT(simulate, Contains(" " + syntax + " ") || Contains(" " + syntax + " ("));
    // A row of the catalog's table names it: "| `compliance` |", or beside a sibling "| `empirical`, `empirical_torque` |".
    bool row = false;
    std::istringstream lines(manual);
    for (std::string line; std::getline(lines, line);) {
      row = row || (line.rfind("| `", 0) == 0 && line.substr(0, line.find(" | ", 2)).find("`" + k->name() + "`") != std::string::npos);
    }
    CHECK(row);
  }
}

TEST_CASE("orbcal --help says what orbcal is for: tracker and motion-capture data as well as images", "[e2e]") {
  const std::string dir = test::tempDir("top-help");
  REQUIRE(test::runOrbcal(dir, "--help").status == 0);
  const std::string help = test::slurp(dir + "/stdout.txt");
  for (const char* words : {"laser tracker", "motion-capture", "orbcal calibrate DESC.yaml", "orbcal diagnose", "orbcal evaluate",
                            "orbcal simulate", "camera on the arm", "orbcal run"}) {
    CHECK_THAT(help, Contains(words));
  }
}
