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

}  // namespace orbcal::sim
