#include "figures.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <iostream>
#include <stdexcept>

#include "orbcal/sim/config.hpp"
#include "orbcal/workflow/experiment.hpp"
#include "progress.hpp"

namespace orbcal::tools {

std::string plotReportFigure(const workflow::FigureRequest& f) {
  const char* env = std::getenv("ORBCAL_PLOT_SCRIPT");
  const std::string script = env ? env : ORBCAL_PLOT_SCRIPT;
  // Debian's python3 (with python3-matplotlib) first: another python3 may come first on PATH.
  const char* python = std::getenv("ORBCAL_PYTHON");
  const std::string interpreter = python ? python : (access("/usr/bin/python3", X_OK) == 0 ? "/usr/bin/python3" : "python3");
  const std::string cmd = interpreter + " " + workflow::shellQuote(script) + " " + f.args + " " + workflow::shellQuote(f.folder + "/" + f.png) + " 2>&1";
  auto [status, output] = workflow::shellOutput(cmd);
  if (status == 0) return "![" + f.caption + "](" + f.png + ")\n";
  // The last line of a Python error is its message (e.g. "ModuleNotFoundError: No module named ...").
  while (!output.empty() && output.back() == '\n') output.pop_back();
  const std::string last = sim::printable(output.substr(output.find_last_of('\n') + 1), 300);
  const bool no_python = status == -1 || (WIFEXITED(status) && WEXITSTATUS(status) == 127);
  if (no_python || output.find("No module named") != std::string::npos) {  // figures are optional: a warning
    std::cerr << "orbcal: warning: figure " << f.png << " not drawn (python3 with matplotlib is needed): " << last << "\n";
    return "(figure " + f.png + " not drawn: python3 with matplotlib is needed)\n";
  }
  // Anything else (a full disk, an unwritable folder, a plotting error): the run is not complete.
  throw std::runtime_error("figure " + f.png + " not drawn: " + (last.empty() ? "the plot script failed" : last) + " (" + script + ")");
}

workflow::Callbacks terminalCallbacks() { return {terminalProgress(), plotReportFigure}; }

}  // namespace orbcal::tools
