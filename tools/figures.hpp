#pragma once
// The figure drawer of the `orbcal` program: tools/plot_report.py run by python3 (workflow/callbacks.hpp).
#include "orbcal/workflow/callbacks.hpp"

namespace orbcal::tools {

/// Draws folder/png with tools/plot_report.py (`args` = its kind and CSV path, quoted); returns the
/// Markdown image line, or, where python3 or matplotlib is missing (figures are optional), a line saying
/// so (also warned on stderr). Any other failure (a full disk, an unwritable folder, an error of the
/// script) throws std::runtime_error naming the figure and the script's last line: the run is not
/// complete, and the command exits non-zero. ORBCAL_PLOT_SCRIPT and ORBCAL_PYTHON in the environment
/// replace the script and the interpreter.
std::string plotReportFigure(const workflow::FigureRequest& figure);

/// The program's callbacks: the progress bar on stderr (progress.hpp) and plotReportFigure.
workflow::Callbacks terminalCallbacks();

}  // namespace orbcal::tools
