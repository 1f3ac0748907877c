// Small measured sets through the `orbcal` program: 12 configurations, too few to hold 10 out, are
// judged by leave-one-configuration-out cross-validation (accepted with geometry errors, refused on
// pure noise); and a joint reading past a limit by less than 2% of the joint's range is calibrated
// with a warning naming the joint and the excess, one beyond it refused naming the file and the column.
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "run_orbcal.hpp"
#include "test_util.hpp"

using namespace orbcal;
using Catch::Contains;

namespace {

/// `csv` with the first data row's cell in `column` set to `value`.
std::string withFirstCell(const std::string& csv, const std::string& column, const std::string& value) {
  std::istringstream in(csv);
  std::string header, row, rest, line;
  std::getline(in, header);
  std::getline(in, row);
  while (std::getline(in, line)) rest += line + "\n";
  std::vector<std::string> names, cells;
  for (std::istringstream h(header); std::getline(h, line, ',');) names.push_back(line);
  for (std::istringstream r(row); std::getline(r, line, ',');) cells.push_back(line);
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i] == column) cells[i] = value;
  }
  std::string out = header + "\n";
  for (std::size_t i = 0; i < cells.size(); ++i) out += (i ? "," : "") + cells[i];
  return out + "\n" + rest;
}

std::string exact(double v) {
  std::ostringstream s;
  s.precision(17);
  s << v;
  return s.str();
}

}  // namespace

TEST_CASE("calibrate DESC.yaml: 12 configurations are judged by cross-validation, accepted with geometry errors and "
          "refused without", "[e2e][measured][heldout][small]") {
  const std::string dir = test::tempDir("small-cv");
  const std::string robot = test::sourcePath("scenes/iiwa7.yaml");
  REQUIRE(test::runOrbcal(dir, "simulate --robot " + robot + " -n 12 --seed 4 --error-angle-deg 0.2 --error-length-mm 1 -o real")
              .status == 0);
  const test::OrbcalRun real = test::runOrbcal(dir, "calibrate real/measurements.yaml -o cal");
  INFO(real.out << real.err);
  CHECK(real.status == 0);
  CHECK_THAT(real.out, Contains("cross-validated position RMS (each of the 12 configurations predicted by fits to the others)"));
  CHECK(std::filesystem::exists(dir + "/cal/model.yaml"));
  CHECK_THAT(test::slurp(dir + "/cal/report.md"), Contains("## Cross-validated prediction") &&
                                                        Contains("each predicted once by a fit that never saw it"));

  REQUIRE(test::runOrbcal(dir, "simulate --robot " + robot + " -n 12 --seed 4 --geometry zero -o noise").status == 0);
  const test::OrbcalRun noise = test::runOrbcal(dir, "calibrate noise/measurements.yaml -o cal-noise");
  INFO(noise.out << noise.err);
  CHECK(noise.status == 1);
  CHECK_THAT(noise.err, Contains("noise/measurements.yaml: ") && Contains("each predicted by a fit without it") ||
                            Contains("each by a fit without it"));
  CHECK_FALSE(std::filesystem::exists(dir + "/cal-noise/model.yaml"));
}

TEST_CASE("calibrate DESC.yaml: a joint reading past its limit by under 2% of the range is warned about, beyond it refused",
          "[e2e][measured][limits]") {
  const std::string dir = test::tempDir("small-limits");
  const std::string robot = test::sourcePath("scenes/iiwa7.yaml");  // joint 1: -170 to 170 deg, 2% of its range: 6.8 deg
  REQUIRE(test::runOrbcal(dir, "simulate --robot " + robot + " -n 30 --seed 6 -o data").status == 0);
  const std::string csv = test::slurp(dir + "/data/session_1.csv");
  test::write(dir + "/data/session_1.csv", withFirstCell(csv, "q1_rad", exact((170.0 + 1.5) * M_PI / 180.0)));
  const test::OrbcalRun near = test::runOrbcal(dir, "calibrate data/measurements.yaml --level offsets -o cal");
  INFO(near.out << near.err);
  CHECK_THAT(near.err, Contains("warning: data/measurements.yaml: joint 1: 1 reading past its upper limit 170 deg") &&
                           Contains("by up to 1.5 deg (within 2% of the joint's range, 6.8 deg"));
  CHECK(std::filesystem::exists(dir + "/cal/report.md"));
  CHECK_THAT(test::slurp(dir + "/cal/report.md"), Contains("**Warning:** joint 1: 1 reading past its upper limit 170 deg"));

  test::write(dir + "/data/session_1.csv", withFirstCell(csv, "q1_rad", exact((170.0 + 7.5) * M_PI / 180.0)));
  const test::OrbcalRun far = test::runOrbcal(dir, "calibrate data/measurements.yaml --level offsets -o cal2");
  INFO(far.out << far.err);
  CHECK(far.status != 0);
  CHECK_THAT(far.err, Contains("session_1.csv: line 2: q1_rad: ") &&
                          Contains("is outside the joint limits [-170, 170] deg of ") &&
                          Contains("by more than 2% of the joint's range (6.8 deg)"));
  CHECK_FALSE(std::filesystem::exists(dir + "/cal2"));
}
