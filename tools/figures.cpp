#include "figures.hpp"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <condition_variable>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <vector>

#include "orbcal/sim/config.hpp"
#include "orbcal/workflow/experiment.hpp"
#include "interrupt.hpp"
#include "progress.hpp"

extern char** environ;

namespace orbcal::tools {

namespace {

std::string plotScript() {
  const char* env = std::getenv("ORBCAL_PLOT_SCRIPT");
  return env ? env : ORBCAL_PLOT_SCRIPT;
}

std::string plotInterpreter() {
  // Debian's python3 (with python3-matplotlib) first: another python3 may come first on PATH.
  const char* python = std::getenv("ORBCAL_PYTHON");
  return python ? python : (access("/usr/bin/python3", X_OK) == 0 ? "/usr/bin/python3" : "python3");
}

/// The Markdown line of a figure not drawn for want of matplotlib (figures are optional), warned on stderr.
std::string notDrawnLine(const workflow::FigureRequest& f, const std::string& why) {
  std::cerr << "orbcal: warning: figure " << f.png << " not drawn (python3 with matplotlib is needed): " << why << "\n";
  return "(figure " + f.png + " not drawn: python3 with matplotlib is needed)\n";
}

[[noreturn]] void failed(const workflow::FigureRequest& f, const std::string& why, const std::string& script) {
  throw std::runtime_error("figure " + f.png + " not drawn: " + (why.empty() ? "the plot script failed" : why) + " (" + script + ")");
}

/// A socket's end moved to a descriptor of at least 100 (close-on-exec): no target of the spawn's dup2
/// (0, 1, 3, 4, ...) is then also a source.
int highDescriptor(int fd) {
  const int high = fcntl(fd, F_DUPFD_CLOEXEC, 100);
  close(fd);
  return high;
}

/// One `python3 plot_report.py --batch` for the length of a command, with `drawers` sockets: it imports
/// matplotlib once, while the command computes (at the idle priority where it may return to the normal
/// one: plot_report.py), then forks one drawer per further socket (`--fds 3,4,...`), so that the
/// import's time is paid once. Each drawer draws each figure asked on its socket (one line:
/// plot_report.py's arguments, shell-quoted) and answers, one line each: "ok", "missing: WHY" (no
/// matplotlib) or "error: WHY". Sockets, not pipes: a write to a process that is gone fails
/// (MSG_NOSIGNAL) instead of raising SIGPIPE. The drawers form their own process group, stopped
/// together.
class PlotProcess {
 public:
  PlotProcess(const std::string& interpreter, const std::string& script, int drawers) {
    std::vector<int> theirs;
    for (int k = 0; k < drawers; ++k) {
      int sv[2];
      if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) != 0) break;
      fds_.push_back(sv[0]);
      theirs.push_back(highDescriptor(sv[1]));
    }
    const bool ready = !fds_.empty() && std::find(theirs.begin(), theirs.end(), -1) == theirs.end();
    if (ready) spawn(interpreter, script, theirs);
    for (int fd : theirs) {
      if (fd >= 0) close(fd);
    }
    if (pid_ < 0) stop();  // every drawer gone: each figure drawn one process each
  }
  ~PlotProcess() { stop(); }
  PlotProcess(const PlotProcess&) = delete;
  PlotProcess& operator=(const PlotProcess&) = delete;

  /// Drawer k's answer to one request; nullopt when it is gone or does not speak the protocol (a
  /// replacement script): the caller then draws this and every later figure one process each.
  std::optional<std::string> ask(std::size_t k, const std::string& request) {
    const int fd = k < fds_.size() ? fds_[k] : -1;
    if (fd < 0) return std::nullopt;
    const std::string line = request + "\n";
    for (std::size_t sent = 0; sent < line.size();) {
      const ssize_t n = send(fd, line.data() + sent, line.size() - sent, MSG_NOSIGNAL);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) return std::nullopt;
      sent += static_cast<std::size_t>(n);
    }
    std::string answer;
    char c = 0;
    for (;;) {
      const ssize_t n = recv(fd, &c, 1, 0);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) return std::nullopt;
      if (c == '\n') break;
      answer += c;
    }
    const bool known = answer == "ok" || answer.rfind("missing: ", 0) == 0 || answer.rfind("error: ", 0) == 0;
    return known ? std::optional<std::string>(answer) : std::nullopt;
  }

 private:
  /// Starts the interpreter: drawer 0 on its stdin and stdout, drawer k on descriptor k + 2.
  void spawn(const std::string& interpreter, const std::string& script, const std::vector<int>& theirs) {
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, theirs[0], 0);
    posix_spawn_file_actions_adddup2(&actions, theirs[0], 1);
    posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);  // its errors come as answers
    std::vector<std::string> args{interpreter, script, "--batch"};
    std::string more;
    for (std::size_t k = 1; k < theirs.size(); ++k) {
      posix_spawn_file_actions_adddup2(&actions, theirs[k], static_cast<int>(k) + 2);
      more += (k > 1 ? "," : "") + std::to_string(k + 2);
    }
    if (!more.empty()) args.insert(args.end(), {"--fds", more});
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawnattr_t attributes;
    posix_spawnattr_init(&attributes);
    posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETPGROUP);
    posix_spawnattr_setpgroup(&attributes, 0);
    if (posix_spawnp(&pid_, interpreter.c_str(), &actions, &attributes, argv.data(), environ) != 0) pid_ = -1;
    if (pid_ > 0) noteChildGroup(pid_, true);  // out of the terminal's group: Ctrl-C's handler stops it
    posix_spawnattr_destroy(&attributes);
    posix_spawn_file_actions_destroy(&actions);
  }

  /// Closes the sockets and stops the process group (idle, every request answered, or still importing:
  /// nothing to lose); waits for the process started.
  void stop() {
    for (int& fd : fds_) {
      if (fd >= 0) close(fd);
      fd = -1;
    }
    if (pid_ > 0) {
      kill(-pid_, SIGTERM);
      int status = 0;
      while (waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
      }
      noteChildGroup(pid_, false);
      pid_ = -1;
    }
  }

  pid_t pid_ = -1;
  std::vector<int> fds_;  ///< this side's end of each drawer's socket; -1: closed
};

/// The drawer of one command: the plot process's drawers while they answer, else one process per
/// figure. Each call takes a drawer no other call is using (waiting for one), so as many calls as
/// drawers run side by side.
struct BatchDrawer {
  std::mutex mutex;
  std::condition_variable freed;
  std::string script = plotScript();
  std::unique_ptr<PlotProcess> process;
  std::vector<bool> busy;
  /// Drawer k ended or did not answer: its figures drawn one process each (char, not bool: the
  /// drawers write their own entries side by side).
  std::vector<char> gone;

  std::string draw(const workflow::FigureRequest& f) {
    std::size_t slot = 0;
    {
      std::unique_lock<std::mutex> lock(mutex);
      freed.wait(lock, [&] { return std::find(busy.begin(), busy.end(), false) != busy.end(); });
      slot = static_cast<std::size_t>(std::find(busy.begin(), busy.end(), false) - busy.begin());
      busy[slot] = true;
    }
    struct Release {
      BatchDrawer& d;
      std::size_t slot;
      ~Release() {
        {
          const std::lock_guard<std::mutex> lock(d.mutex);
          d.busy[slot] = false;
        }
        d.freed.notify_one();
      }
    } release{*this, slot};
    const std::string request = f.args + " " + workflow::shellQuote(f.folder + "/" + f.png);
    if (!gone[slot] && request.find('\n') == std::string::npos) {  // gone[slot]: this call's alone until released
      if (const std::optional<std::string> answer = process->ask(slot, request)) {
        if (*answer == "ok") return "![" + f.caption + "](" + f.png + ")\n";
        if (answer->rfind("missing: ", 0) == 0) return notDrawnLine(f, sim::printable(answer->substr(9), 300));
        failed(f, sim::printable(answer->substr(7), 300), script);
      }
      gone[slot] = true;  // gone, or not a batch drawer: one process per figure from here on
    }
    return plotReportFigure(f);
  }
};

}  // namespace

std::string plotReportFigure(const workflow::FigureRequest& f) {
  const std::string script = plotScript();
  const std::string cmd = plotInterpreter() + " " + workflow::shellQuote(script) + " " + f.args + " " +
                          workflow::shellQuote(f.folder + "/" + f.png) + " 2>&1";
  auto [status, output] = workflow::shellOutput(cmd);
  if (status == 0) return "![" + f.caption + "](" + f.png + ")\n";
  // The last line of a Python error is its message (e.g. "ModuleNotFoundError: No module named ...").
  while (!output.empty() && output.back() == '\n') output.pop_back();
  const std::string last = sim::printable(output.substr(output.find_last_of('\n') + 1), 300);
  const bool no_python = status == -1 || (WIFEXITED(status) && WEXITSTATUS(status) == 127);
  if (no_python || output.find("No module named") != std::string::npos) return notDrawnLine(f, last);  // figures are optional
  // Anything else (a full disk, an unwritable folder, a plotting error): the run is not complete.
  failed(f, last, script);
}

workflow::FigureFn batchFigureDrawer(int drawers) {
  auto drawer = std::make_shared<BatchDrawer>();
  const int n = std::max(1, drawers);
  drawer->process = std::make_unique<PlotProcess>(plotInterpreter(), drawer->script, n);
  drawer->busy.assign(static_cast<std::size_t>(n), false);
  drawer->gone.assign(static_cast<std::size_t>(n), false);
  return [drawer](const workflow::FigureRequest& f) { return drawer->draw(f); };
}

workflow::Callbacks terminalCallbacks(bool figures, int plot_drawers) {
  const int at_once = figures ? std::max(1, plot_drawers) : 1;
  return {terminalProgress(), figures ? batchFigureDrawer(at_once) : workflow::FigureFn(plotReportFigure), at_once};
}

}  // namespace orbcal::tools
