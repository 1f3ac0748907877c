#include "orbcal/sim/fileio.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
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

StagedFolder::StagedFolder(std::string final_path)
    : final_(std::move(final_path)), tmp_(final_ + ".tmp-" + std::to_string(::getpid())) {
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

}  // namespace orbcal::sim
