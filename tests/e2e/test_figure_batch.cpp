// The program's figure drawer (tools/figures.hpp): one python3 process draws all the figures of a command,
// answering each (an image line; a failure named, and the next figure still drawn).
#include <catch2/catch.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "figures.hpp"
#include "orbcal/sim/fileio.hpp"
#include "test_util.hpp"

namespace fs = std::filesystem;
using namespace orbcal;
using Catch::Matchers::Contains;
using Catch::Matchers::StartsWith;

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

}  // namespace

TEST_CASE("figures: one plot process draws every figure of a command, a failed one is named and the next drawn",
          "[e2e][figures]") {
  if (system("/usr/bin/python3 -c 'import matplotlib' 2>/dev/null") != 0) {
    ORBCAL_SKIP("python3 with matplotlib is not installed");
  }
  const std::string dir = test::tempDir("figure-batch");
  sim::writeFileAtomic(dir + "/estimates.csv", "parameter,effect,unit,estimate,sigma,truth,held,class\nd1,geometry,mm,0.1,0.01,,0,\n");
  sim::writeFileAtomic(dir + "/residuals.csv", "index,q2_deg,base_mm,selected_mm\n0,10,0.2,0.1\n1,20,0.3,0.1\n");
  // The interpreter, wrapped: each start of a python3 adds a line to started.txt.
  sim::writeFileAtomic(dir + "/python.sh", "#!/bin/sh\necho started >> '" + dir + "/started.txt'\nexec /usr/bin/python3 \"$@\"\n");
  fs::permissions(dir + "/python.sh", fs::perms::owner_all);
  const ScopedEnv python("ORBCAL_PYTHON", dir + "/python.sh");
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
