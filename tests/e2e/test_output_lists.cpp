// The files each judging command writes are listed once, in docs/reports.md ("What each command
// writes"): calibrate (accepted and refused), diagnose and evaluate run on simulated tracker data, and
// what each wrote is compared with its row of that table.
#include <catch2/catch.hpp>
#include <algorithm>
#include <filesystem>
#include <regex>
#include <set>
#include <sstream>

#include "run_orbcal.hpp"
#include "test_util.hpp"

using namespace orbcal;
namespace fs = std::filesystem;

namespace {

/// The files of one row of the table: those always written, those written when accepted, and which of
/// them are conditional ("unexplained.png` (when ...") or patterns ("residuals_*.png").
struct Row {
  std::set<std::string> always, accepted, optional;
};

std::set<std::string> filesOfCell(const std::string& cell, std::set<std::string>& optional) {
  static const std::regex file("`([^` ]+\\.[a-z]+)`( \\(when)?");
  std::set<std::string> out;
  for (auto it = std::sregex_iterator(cell.begin(), cell.end(), file); it != std::sregex_iterator(); ++it) {
    out.insert((*it)[1]);
    if ((*it)[2].matched || (*it)[1].str().find('*') != std::string::npos) optional.insert((*it)[1]);
  }
  return out;
}

/// The row of docs/reports.md's table whose command cell starts with `command`.
Row documented(const std::string& command) {
  std::istringstream lines(test::slurp(test::sourcePath("docs/reports.md")));
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("| `" + command, 0) != 0) continue;
    std::vector<std::string> cells;
    std::istringstream s(line);
    for (std::string c; std::getline(s, c, '|');) cells.push_back(c);
    REQUIRE(cells.size() >= 5);  // "", command, folder, always, accepted
    Row r;
    r.always = filesOfCell(cells[3], r.optional);
    r.accepted = filesOfCell(cells[4], r.optional);
    return r;
  }
  FAIL("docs/reports.md has no row for " + command);
  return {};
}

/// The files a run wrote into `folder` (not the dot files every output folder has).
std::set<std::string> written(const std::string& folder) {
  std::set<std::string> out;
  for (const auto& e : fs::directory_iterator(folder)) {
    const std::string name = e.path().filename().string();
    if (name[0] != '.') out.insert(name);
  }
  return out;
}

bool matches(const std::string& pattern, const std::string& name) {
  const std::size_t star = pattern.find('*');
  if (star == std::string::npos) return pattern == name;
  const std::string head = pattern.substr(0, star), tail = pattern.substr(star + 1);
  return name.size() > head.size() + tail.size() && name.rfind(head, 0) == 0 &&
         name.compare(name.size() - tail.size(), tail.size(), tail) == 0;
}

/// Every written file is listed (by name or pattern), and every listed file that is not conditional was written.
void checkAgainst(const std::set<std::string>& files, const std::set<std::string>& listed, const std::set<std::string>& optional) {
  for (const std::string& f : files) {
    CAPTURE(f);
    CHECK(std::any_of(listed.begin(), listed.end(), [&](const std::string& p) { return matches(p, f); }));
  }
  for (const std::string& l : listed) {
    CAPTURE(l);
    if (optional.count(l) == 0) CHECK(files.count(l) == 1);
  }
}

std::set<std::string> unite(std::set<std::string> a, const std::set<std::string>& b) {
  a.insert(b.begin(), b.end());
  return a;
}

}  // namespace

TEST_CASE("the files calibrate, diagnose and evaluate write are the ones docs/reports.md lists", "[e2e][docs]") {
  const std::string dir = test::tempDir("output-lists");
  REQUIRE(test::runOrbcal(dir, "simulate -o data -n 80 --seed 3 --inject compliance:2").status == 0);
  const std::string desc = "data/measurements.yaml";

  const Row cal = documented("orbcal calibrate DESCRIPTION.yaml");
  REQUIRE(cal.always.count("report.md") == 1);  // the parsing finds the table's files
  REQUIRE(cal.accepted.count("model.yaml") == 1);
  SECTION("calibrate, accepted") {
    REQUIRE(test::runOrbcal(dir, "calibrate " + desc + " --effects compliance:2 --quiet -o accepted").status == 0);
    checkAgainst(written(dir + "/accepted"), unite(cal.always, cal.accepted), cal.optional);
    // The compliance also as a stiffness: 1 / c, in N*m/rad.
    const std::string report = test::slurp(dir + "/accepted/report.md");
    std::smatch c, k;
    REQUIRE(std::regex_search(report, c, std::regex("\\| c2 \\| compliance \\| \\+([0-9.e+-]+) \\|")));
    REQUIRE(std::regex_search(report, k, std::regex("- c2: stiffness ([0-9.e+]+) N\\*m/rad \\(1-sigma ")));
    CHECK(std::stod(k[1]) == Approx(1.0 / std::stod(c[1])).epsilon(1e-4));  // both printed to 5 digits
  }
  SECTION("calibrate, refused (the hidden compliance left out)") {
    REQUIRE(test::runOrbcal(dir, "calibrate " + desc + " --quiet -o refused").status == 1);
    checkAgainst(written(dir + "/refused"), cal.always, cal.optional);
  }
  SECTION("diagnose") {
    const Row diag = documented("orbcal diagnose INPUT");
    REQUIRE(test::runOrbcal(dir, "diagnose " + desc + " --quiet -o diag").status == 0);
    CHECK(diag.accepted.empty());
    checkAgainst(written(dir + "/diag"), diag.always, diag.optional);
  }
  SECTION("evaluate") {
    const Row eval = documented("orbcal evaluate");
    CHECK(eval.accepted.empty());
    REQUIRE(test::runOrbcal(dir, "evaluate --model data/truth/model.yaml --data " + desc + " -o eval").status == 0);
    checkAgainst(written(dir + "/eval"), eval.always, eval.optional);
  }
}

TEST_CASE("evaluate's report opens with its verdict, boxed on the page, against the nominal arm and the stated noise",
          "[e2e][docs][report]") {
  const std::string dir = test::tempDir("evaluate-verdict");
  REQUIRE(test::runOrbcal(dir, "simulate -o data -n 40 --seed 4").status == 0);
  // The truth predicts its own data to the noise; the nominal arm (random DH errors of 0.5 mm) does not.
  REQUIRE(test::runOrbcal(dir, "evaluate --model data/truth/model.yaml --data data/measurements.yaml -o eval").status == 0);
  const std::string md = test::slurp(dir + "/eval/evaluation.md");
  const std::size_t first = md.find("\n\n") + 2;  // after the title
  CHECK(md.substr(first).rfind("**The model predicts these data better than the nominal arm: position RMS ", 0) == 0);
  // simulate states a tracker noise of 0.05 mm per axis: sqrt(3) x 0.05 = 0.0866 mm.
  CHECK(md.find("The tracker noise the description states alone gives about 0.0866 mm RMS.") != std::string::npos);
  CHECK(md.find("**", first + 2) < md.find("\n\n", first));  // the bold verdict closes within the paragraph
  const std::string html = test::slurp(dir + "/eval/report.html");
  CHECK(html.find("class=\"verdict\"") != std::string::npos);
  CHECK(html.find("class=\"verdict\"") < html.find("<table"));
}

TEST_CASE("reports read by a colleague: a URDF chain's parameters named by its joints, no source path, no statistic "
          "left unexplained", "[e2e][docs][report]") {
  const std::string dir = test::tempDir("report-words");
  const std::string urdf = test::sourcePath("tests/data/iiwa7.urdf");
  REQUIRE(test::runOrbcal(dir, "simulate --robot '" + urdf + "' --base-link iiwa_link_0 --tip-link iiwa_link_7 -n 60 --seed 6 -o data")
              .status == 0);
  const test::OrbcalRun cal = test::runOrbcal(dir, "calibrate data/measurements.yaml --quiet --no-plots -o cal");
  CAPTURE(cal.out, cal.err);
  REQUIRE(cal.status == 0);
  const std::string report = test::slurp(dir + "/cal/report.md");
  CHECK(report.find("geometry (49 errors of the joints iiwa_joint_1 ... iiwa_joint_7 (7 each: zero offset, origin x, y, z, "
                    "roll, pitch, yaw))") != std::string::npos);
  CHECK(report.find("DH errors") == std::string::npos);
  REQUIRE(test::runOrbcal(dir, "diagnose data/measurements.yaml --quiet --no-plots -o diag").status == 0);
  const std::string diagnosis = test::slurp(dir + "/diag/report.md");
  CHECK(diagnosis.find("Parameters estimated on the other folds") == std::string::npos);
  for (const std::string& text : {report, diagnosis}) {
    static const std::regex source_path("[a-z_]+/[a-z_/]*\\.(hpp|cpp|py)\\b");
    std::smatch m;
    const bool found = std::regex_search(text, m, source_path);
    CAPTURE(found ? m.str() : std::string());
    CHECK_FALSE(found);
  }
}

// The noise estimated on a subset (--noise-observations) is said where it is reported: the report's
// noise sentence names the subset and the whole, diagnosis.json's noise_floor the subset's size, and the
// subset is at least what was asked for and less than the whole.
TEST_CASE("diagnose --noise-observations: the report and diagnosis.json say the noise came from a subset", "[e2e][diagnose][report]") {
  const std::string dir = test::tempDir("noise-subset");
  REQUIRE(test::runOrbcal(dir, "simulate -n 200 --seed 4 -o data").status == 0);
  const test::OrbcalRun run = test::runOrbcal(dir, "diagnose data/measurements.yaml --quiet --no-plots --noise-observations 100 -o diag");
  CAPTURE(run.out, run.err);
  REQUIRE(run.status == 0);
  const std::string report = test::slurp(dir + "/diag/report.md");
  std::smatch m;
  REQUIRE(std::regex_search(report, m, std::regex("on a seeded random ([0-9]+) of the 200 observations")));
  const int subset = std::stoi(m[1].str());
  CHECK(subset >= 100);
  CHECK(subset < 200);
  CHECK(test::slurp(dir + "/diag/diagnosis.json").find("\"noise_observations\": " + m[1].str()) != std::string::npos);
}

// The selection on a subset (--selection-observations) is said where its numbers are reported: the
// candidates' table names the subset and the whole, diagnosis.json gives the subset's size, and the
// held-out residuals (residuals.csv) are the selected model's on every observation.
TEST_CASE("diagnose --selection-observations: the report and diagnosis.json say the selection ran on a subset", "[e2e][diagnose][report]") {
  const std::string dir = test::tempDir("selection-subset");
  REQUIRE(test::runOrbcal(dir, "simulate -n 200 --seed 4 -o data").status == 0);
  const test::OrbcalRun run = test::runOrbcal(dir, "diagnose data/measurements.yaml --quiet --no-plots --selection-observations 120 -o diag");
  CAPTURE(run.out, run.err);
  REQUIRE(run.status == 0);
  const std::string report = test::slurp(dir + "/diag/report.md");
  CHECK(report.find("a seeded random 120 of the 200 observations (`--selection-observations`)") != std::string::npos);
  CHECK(test::slurp(dir + "/diag/diagnosis.json").find("\"selection_observations\": 120,") != std::string::npos);
  const std::string csv = test::slurp(dir + "/diag/residuals.csv");
  CHECK(std::count(csv.begin(), csv.end(), '\n') == 201);  // a header and every observation
}
