#pragma once
// Output that is never half-written: content goes to a temporary file beside the target, is
// flushed, then renamed over it. A full disk or an unwritable folder gives an InputError that
// names the file, and the previous content (if any) stays intact.
#include <string>

namespace orbcal::sim {

/// With `sync_now` false the content is not fsync'ed (an fsync costs ~7 ms on the development machine,
/// more than rendering an image): the rename is still atomic (readers see the old file or the whole new
/// one), but after a crash the file may be empty until syncFileSystem has run. Call syncFileSystem before
/// writing anything that says such files are complete.
void writeFileAtomic(const std::string& path, const std::string& content, bool sync_now = true);
/// Flushes every file of the file system holding `path` to disk (syncfs: one journal commit for all the
/// files written with sync_now false). Throws InputError naming `path` on failure.
void syncFileSystem(const std::string& path);
/// Creates the folder and its parents; throws InputError naming the folder on failure.
void makeDirectories(const std::string& path);

/// A folder that is never seen half-written: it is built as <path>.tmp-PID beside its final path (so the
/// rename is atomic), flushed to disk and renamed into place by commit(); destroyed without commit()
/// (a failure, an exception), it is removed. A stale <path>.tmp-PID of a killed earlier run is replaced.
class StagedFolder {
 public:
  explicit StagedFolder(std::string final_path);
  ~StagedFolder();
  StagedFolder(const StagedFolder&) = delete;
  StagedFolder& operator=(const StagedFolder&) = delete;
  /// Where to write the content meanwhile.
  const std::string& path() const { return tmp_; }
  /// syncFileSystem, then the rename. `replace`: a folder already at the final path is removed first;
  /// otherwise it makes the rename fail (InputError naming both paths).
  void commit(bool replace = false);

 private:
  std::string final_, tmp_;
  bool committed_ = false;
};

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
