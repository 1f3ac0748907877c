#pragma once
// Ctrl-C (SIGINT) and SIGTERM during a command: one line on stderr saying where the command stood (the
// stage and count of its progress, tools/progress.hpp) and what a rerun does, then exit 130 (SIGINT) or
// 143 (SIGTERM). Files are never half-written (sim::writeFileAtomic), a folder lock dies with the
// process (sim::FolderLock), and `orbcal render` keeps finished images, so a rerun resumes.
#include <string>

namespace orbcal::tools {

/// Installs the handler for SIGINT and SIGTERM (once, in main). `program` starts the line ("orbcal").
void installInterruptHandler(const char* program);
/// What the line says after the position, set by a command before its long work, e.g. "the finished
/// images are kept in DIR: rerun the same command to resume". Default: every file is written whole or
/// not at all; rerunning starts over.
void setInterruptNote(const std::string& note);
/// The position the line reports: a stage name and done / total (called by Progress).
void noteInterruptProgress(const std::string& stage, int done, int total);
/// Whether a progress line is on the terminal (the interrupt line then starts on a new line).
void noteProgressShown(bool shown);
/// A process group of the command's own (the figure drawers, tools/figures.hpp), which the terminal's
/// Ctrl-C does not reach: the handler stops it (SIGTERM) before exiting. `running` false forgets it.
void noteChildGroup(int pgid, bool running);

}  // namespace orbcal::tools
