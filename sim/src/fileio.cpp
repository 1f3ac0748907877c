#include "orbcal/sim/fileio.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <set>
#include <sstream>
#include <system_error>

#include "orbcal/sim/config.hpp"

namespace orbcal::sim {

void writeFileAtomic(const std::string& path, const std::string& content, bool sync_now) {
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw InputError(path + ": cannot write: " + std::strerror(errno));
  const bool wrote = std::fwrite(content.data(), 1, content.size(), f) == content.size();
  const int write_errno = errno;
  const bool flushed = std::fflush(f) == 0 && (!sync_now || ::fsync(::fileno(f)) == 0);
  const int flush_errno = errno;
  const bool closed = std::fclose(f) == 0;
  if (!wrote || !flushed || !closed) {
    std::remove(tmp.c_str());
    throw InputError(path + ": cannot write: " + std::strerror(!wrote ? write_errno : flush_errno));
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int e = errno;
    std::remove(tmp.c_str());
    throw InputError(path + ": cannot write: " + std::strerror(e));
  }
}

void syncFileSystem(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw InputError(path + ": cannot open to flush it to disk: " + std::strerror(errno));
  const bool ok = ::syncfs(fd) == 0;
  const int e = errno;
  ::close(fd);
  if (!ok) throw InputError(path + ": cannot flush to disk: " + std::strerror(e));
}

void makeDirectories(const std::string& path) {
  std::error_code ec;
  std::filesystem::create_directories(path, ec);
  if (ec) throw InputError(path + ": cannot create folder: " + ec.message());
}

std::string stagedName(const std::string& final_path, long pid) {
  const std::filesystem::path p(final_path);
  return (p.parent_path() / ("." + p.filename().string() + ".tmp-" + std::to_string(pid))).string();
}

StagedFolder::StagedFolder(std::string final_path, bool hidden)
    : final_(std::move(final_path)),
      tmp_(hidden ? stagedName(final_, ::getpid()) : final_ + ".tmp-" + std::to_string(::getpid())) {
  std::error_code ec;
  std::filesystem::remove_all(tmp_, ec);
  if (ec) throw InputError(tmp_ + ": cannot remove: " + ec.message());
  makeDirectories(tmp_);
}

StagedFolder::~StagedFolder() {
  if (committed_) return;
  std::error_code ec;
  std::filesystem::remove_all(tmp_, ec);
}

void StagedFolder::commit(bool replace) {
  syncFileSystem(tmp_);  // every file on disk before the folder appears under its name
  if (replace) {
    std::error_code ec;
    std::filesystem::remove_all(final_, ec);
    if (ec) throw InputError(final_ + ": cannot remove: " + ec.message());
  }
  if (std::rename(tmp_.c_str(), final_.c_str()) != 0) {
    throw InputError(final_ + ": cannot move " + tmp_ + " into place: " + std::strerror(errno));
  }
  committed_ = true;
}

void StagedFolder::commitByExchange() {
  syncFileSystem(tmp_);
  const auto fail = [&](int e) { return InputError(final_ + ": cannot move " + tmp_ + " into place: " + std::strerror(e)); };
  if (::renameat2(AT_FDCWD, tmp_.c_str(), AT_FDCWD, final_.c_str(), RENAME_EXCHANGE) != 0) {
    if (errno != EINVAL && errno != ENOSYS && errno != ENOTSUP) throw fail(errno);
    const std::string aside = tmp_ + ".old";  // no exchange here: the old folder aside, the new one in
    if (std::rename(final_.c_str(), aside.c_str()) != 0) throw fail(errno);
    if (std::rename(tmp_.c_str(), final_.c_str()) != 0) {
      const int e = errno;
      std::rename(aside.c_str(), final_.c_str());
      throw fail(e);
    }
    std::rename(aside.c_str(), tmp_.c_str());
  }
  committed_ = true;
  std::error_code ec;
  std::filesystem::remove_all(tmp_, ec);  // the old content; a leftover is removed by the next OutputFolder
}

FolderLock::FolderLock(const std::string& folder, const std::string& command) : path_(folder + "/" + kFolderLockName) {
  for (int attempt = 0; attempt < 100; ++attempt) {
    const int fd = ::open(path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) throw InputError(folder + ": cannot create the lock file " + path_ + ": " + std::strerror(errno));
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int e = errno;
      std::string holder;
      if (e == EWOULDBLOCK) {
        char buf[256];
        const ssize_t n = ::pread(fd, buf, sizeof buf - 1, 0);
        holder = n > 0 ? std::string(buf, static_cast<std::size_t>(n)) : std::string();
        while (!holder.empty() && (holder.back() == '\n' || holder.back() == ' ')) holder.pop_back();
      }
      ::close(fd);
      if (e != EWOULDBLOCK) throw InputError(path_ + ": cannot lock: " + std::strerror(e));
      throw InputError(folder + ": another command is writing this folder (lock " + path_ + " held" +
                       (holder.empty() ? std::string() : " by " + printable(holder, 80)) +
                       "); wait for it to finish, or use another folder");
    }
    // The holder before us may have removed the file between our open and our flock: then we locked a
    // file nobody else sees; take the one at the path instead.
    struct stat at_fd {}, at_path {};
    if (::fstat(fd, &at_fd) == 0 && ::stat(path_.c_str(), &at_path) == 0 && at_fd.st_ino == at_path.st_ino &&
        at_fd.st_dev == at_path.st_dev) {
      const std::string who = "process " + std::to_string(::getpid()) + " (" + command + ")\n";
      if (::ftruncate(fd, 0) == 0) {
        [[maybe_unused]] const ssize_t w = ::pwrite(fd, who.data(), who.size(), 0);
      }
      fd_ = fd;
      return;
    }
    ::close(fd);
  }
  throw InputError(path_ + ": cannot lock: the lock file keeps changing");
}

FolderLock::~FolderLock() {
  if (fd_ < 0) return;
  ::unlink(path_.c_str());  // while still held: a waiter that opened it re-checks the path (above)
  ::close(fd_);
}

namespace {

/// Every file under `folder` (not the folders themselves), as paths relative to it, sorted; the lock
/// and the output marker at its top are left out.
std::vector<std::string> filesUnder(const std::string& folder) {
  std::vector<std::string> files;
  std::error_code ec;
  for (auto it = std::filesystem::recursive_directory_iterator(folder, ec); !ec && it != std::filesystem::recursive_directory_iterator();
       it.increment(ec)) {
    if (it->is_directory(ec) && !it->is_symlink(ec)) continue;
    const std::string rel = std::filesystem::relative(it->path(), folder).generic_string();
    if (rel != kFolderLockName && rel != kOutputMarkerName) files.push_back(rel);
  }
  if (ec) throw InputError(folder + ": cannot list: " + ec.message());
  std::sort(files.begin(), files.end());
  return files;
}

/// What an output folder's marker says: the command that wrote it and the files it wrote.
struct OutputMarker {
  std::string command;
  std::set<std::string> files;
};
OutputMarker readOutputMarker(const std::string& folder) {
  OutputMarker m;
  std::FILE* f = std::fopen((folder + "/" + kOutputMarkerName).c_str(), "rb");
  if (!f) return m;
  std::string text;
  char buf[4096];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, f)) > 0;) text.append(buf, n);
  std::fclose(f);
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("command: ", 0) == 0) m.command = line.substr(9);
    if (line.rfind("file: ", 0) == 0) m.files.insert(line.substr(6));
  }
  return m;
}

/// `path` without trailing slashes ("out/" and "out" are one folder).
std::string withoutTrailingSlash(std::string path) {
  while (path.size() > 1 && path.back() == '/') path.pop_back();
  return path;
}

}  // namespace

OutputFolder::OutputFolder(std::string final_path, std::string command)
    : final_(withoutTrailingSlash(std::move(final_path))), command_(std::move(command)) {
  const std::filesystem::path absolute = std::filesystem::absolute(final_).lexically_normal();
  for (std::filesystem::path p = absolute; !p.empty() && !std::filesystem::exists(p); p = p.parent_path()) {
    created_.insert(created_.begin(), p.string());
  }
  try {
    makeDirectories(final_);
    lock_.emplace(final_, command_);
    refuseForeignFiles();
    removeStaleStaging();
    clear();
    staged_.emplace(withoutTrailingSlash(absolute.string()), true);
  } catch (...) {
    staged_.reset();
    lock_.reset();
    std::error_code ec;
    for (auto it = created_.rbegin(); it != created_.rend(); ++it) std::filesystem::remove(*it, ec);
    throw;
  }
}

OutputFolder::~OutputFolder() {
  staged_.reset();  // removed unless committed
  lock_.reset();
  if (committed_) return;
  std::error_code ec;
  for (auto it = created_.rbegin(); it != created_.rend(); ++it) std::filesystem::remove(*it, ec);  // where empty
}

std::string OutputFolder::published(const std::string& staged_path) const {
  const std::string& tmp = staged_->path();
  if (staged_path.compare(0, tmp.size(), tmp) != 0) return staged_path;
  return final_ + staged_path.substr(tmp.size());
}

void OutputFolder::refuseForeignFiles() const {
  const OutputMarker marker = readOutputMarker(final_);
  for (const std::string& file : filesUnder(final_)) {
    if (marker.command == command_ && marker.files.count(file)) continue;
    const bool other = !marker.command.empty() && marker.command != command_;
    throw InputError(final_ + ": holds " + quoteInput(file) + ", " +
                     (other ? "the output of " + printable(marker.command, 80) : "which " + command_ + " did not write") + "; " +
                     command_ + " replaces its output folder as a whole: move that away, or use a new or empty folder");
  }
}

void OutputFolder::removeStaleStaging() const {
  const std::filesystem::path p = std::filesystem::absolute(final_).lexically_normal();
  const std::string prefix = "." + std::filesystem::path(withoutTrailingSlash(p.string())).filename().string() + ".tmp-";
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(p.parent_path(), ec)) {
    if (e.path().filename().string().rfind(prefix, 0) == 0) std::filesystem::remove_all(e.path(), ec);
  }
}

void OutputFolder::swapIn(StagedFolder& staged) {
  // The lock file goes with the new content (a second name of the same file, which this process holds
  // locked), so the final path always has it.
  const std::string link = staged.path() + "/" + kFolderLockName;
  if (::link(lock_->path().c_str(), link.c_str()) != 0) {
    throw InputError(link + ": cannot link the lock file " + lock_->path() + ": " + std::strerror(errno));
  }
  staged.commitByExchange();
}

void OutputFolder::clear() {
  bool only_the_lock = true;
  for (const auto& e : std::filesystem::directory_iterator(final_)) only_the_lock = only_the_lock && e.path().filename() == kFolderLockName;
  if (only_the_lock) return;
  StagedFolder empty(withoutTrailingSlash(std::filesystem::absolute(final_).lexically_normal().string()), true);
  swapIn(empty);
}

void OutputFolder::commit() {
  std::ostringstream m;
  m << "# The output of one run of " << command_ << ", written as a whole. Its next run replaces this folder as a\n"
    << "# whole, after checking that it holds only the files listed here.\ncommand: " << command_ << "\n";
  for (const std::string& file : filesUnder(staged_->path())) m << "file: " << file << "\n";
  writeFileAtomic(staged_->path() + "/" + kOutputMarkerName, m.str(), false);
  swapIn(*staged_);
  committed_ = true;
}

}  // namespace orbcal::sim
