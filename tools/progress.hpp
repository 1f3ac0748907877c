#pragma once
// A progress line on a terminal (stderr), silent when stderr is not a terminal (CI, pipes, logs).
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <map>
#include <memory>
#include <string>

#include "interrupt.hpp"
#include "orbcal/workflow/callbacks.hpp"

namespace orbcal::tools {

class Progress {
 public:
  Progress(std::string label, int total)
      : label_(std::move(label)), total_(total), tty_(::isatty(2) != 0), start_(std::chrono::steady_clock::now()) {
    if (total_ > 0) noteInterruptProgress(label_, 0, total_);  // what Ctrl-C reports (interrupt.hpp)
  }
  ~Progress() { finish(); }
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void update(int done) {
    if (total_ <= 0) return;
    noteInterruptProgress(label_, done, total_);
    if (!tty_) return;
    const auto now = std::chrono::steady_clock::now();
    if (done < total_ && now - last_ < std::chrono::milliseconds(100)) return;
    last_ = now;
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    const double eta = done > 0 ? elapsed * (total_ - done) / done : 0.0;
    const int width = 30, filled = width * done / total_;
    std::fprintf(stderr, "\r%s [%s%s] %d/%d  %.1f s, %.0f s left ", label_.c_str(), std::string(filled, '#').c_str(),
                 std::string(width - filled, '.').c_str(), done, total_, elapsed, eta);
    std::fflush(stderr);
    shown_ = true;
    noteProgressShown(true);
  }
  void finish() {
    if (shown_) std::fprintf(stderr, "\n");
    if (shown_) noteProgressShown(false);
    shown_ = false;
  }

 private:
  std::string label_;
  int total_;
  bool tty_;
  bool shown_ = false;
  std::chrono::steady_clock::time_point start_, last_{};
};

/// A workflow's progress callback (workflow/callbacks.hpp) drawn as these bars: one per open stage,
/// closed when the stage ends (done = -1).
inline workflow::ProgressFn terminalProgress() {
  auto bars = std::make_shared<std::map<std::string, std::unique_ptr<Progress>>>();
  return [bars](const std::string& stage, int done, int total) {
    if (done < 0) {
      bars->erase(stage);
      return;
    }
    auto& bar = (*bars)[stage];
    if (!bar) bar = std::make_unique<Progress>(stage, total);
    bar->update(done);
  };
}

}  // namespace orbcal::tools
