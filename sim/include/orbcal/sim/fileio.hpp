#pragma once
// Output that is never half-written: content goes to a temporary file beside the target, is
// flushed, then renamed over it. A full disk or an unwritable folder gives an InputError that
// names the file, and the previous content (if any) stays intact.
#include <string>

namespace orbcal::sim {

void writeFileAtomic(const std::string& path, const std::string& content);
/// Creates the folder and its parents; throws InputError naming the folder on failure.
void makeDirectories(const std::string& path);

/// An exclusive lock on a folder while a command writes it (a dataset folder, a calibration output):
/// flock(2) on <folder>/.orbcal.lock, taken without waiting. A second writer gets an InputError naming
/// the folder, the lock file and the process holding it, so two runs never mix their files. The lock
/// is released (and the lock file removed) by the destructor, and by the kernel when the process exits
/// or crashes, so a stale lock never blocks a rerun. The folder must exist.
class FolderLock {
 public:
  /// `command` says who holds it, e.g. "orbcal render"; recorded in the lock file for the message.
  FolderLock(const std::string& folder, const std::string& command);
  ~FolderLock();
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  int fd_ = -1;
};

/// Name of the lock file FolderLock makes in a folder.
inline constexpr const char* kFolderLockName = ".orbcal.lock";

}  // namespace orbcal::sim
