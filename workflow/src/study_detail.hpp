#pragma once
// Helpers shared by the study sources (study.cpp, study_run.cpp, study_slurm.cpp, study_merge.cpp); not
// part of the library's interface.
#include <string>
#include <utility>
#include <vector>

#include "orbcal/workflow/study.hpp"

namespace orbcal::workflow::study_detail {

/// Figures redrawn per cell from the merged rows: (CSV, plot_report.py kind).
std::vector<std::pair<std::string, std::string>> builtinFigures(const StudySpec& s);
/// "task-NNNNNN".
std::string taskName(int index);
/// Columns that hold wall times, not results: left out of merged CSVs (they differ from run to run).
bool isTiming(const std::string& column);
/// A command line as a shell reads it back: arguments with other characters than [A-Za-z0-9_./:=+-] quoted.
std::string joinArgs(const std::vector<std::string>& args);
/// A YAML double-quoted scalar.
std::string yamlQuote(const std::string& text);
/// "a, b, c".
std::string joinList(const std::vector<std::string>& items);
/// What a Slurm query printed; empty where Slurm is not there or refuses (sacct without accounting).
std::string slurmQuery(const std::string& command);
/// Whether a path exists (false where it cannot be told).
bool exists(const std::string& p);
/// Removes a file or folder tree; InputError naming it when it cannot.
void removeAll(const std::string& p);

}  // namespace orbcal::workflow::study_detail
