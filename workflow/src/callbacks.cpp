#include "orbcal/workflow/callbacks.hpp"

#include <algorithm>
#include <atomic>
#include <exception>
#include <future>
#include <utility>

namespace orbcal::workflow {

Progress::Progress(ProgressFn fn, std::string stage, int total)
    : fn_(std::move(fn)), stage_(std::move(stage)), total_(total), open_(fn_ && total > 0) {
  if (open_) fn_(stage_, 0, total_);
}

Progress::~Progress() {
  try {
    finish();
  } catch (...) {  // a destructor does not throw: the caller's progress display failed, the work did not
  }
}

void Progress::update(int done) {
  if (open_) fn_(stage_, done, total_);
}

void Progress::finish() {
  if (!open_) return;
  open_ = false;
  fn_(stage_, -1, total_);
}

std::string shellQuote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

std::string drawFigure(const Callbacks& callbacks, bool plots, const std::string& folder, const std::string& args,
                       const std::string& png, const std::string& caption) {
  if (!plots) return "(figures not drawn: --no-plots)\n";
  if (!callbacks.figure) return "(figure " + png + " not drawn: no figure drawer given)\n";
  return callbacks.figure(FigureRequest{folder, png, args, caption});
}

std::string drawFigures(const Callbacks& callbacks, bool plots, const std::vector<FigureRequest>& figures) {
  std::vector<std::string> lines(figures.size());
  std::vector<std::exception_ptr> failures(figures.size());
  std::atomic<std::size_t> next{0};
  const auto work = [&] {  // takes the next figure not yet taken until none is left
    for (std::size_t i = next++; i < figures.size(); i = next++) {
      const FigureRequest& f = figures[i];
      try {
        lines[i] = drawFigure(callbacks, plots, f.folder, f.args, f.png, f.caption);
      } catch (...) {
        failures[i] = std::current_exception();
      }
    }
  };
  const std::size_t workers = std::min(figures.size(), static_cast<std::size_t>(std::max(1, callbacks.figures_at_once)));
  std::vector<std::future<void>> others;
  for (std::size_t w = 1; w < workers; ++w) others.push_back(std::async(std::launch::async, work));
  work();
  for (std::future<void>& o : others) o.get();
  std::string out;
  for (std::size_t i = 0; i < figures.size(); ++i) {
    if (failures[i]) std::rethrow_exception(failures[i]);
    out += lines[i];
  }
  return out;
}

}  // namespace orbcal::workflow
