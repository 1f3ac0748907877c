#include "orbcal/workflow/callbacks.hpp"

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

}  // namespace orbcal::workflow
