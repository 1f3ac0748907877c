#include "interrupt.hpp"

#include <unistd.h>

#include <atomic>
#include <csignal>
#include <signal.h>
#include <cstring>

namespace orbcal::tools {

namespace {

// What the handler reads. Strings are copied into fixed buffers (a handler may not allocate); the stage
// is double-buffered so that the handler always sees a complete one.
constexpr std::size_t kText = 512;
char g_program[64] = "orbcal";
char g_note[kText] = "every file is written whole or not at all: rerun the same command to start over";
char g_stage[2][128] = {"", ""};
std::atomic<int> g_stage_slot{0};
std::atomic<int> g_done{-1}, g_total{0};
std::atomic<bool> g_bar_shown{false};
std::atomic<int> g_groups[4] = {0, 0, 0, 0};  ///< noteChildGroup's process groups; 0: free

void copy(char* dst, std::size_t size, const std::string& src) {
  const std::size_t n = std::min(size - 1, src.size());
  std::memcpy(dst, src.data(), n);
  dst[n] = '\0';
}

/// Appends to buf (async-signal-safe).
struct Line {
  char buf[2 * kText];
  std::size_t n = 0;
  void add(const char* s) {
    while (*s && n + 1 < sizeof buf) buf[n++] = *s++;
  }
  void add(int v) {
    char digits[16];
    int k = 0;
    unsigned u = v < 0 ? 0u - static_cast<unsigned>(v) : static_cast<unsigned>(v);
    do {
      digits[k++] = static_cast<char>('0' + u % 10);
      u /= 10;
    } while (u && k < 15);
    if (v < 0) add("-");
    while (k > 0 && n + 1 < sizeof buf) buf[n++] = digits[--k];
  }
};

extern "C" void onInterrupt(int sig) {
  Line l;
  if (g_bar_shown.load()) l.add("\n");
  l.add(g_program);
  l.add(sig == SIGINT ? ": interrupted (SIGINT)" : ": stopped (SIGTERM)");
  const int done = g_done.load(), total = g_total.load();
  const char* stage = g_stage[g_stage_slot.load()];
  if (done >= 0 && stage[0] != '\0') {
    l.add(" at ");
    l.add(stage);
    l.add(" ");
    l.add(done);
    l.add("/");
    l.add(total);
  }
  l.add("; ");
  l.add(g_note);
  l.add("\n");
  [[maybe_unused]] const ssize_t w = ::write(2, l.buf, l.n);
  for (std::atomic<int>& g : g_groups) {
    if (const int pgid = g.load(); pgid > 0) ::kill(-pgid, SIGTERM);
  }
  ::_exit(128 + sig);
}

}  // namespace

void installInterruptHandler(const char* program) {
  copy(g_program, sizeof g_program, program);
  struct sigaction sa {};
  sa.sa_handler = onInterrupt;
  sigemptyset(&sa.sa_mask);
  sigaddset(&sa.sa_mask, SIGINT);
  sigaddset(&sa.sa_mask, SIGTERM);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

void setInterruptNote(const std::string& note) { copy(g_note, sizeof g_note, note); }

void noteInterruptProgress(const std::string& stage, int done, int total) {
  const int slot = g_stage_slot.load();
  if (stage != g_stage[slot]) {
    copy(g_stage[1 - slot], sizeof g_stage[0], stage);
    g_stage_slot.store(1 - slot);
  }
  g_total.store(total);
  g_done.store(done);
}

void noteProgressShown(bool shown) { g_bar_shown.store(shown); }

void noteChildGroup(int pgid, bool running) {
  for (std::atomic<int>& g : g_groups) {
    int expected = running ? 0 : pgid;
    if (g.compare_exchange_strong(expected, running ? pgid : 0)) return;  // more than four at once: not stopped
  }
}

}  // namespace orbcal::tools
