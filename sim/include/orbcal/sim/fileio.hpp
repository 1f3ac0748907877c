#pragma once
// Output that is never half-written: content goes to a temporary file beside the target, is
// flushed, then renamed over it. A full disk or an unwritable folder gives an InputError that
// names the file, and the previous content (if any) stays intact.
#include <optional>
#include <string>
#include <vector>

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
/// `hidden`: built as <parent>/.<name>.tmp-PID instead (stagedName), out of sight of `ls`.
class StagedFolder {
 public:
  explicit StagedFolder(std::string final_path, bool hidden = false);
  ~StagedFolder();
  StagedFolder(const StagedFolder&) = delete;
  StagedFolder& operator=(const StagedFolder&) = delete;
  /// Where to write the content meanwhile.
  const std::string& path() const { return tmp_; }
  /// syncFileSystem, then the rename. `replace`: a folder already at the final path is removed first;
  /// otherwise it makes the rename fail (InputError naming both paths).
  void commit(bool replace = false);
  /// syncFileSystem, then swaps the staged folder with the folder at the final path, which must exist,
  /// in one atomic step (renameat2 RENAME_EXCHANGE: a reader sees the old folder or the new one, never
  /// none), and removes the old content, now at path(). File systems without the exchange (NFS) get
  /// two renames, the final path missing between them. InputError naming both paths on failure.
  void commitByExchange();

 private:
  std::string final_, tmp_;
  bool committed_ = false;
};

/// The hidden staging name of `final_path` for `pid`: <parent>/.<name>.tmp-PID.
std::string stagedName(const std::string& final_path, long pid);

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
/// Name of the file OutputFolder leaves in a folder it wrote: the command and the files it wrote.
inline constexpr const char* kOutputMarkerName = ".orbcal-output";

/// A command's output folder (calibrate -o, diagnose -o, evaluate -o, simulate -o, an experiment's
/// folder), written as a whole, so that it never mixes two runs and never shows an earlier run's
/// result as this one's:
///  1. the constructor creates the folder (and its parents) where missing and locks it (FolderLock,
///     as dataset writers do: a second writer is refused with the folder and the lock named); a folder
///     holding anything this command did not write there (per the kOutputMarkerName file of its last
///     run; every file counts, a user's own too) is refused with the first such file named, and left
///     as it was. It then clears the folder: the earlier run's files go at once, so that a run that
///     fails, is refused or is killed from here on leaves no result of the run before either;
///  2. the command writes into path(), a hidden sibling (<parent>/.<name>.tmp-PID);
///  3. commit() writes the marker and exchanges the staged folder with the (empty) folder atomically.
/// Destroyed without commit() (an exception), the staged folder is removed, the lock released, and
/// the folders the constructor created are removed again: the folder is left empty or absent. Staged
/// folders of killed earlier runs (the lock proves them dead) are removed by the next run.
class OutputFolder {
 public:
  /// `command` ("orbcal calibrate") names the lock's holder and the folder's owner.
  OutputFolder(std::string final_path, std::string command);
  ~OutputFolder();
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;
  /// Where to write meanwhile.
  const std::string& path() const { return staged_->path(); }
  /// Where the folder is once committed.
  const std::string& finalPath() const { return final_; }
  /// `staged_path` (path() or a file under it) as it will be named after commit().
  std::string published(const std::string& staged_path) const;
  void commit();

 private:
  void refuseForeignFiles() const;
  void clear();
  void removeStaleStaging() const;
  void swapIn(StagedFolder& staged);
  std::string final_, command_;
  std::vector<std::string> created_;  ///< folders the constructor made, outermost first
  std::optional<FolderLock> lock_;
  std::optional<StagedFolder> staged_;
  bool committed_ = false;
};

}  // namespace orbcal::sim
