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

/// One `python3 plot_report.py --batch` for the length of a command: it imports matplotlib once, while
/// the command computes (at the idle priority where it may return to the normal one: plot_report.py),
/// then draws each figure asked on its stdin (one line: plot_report.py's arguments, shell-quoted) and
/// answers on its stdout, one line each: "ok", "missing: WHY" (no matplotlib) or "error: WHY". A socket
/// pair, not pipes: a write to a process that is gone fails (MSG_NOSIGNAL) instead of raising SIGPIPE.
class PlotProcess {
 public:
  PlotProcess(const std::string& interpreter, const std::string& script) {
    int sv[2];
    if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) != 0) return;
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, sv[1], 0);
    posix_spawn_file_actions_adddup2(&actions, sv[1], 1);
    posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);  // its errors come as answers
    std::string a0 = interpreter, a1 = script, a2 = "--batch";
    char* argv[] = {a0.data(), a1.data(), a2.data(), nullptr};
    const int spawned = posix_spawnp(&pid_, interpreter.c_str(), &actions, nullptr, argv, environ);
    posix_spawn_file_actions_destroy(&actions);
    close(sv[1]);
    if (spawned != 0) {
      close(sv[0]);
      pid_ = -1;
      return;
    }
    fd_ = sv[0];
  }
  ~PlotProcess() {
    if (fd_ >= 0) close(fd_);
    if (pid_ > 0) {
      kill(pid_, SIGTERM);  // idle (every request is answered) or still importing: nothing to lose
      int status = 0;
      while (waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
      }
    }
  }
  PlotProcess(const PlotProcess&) = delete;
  PlotProcess& operator=(const PlotProcess&) = delete;

  /// The answer to one request; nullopt when the process is gone or does not speak the protocol (a
  /// replacement script): the caller then draws this and every later figure one process each.
  std::optional<std::string> ask(const std::string& request) {
    if (fd_ < 0) return std::nullopt;
    const std::string line = request + "\n";
    for (std::size_t sent = 0; sent < line.size();) {
      const ssize_t n = send(fd_, line.data() + sent, line.size() - sent, MSG_NOSIGNAL);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) return std::nullopt;
      sent += static_cast<std::size_t>(n);
    }
    std::string answer;
    char c = 0;
    for (;;) {
      const ssize_t n = recv(fd_, &c, 1, 0);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) return std::nullopt;
      if (c == '\n') break;
      answer += c;
    }
    const bool known = answer == "ok" || answer.rfind("missing: ", 0) == 0 || answer.rfind("error: ", 0) == 0;
    return known ? std::optional<std::string>(answer) : std::nullopt;
  }

 private:
  pid_t pid_ = -1;
  int fd_ = -1;
};

/// The drawer of one command: its plot processes while they answer, else one process per figure. Each
/// call takes a process no other call is using (waiting for one), so as many calls as processes run
/// side by side.
struct BatchDrawer {
  std::mutex mutex;
  std::condition_variable freed;
  std::string script = plotScript();
  std::vector<std::unique_ptr<PlotProcess>> processes;  ///< null: gone, drawn one process per figure
  std::vector<bool> busy;

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
    std::unique_ptr<PlotProcess>& process = processes[slot];  // this call's alone until released
    const std::string request = f.args + " " + workflow::shellQuote(f.folder + "/" + f.png);
    if (process && request.find('\n') == std::string::npos) {
      if (const std::optional<std::string> answer = process->ask(request)) {
        if (*answer == "ok") return "![" + f.caption + "](" + f.png + ")\n";
        if (answer->rfind("missing: ", 0) == 0) return notDrawnLine(f, sim::printable(answer->substr(9), 300));
        failed(f, sim::printable(answer->substr(7), 300), script);
      }
      process.reset();  // gone, or not a batch drawer: one process per figure from here on
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

workflow::FigureFn batchFigureDrawer(int processes) {
  auto drawer = std::make_shared<BatchDrawer>();
  for (int k = 0; k < std::max(1, processes); ++k) drawer->processes.push_back(std::make_unique<PlotProcess>(plotInterpreter(), drawer->script));
  drawer->busy.assign(drawer->processes.size(), false);
  return [drawer](const workflow::FigureRequest& f) { return drawer->draw(f); };
}

workflow::Callbacks terminalCallbacks(bool figures, int plot_processes) {
  const int at_once = figures ? std::max(1, plot_processes) : 1;
  return {terminalProgress(), figures ? batchFigureDrawer(at_once) : workflow::FigureFn(plotReportFigure), at_once};
}

}  // namespace orbcal::tools
