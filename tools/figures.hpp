#pragma once
// The figure drawer of the `orbcal` program: tools/plot_report.py run by python3 (workflow/callbacks.hpp),
// one process for all the figures of a command.
#include "orbcal/workflow/callbacks.hpp"

namespace orbcal::tools {

/// Draws folder/png with tools/plot_report.py (`args` = its kind and CSV path, quoted); returns the
/// Markdown image line, or, where python3 or matplotlib is missing (figures are optional), a line saying
/// so (also warned on stderr). Any other failure (a full disk, an unwritable folder, an error of the
/// script) throws std::runtime_error naming the figure and the script's last line: the run is not
/// complete, and the command exits non-zero. ORBCAL_PLOT_SCRIPT and ORBCAL_PYTHON in the environment
/// replace the script and the interpreter.
std::string plotReportFigure(const workflow::FigureRequest& figure);

/// The figure drawer of one command: one `python3 plot_report.py --batch` started now (it imports
/// matplotlib while the command computes, then forks into `drawers` processes) draws every figure the
/// command asks for, as many side by side as there are drawers (workflow::drawFigures), with the
/// outcomes of plotReportFigure (an image line; a "not drawn" line and a warning without matplotlib;
/// std::runtime_error naming the figure for any other failure). Where that process cannot start, ends,
/// or does not answer as plot_report.py does (an ORBCAL_PLOT_SCRIPT without --batch), each figure from
/// then on is drawn by plotReportFigure. The processes are stopped when the last copy of the drawer goes.
workflow::FigureFn batchFigureDrawer(int drawers = 1);

/// The program's callbacks: the progress bar on stderr (progress.hpp) and, with `figures`, a
/// batchFigureDrawer of `plot_drawers` drawers, the figures drawn that many at once (without:
/// plotReportFigure, which a workflow told not to draw never calls). More than one drawer pays off
/// only for a command that draws its figures with workflow::drawFigures.
workflow::Callbacks terminalCallbacks(bool figures = true, int plot_drawers = 1);

}  // namespace orbcal::tools
