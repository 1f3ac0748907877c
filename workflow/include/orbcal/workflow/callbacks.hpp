#pragma once
// What a long-running workflow reports to its caller: progress and figures, as callbacks, so that the
// library never writes to a terminal nor runs a plotting program itself. The `orbcal` program passes a
// progress bar on stderr and a runner of tools/plot_report.py (tools/progress.hpp, tools/figures.hpp);
// a test or a Python caller passes its own, or none.
#include <functional>
#include <string>
#include <vector>

namespace orbcal::workflow {

/// Progress of one stage: `done` of `total` steps. A stage starts with done = 0 and ends with one call
/// with done = -1 (finished or abandoned by an exception: a progress line may be closed then). Several
/// stages may be open at once (a stage inside another), told apart by name.
using ProgressFn = std::function<void(const std::string& stage, int done, int total)>;

/// A figure of a report: tools/plot_report.py's arguments (`args`: the figure kind and its CSV file,
/// quoted for a shell), drawn into folder/png, with `caption` as its alt text.
struct FigureRequest {
  std::string folder, png, args, caption;
};
/// Draws a figure; returns the report's Markdown image line, or a line saying it was not drawn (figures
/// are optional where the drawer is missing). Throws std::runtime_error on a real failure (a full disk,
/// an error of the drawer): the run is then not complete.
using FigureFn = std::function<std::string(const FigureRequest& figure)>;

/// Carried by the options of every long-running workflow. Empty callbacks: no progress, no figures.
struct Callbacks {
  ProgressFn progress;
  FigureFn figure;
  /// How many calls `figure` takes side by side, from as many threads (drawFigures): 1, one at a time.
  int figures_at_once = 1;
};

/// One stage's progress for the length of a scope: start (done = 0) on construction, update(done),
/// end (done = -1) on finish() or destruction. Silent with an empty callback or total <= 0.
class Progress {
 public:
  Progress(ProgressFn fn, std::string stage, int total);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;
  void update(int done);
  void finish();

 private:
  ProgressFn fn_;
  std::string stage_;
  int total_;
  bool open_;
};

/// One argument quoted for a POSIX shell ('...', an apostrophe as '\''): what FigureRequest::args
/// and the study's command lines are made of, whatever the paths and labels hold.
std::string shellQuote(const std::string& s);

/// The Markdown line of a figure: drawn by `callbacks.figure`; "(figures not drawn: --no-plots)" when
/// `plots` is off; a "not drawn" line without a drawer. Throws what the drawer throws.
std::string drawFigure(const Callbacks& callbacks, bool plots, const std::string& folder, const std::string& args,
                       const std::string& png, const std::string& caption);

/// Several figures' lines, in their order, each as drawFigure gives it, Callbacks::figures_at_once of
/// them drawn side by side; once all have ended, the first failure (in their order) is thrown.
std::string drawFigures(const Callbacks& callbacks, bool plots, const std::vector<FigureRequest>& figures);

}  // namespace orbcal::workflow
