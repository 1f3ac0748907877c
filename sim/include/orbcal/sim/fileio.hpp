#pragma once
// Output that is never half-written: content goes to a temporary file beside the target, is
// flushed, then renamed over it. A full disk or an unwritable folder gives an InputError that
// names the file, and the previous content (if any) stays intact.
#include <string>

namespace orbcal::sim {

void writeFileAtomic(const std::string& path, const std::string& content);
/// Creates the folder and its parents; throws InputError naming the folder on failure.
void makeDirectories(const std::string& path);

}  // namespace orbcal::sim
