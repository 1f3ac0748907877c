// The program's figure drawer (tools/figures.hpp): one python3 process (two drawers for diagnose) draws all the figures of a command,
// answering each (an image line; a failure named, and the next figure still drawn).
#include <catch2/catch.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "figures.hpp"
#include "orbcal/sim/fileio.hpp"
#include "test_util.hpp"

namespace fs = std::filesystem;
using namespace orbcal;
using Catch::Matchers::Contains;
using Catch::Matchers::StartsWith;

/// Skips the test case where Debian's python3 has no matplotlib.
#define ORBCAL_NEED_MATPLOTLIB()                                                  \
  if (system("/usr/bin/python3 -c 'import matplotlib' 2>/dev/null") != 0) {      \
    ORBCAL_SKIP("python3 with matplotlib is not installed");                    \
  }

namespace {

int lines(const std::string& path) {
  std::ifstream in(path);
  int n = 0;
  for (std::string line; std::getline(in, line);) ++n;
  return n;
}

/// Sets an environment variable for the length of a scope.
struct ScopedEnv {
  std::string name;
  ScopedEnv(std::string n, const std::string& value) : name(std::move(n)) { setenv(name.c_str(), value.c_str(), 1); }
  ~ScopedEnv() { unsetenv(name.c_str()); }
};

/// The interpreter, wrapped: each start of a python3 adds a line to dir/started.txt. Returns its path.
std::string countingPython(const std::string& dir) {
  sim::writeFileAtomic(dir + "/python.sh", "#!/bin/sh\necho started >> '" + dir + "/started.txt'\nexec /usr/bin/python3 \"$@\"\n");
  fs::permissions(dir + "/python.sh", fs::perms::owner_all);
  return dir + "/python.sh";
}

}  // namespace

TEST_CASE("figures: one plot process draws every figure of a command, a failed one is named and the next drawn",
          "[e2e][figures]") {
  ORBCAL_NEED_MATPLOTLIB();
  const std::string dir = test::tempDir("figure-batch");
  sim::writeFileAtomic(dir + "/estimates.csv", "parameter,effect,unit,estimate,sigma,truth,held,class\nd1,geometry,mm,0.1,0.01,,0,\n");
  sim::writeFileAtomic(dir + "/residuals.csv", "index,q2_deg,base_mm,selected_mm\n0,10,0.2,0.1\n1,20,0.3,0.1\n");
  const ScopedEnv python("ORBCAL_PYTHON", countingPython(dir));
  {
    const workflow::FigureFn draw = tools::batchFigureDrawer();
    const auto request = [&](const std::string& args, const std::string& png) {
      return draw(workflow::FigureRequest{dir, png, args, "caption of " + png});
    };
    CHECK(request("parameters " + workflow::shellQuote(dir + "/estimates.csv"), "a.png") == "![caption of a.png](a.png)\n");
    try {
      request("residuals " + workflow::shellQuote(dir + "/residuals.csv") + " q9_deg 'joint 9'", "b.png");
      FAIL("a figure of a column that is not there was drawn");
    } catch (const std::runtime_error& e) {
      CHECK_THAT(e.what(), StartsWith("figure b.png not drawn: plot_report.py: " + dir + "/residuals.csv: no column 'q9_deg'"));
    }
    CHECK(request("residuals " + workflow::shellQuote(dir + "/residuals.csv") + " q2_deg 'joint 2 (deg)' --floor 0.05", "c d.png") ==
          "![caption of c d.png](c d.png)\n");
  }
  CHECK(fs::file_size(dir + "/a.png") > 1000);
  CHECK(fs::file_size(dir + "/c d.png") > 1000);
  CHECK_FALSE(fs::exists(dir + "/b.png"));
  CHECK(lines(dir + "/started.txt") == 1);  // three figures, one process
}

TEST_CASE("figures: a replacement plot script that draws one figure per run still draws each", "[e2e][figures]") {
  const std::string dir = test::tempDir("figure-single");
  // A script that does not answer --batch (it draws nothing: it only touches the PNG, its last argument).
  sim::writeFileAtomic(dir + "/plot.sh", "#!/bin/sh\nfor a; do last=$a; done\n[ \"$1\" = --batch ] && exit 3\necho started >> '" + dir +
                                             "/started.txt'\ntouch \"$last\"\n");
  fs::permissions(dir + "/plot.sh", fs::perms::owner_all);
  const ScopedEnv python("ORBCAL_PYTHON", "/bin/sh");
  const ScopedEnv script("ORBCAL_PLOT_SCRIPT", dir + "/plot.sh");
  const workflow::FigureFn draw = tools::batchFigureDrawer();
  for (const char* png : {"a.png", "b.png"}) {
    CHECK(draw(workflow::FigureRequest{dir, png, "heldout x.csv", "c"}) == "![c](" + std::string(png) + ")\n");
    CHECK(fs::exists(dir + "/" + png));
  }
  CHECK(lines(dir + "/started.txt") == 2);
}

TEST_CASE("figures: two drawers of one plot process draw a command's figures side by side, their lines in order, the first "
          "failure thrown",
          "[e2e][figures]") {
  ORBCAL_NEED_MATPLOTLIB();
  const std::string dir = test::tempDir("figure-pair");
  sim::writeFileAtomic(dir + "/residuals.csv", "index,q2_deg,base_mm,selected_mm\n0,10,0.2,0.1\n1,20,0.3,0.1\n");
  const ScopedEnv python("ORBCAL_PYTHON", countingPython(dir));
  const std::string table = "residuals " + workflow::shellQuote(dir + "/residuals.csv");
  const auto figures = [&](const std::vector<std::string>& columns) {
    std::vector<workflow::FigureRequest> out;
    for (std::size_t i = 0; i < columns.size(); ++i) {
      out.push_back({dir, "f" + std::to_string(i) + ".png", table + " " + columns[i] + " label", "caption " + std::to_string(i)});
    }
    return out;
  };
  {
    const workflow::Callbacks callbacks = tools::terminalCallbacks(true, 2);
    CHECK(callbacks.figures_at_once == 2);
    std::string expected;
    for (int i = 0; i < 5; ++i) expected += "![caption " + std::to_string(i) + "](f" + std::to_string(i) + ".png)\n";
    CHECK(workflow::drawFigures(callbacks, true, figures({"q2_deg", "index", "q2_deg", "index", "q2_deg"})) == expected);
    for (int i = 0; i < 5; ++i) fs::remove(dir + "/f" + std::to_string(i) + ".png");
    // Figures 1 and 3 fail: 1's failure is thrown, once every figure has ended (4 is drawn).
    try {
      workflow::drawFigures(callbacks, true, figures({"q2_deg", "q8_deg", "index", "q9_deg", "q2_deg"}));
      FAIL("figures of columns that are not there were drawn");
    } catch (const std::runtime_error& e) {
      CHECK_THAT(e.what(), Contains("figure f1.png not drawn") && Contains("no column 'q8_deg'"));
    }
    CHECK(fs::exists(dir + "/f4.png"));
    CHECK_FALSE(fs::exists(dir + "/f3.png"));
  }
  CHECK(lines(dir + "/started.txt") == 1);  // ten figures, one interpreter started (the second drawer forked from it)
}
