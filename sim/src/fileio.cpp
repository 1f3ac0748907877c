#include "orbcal/sim/fileio.hpp"

#include <fcntl.h>
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

}  // namespace orbcal::sim
