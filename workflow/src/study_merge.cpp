// Studies: merging the finished tasks into one report (study.hpp).
#include "orbcal/workflow/study.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <set>
#include <sstream>
#include <thread>
#include <tuple>

#include "orbcal/workflow/experiment.hpp"
#include "orbcal/workflow/report_html.hpp"
#include "orbcal/calib/diagnose.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/fileio.hpp"
#include "study_detail.hpp"

namespace fs = std::filesystem;

namespace orbcal::workflow {

using sim::InputError;
using namespace study_detail;

// --- merge ---------------------------------------------------------------------------------------

namespace {

struct MergedTable {
  std::vector<std::string> header;                 ///< the job's columns (timings left out)
  std::vector<int> source_columns;                 ///< their columns in the job's file
  std::vector<std::pair<int, std::vector<std::string>>> rows;  ///< (task, cells)
};

void collectCsvs(const fs::path& root, const fs::path& here, std::set<std::string>& out) {
  std::vector<fs::path> entries;
  for (const auto& e : fs::directory_iterator(here)) entries.push_back(e.path());
  std::sort(entries.begin(), entries.end());
  for (const fs::path& p : entries) {
    if (fs::is_directory(p)) {
      if (p.filename() != "datasets") collectCsvs(root, p, out);
    } else if (p.extension() == ".csv") {
      out.insert(fs::relative(p, root).generic_string());
    }
  }
}

std::string prefixHeader(const StudySpec& s) {
  std::string h = "task,cell,replicate,seed";
  for (const auto& [key, values] : s.grid) h += "," + key;
  return h;
}

std::string prefixCells(const StudyTask& t) {
  std::string h = std::to_string(t.index) + "," + std::to_string(t.cell) + "," + std::to_string(t.replicate) + "," +
                  std::to_string(t.seed);
  for (const std::string& v : t.cell_values) h += "," + v;
  return h;
}

/// "2.432 +- 0.093 [2.414, 2.451]": the standard deviation to two significant digits, the mean and the
/// interval to the same decimal place (a spread of 0 or a single seed: four significant digits).
std::string markdownCell(double mean, double sd, double half, std::size_t n) {
  if (n == 0) return "-";
  if (!(sd > 0.0) || !std::isfinite(sd)) return formatNumber("%.4g", mean) + (sd == 0.0 && n > 1 ? " +- 0" : "");
  const int decimals = std::clamp(1 - static_cast<int>(std::floor(std::log10(sd))), 0, 12);
  const std::string f = "%." + std::to_string(decimals) + "f";
  return formatNumber(f.c_str(), mean) + " +- " + formatNumber(f.c_str(), sd) + " [" + formatNumber(f.c_str(), mean - half) +
         ", " + formatNumber(f.c_str(), mean + half) + "]";
}

/// One summary: per cell and key, n, mean, std and the 95 % t interval of each value; CSV and markdown.
std::pair<std::string, std::string> summarize(const StudySpec& s, const std::vector<StudyTask>& tasks,
                                              const StudySummarySpec& spec, const MergedTable& t) {
  auto col = [&](const std::string& name) {
    const auto it = std::find(t.header.begin(), t.header.end(), name);
    if (it == t.header.end()) {
      throw InputError(s.source + ": summary " + spec.file + ": no column '" + name + "' in the jobs' " + spec.file);
    }
    return static_cast<int>(it - t.header.begin());
  };
  std::vector<int> keys, values;
  for (const std::string& k : spec.keys) keys.push_back(col(k));
  for (const std::string& v : spec.values) values.push_back(col(v));
  // Groups in order of first appearance, each with its first row's task (whose cell values it shows).
  std::vector<std::pair<std::pair<int, std::vector<std::string>>, int>> order;
  std::map<std::pair<int, std::vector<std::string>>, std::vector<std::vector<double>>> groups;
  for (const auto& [task, cells] : t.rows) {
    std::pair<int, std::vector<std::string>> g{tasks[task].cell, {}};
    for (int k : keys) g.second.push_back(cells[k]);
    auto [it, fresh] = groups.try_emplace(g, std::vector<std::vector<double>>(values.size()));
    if (fresh) order.emplace_back(g, task);
    for (std::size_t v = 0; v < values.size(); ++v) {
      const std::string& c = cells[values[v]];
      if (c.empty()) continue;  // a value the job left empty on this row
      char* end = nullptr;
      const double x = std::strtod(c.c_str(), &end);
      if (end == c.c_str() || *end != '\0' || !std::isfinite(x)) {
        throw InputError(spec.file + ": task " + std::to_string(task) + ": " + spec.values[v] + ": expected a number, got " +
                         sim::quoteInput(c));
      }
      it->second[v].push_back(x);
    }
  }
  std::ostringstream csv, md;
  csv << "cell";
  for (const auto& [key, vals] : s.grid) csv << "," << key;
  for (const std::string& k : spec.keys) csv << "," << k;
  csv << ",n";
  for (const std::string& v : spec.values) csv << "," << v << "_mean," << v << "_std," << v << "_ci95_low," << v << "_ci95_high";
  csv << "\n";
  md << "### " << spec.file << "\n\nPer cell" << (spec.keys.empty() ? "" : " and " + joinList(spec.keys))
     << ": mean +- standard deviation over the seeds [95 % confidence interval of the mean, Student's t]; n rows.\n\n|";
  for (const auto& [key, vals] : s.grid) md << " " << key << " |";
  for (const std::string& k : spec.keys) md << " " << k << " |";
  md << " n |";
  for (const std::string& v : spec.values) md << " " << v << " |";
  md << "\n|";
  for (std::size_t i = 0; i < s.grid.size() + spec.keys.size() + 1 + spec.values.size(); ++i) md << "---|";
  md << "\n";
  for (const auto& [g, first] : order) {
    const auto& data = groups[g];
    csv << g.first;
    md << "|";
    for (const std::string& v : tasks[first].cell_values) {
      csv << "," << v;
      md << " " << v << " |";
    }
    for (const std::string& k : g.second) {
      csv << "," << k;
      md << " " << k << " |";
    }
    const std::size_t n = data.empty() ? 0 : data[0].size();
    csv << "," << n;
    md << " " << n << " |";
    for (const std::vector<double>& x : data) {
      const auto [mean, sd] = meanAndStd(x);
      const double half = x.size() > 1 ? calib::studentTCritical(0.05, x.size() - 1.0) * sd / std::sqrt(double(x.size())) : 0.0;
      if (x.empty()) {
        csv << ",,,,";
      } else {
        csv << "," << formatNumber("%.9g", mean) << "," << formatNumber("%.9g", sd) << "," << formatNumber("%.9g", mean - half)
            << "," << formatNumber("%.9g", mean + half);
      }
      md << " " << markdownCell(mean, sd, half, x.size()) << " |";
    }
    csv << "\n";
    md << "\n";
  }
  return {csv.str(), md.str()};
}

}  // namespace

namespace {

/// InputError naming the tasks of DIR that are not done.
void requireAllDone(const std::string& dir, const std::vector<StudyTask>& tasks) {
  const std::vector<TaskState> states = studyTaskStates(dir, static_cast<int>(tasks.size()));
  std::map<TaskState, std::vector<int>> not_done;
  for (std::size_t i = 0; i < states.size(); ++i) {
    if (states[i] != TaskState::kDone) not_done[states[i]].push_back(static_cast<int>(i));
  }
  if (!not_done.empty()) {
    std::string what;
    std::size_t total = 0;
    for (const auto& [state, list] : not_done) {
      what += (what.empty() ? "" : "; ") + std::string(taskStateName(state)) + ": " + arrayRanges(list);
      total += list.size();
    }
    throw InputError(dir + ": " + std::to_string(total) + " of " + std::to_string(tasks.size()) + " tasks are not done (" +
                     what + "); run `orbcal study run` or `orbcal study submit` again, then merge");
  }
}

/// A render study: one dataset per (cell, seed), its shards merged into tmp/datasets/ with one manifest;
/// returns the report's table.
std::string mergeDatasets(const StudySpec& s, const std::vector<StudyTask>& tasks, const std::string& dir, const std::string& tmp,
                          MergeReport& report) {
  std::ostringstream md;
  // One dataset per (cell, seed): its shards merged into one folder with one manifest.
  md << "## Datasets\n\n| dataset | cell | seed | shards | samples |\n|---|---|---|---|---|\n";
  for (std::size_t first = 0; first < tasks.size(); first += s.shards) {
    const StudyTask& t = tasks[first];
    std::vector<std::string> shard_dirs;
    for (int k = 0; k < s.shards; ++k) shard_dirs.push_back(taskFolder(dir, t.index + k) + "/out");
    const std::string name = "datasets/cell-" + std::to_string(t.cell) + "-seed-" + std::to_string(t.seed);
    sim::makeDirectories(tmp + "/datasets");
    const int samples = sim::mergeDatasetShards(shard_dirs, tmp + "/" + name).samples;
    report.files.push_back(name);
    md << "| `" << name << "` | " << describeCell(s, t) << " | " << t.seed << " | " << s.shards << " | " << samples << " |\n";
  }
  return md.str();
}

/// Every CSV of the tasks' outputs concatenated in task order with the task's columns first, into tmp.
std::map<std::string, MergedTable> mergeTables(const StudySpec& s, const std::vector<StudyTask>& tasks, const std::string& dir,
                                               const std::string& tmp, MergeReport& report) {
  std::set<std::string> relpaths;
  for (const StudyTask& t : tasks) {
    const fs::path root = taskFolder(dir, t.index) + "/out";
    if (fs::is_directory(root)) collectCsvs(root, root, relpaths);
  }
  std::map<std::string, MergedTable> tables;
  for (const std::string& rel : relpaths) {
    MergedTable& m = tables[rel];
    std::vector<std::string> full_header;
    std::ostringstream csv;
    for (const StudyTask& t : tasks) {
      const std::string path = taskFolder(dir, t.index) + "/out/" + rel;
      if (!exists(path)) continue;
      const sim::CsvTable table = sim::CsvTable::parse(sim::readTextSource(path), path);
      if (full_header.empty() && m.rows.empty()) {
        full_header = table.header();
        for (std::size_t c = 0; c < full_header.size(); ++c) {
          if (isTiming(full_header[c])) continue;
          m.header.push_back(full_header[c]);
          m.source_columns.push_back(static_cast<int>(c));
        }
        csv << prefixHeader(s);
        for (const std::string& h : m.header) csv << "," << h;
        csv << "\n";
      } else if (table.header() != full_header) {
        throw InputError(path + ": header differs from the other tasks' " + rel);
      }
      for (std::size_t r = 0; r < table.rows(); ++r) {
        std::vector<std::string> cells;
        csv << prefixCells(t);
        for (int c : m.source_columns) {
          cells.push_back(table.cell(r, c));
          csv << "," << table.cell(r, c);
        }
        csv << "\n";
        m.rows.emplace_back(t.index, std::move(cells));
      }
    }
    sim::makeDirectories(fs::path(tmp + "/" + rel).parent_path().string());
    sim::writeFileAtomic(tmp + "/" + rel, csv.str());
    report.files.push_back(rel);
  }
  return tables;
}

/// The presets' figures, per cell, drawn from the merged rows of that cell.
std::string figuresSection(const StudySpec& s, const std::vector<StudyTask>& tasks, const std::map<std::string, MergedTable>& tables,
                           std::size_t cells, const std::string& tmp, bool plots, const Callbacks& callbacks) {
  std::ostringstream md;
  const auto figures = builtinFigures(s);
  if (!figures.empty()) md << "## Figures\n\n";
  for (const auto& [file, kind] : figures) {
    const auto it = tables.find(file);
    if (it == tables.end()) continue;
    for (std::size_t c = 0; c < cells; ++c) {
      std::ostringstream csv;
      for (std::size_t i = 0; i < it->second.header.size(); ++i) csv << (i ? "," : "") << it->second.header[i];
      csv << "\n";
      const StudyTask* first = nullptr;
      for (const auto& [task, row] : it->second.rows) {
        if (tasks[task].cell != static_cast<int>(c)) continue;
        first = first ? first : &tasks[task];
        for (std::size_t i = 0; i < row.size(); ++i) csv << (i ? "," : "") << row[i];
        csv << "\n";
      }
      if (!first) continue;
      const std::string stem = fs::path(file).stem().string() + "-cell-" + std::to_string(c);
      sim::makeDirectories(tmp + "/figures");
      sim::writeFileAtomic(tmp + "/figures/" + stem + ".csv", csv.str());
      md << (s.grid.empty() ? std::string("All seeds pooled") : "Cell " + std::to_string(c) + " (" + describeCell(s, *first) + "), all seeds pooled")
         << ":\n\n"
         << drawFigure(callbacks, plots, tmp, kind + " '" + tmp + "/figures/" + stem + ".csv'", "figures/" + stem + ".png", stem)
         << "\n";
    }
  }
  return md.str();
}

}  // namespace

MergeReport mergeStudy(const std::string& dir, const std::string& out_arg, bool plots, const Callbacks& callbacks) {
  const StudySpec s = loadStudyFolder(dir);
  const std::vector<StudyTask> tasks = expandStudy(s);
  requireAllDone(dir, tasks);
  const std::string out = out_arg.empty() ? dir + "/merged" : out_arg;
  sim::StagedFolder staged(out);  // a merge that fails leaves no half-built folder behind
  const std::string& tmp = staged.path();
  MergeReport report;
  std::ostringstream md;
  std::size_t cells = 1;
  for (const auto& [key, values] : s.grid) cells *= values.size();
  md << "# Study " << s.name << ": orbcal " << s.job << (s.preset.empty() ? "" : " --preset " + s.preset) << "\n\n"
     << cells << " cell" << (cells > 1 ? "s" : "") << " x " << s.seeds.size() << " seed" << (s.seeds.size() > 1 ? "s" : "")
     << (s.shards > 1 ? " x " + std::to_string(s.shards) + " shards" : "") << " = " << tasks.size()
     << " tasks, each run as `orbcal study task` (locally or as a Slurm array task); seeds "
     << (s.common_seeds ? "as listed, the same in every cell" : "derived from each listed seed and the cell's values")
     << " (`tasks.csv` has every task's command).\n\n";
  if (!s.options.empty()) {
    md << "Fixed options:";
    for (const auto& [key, values] : s.options) md << " `--" << key << (values.empty() ? "" : " " + joinList(values)) << "`";
    md << "\n\n";
  }
  for (const auto& [key, values] : s.grid) md << "- grid `--" << key << "`: " << joinArgs(values) << "\n";
  if (!s.grid.empty()) md << "\n";

  if (s.job == "render") {
    md << mergeDatasets(s, tasks, dir, tmp, report);
  } else {
    const std::map<std::string, MergedTable> tables = mergeTables(s, tasks, dir, tmp, report);
    md << "## Summaries\n\n";
    for (const StudySummarySpec& spec : s.summaries) {
      const auto it = tables.find(spec.file);
      if (it == tables.end()) throw InputError(s.source + ": summary: no task wrote " + spec.file);
      const auto [csv, table] = summarize(s, tasks, spec, it->second);
      const std::string name = "summary/" + fs::path(spec.file).stem().string() + ".csv";
      sim::makeDirectories(tmp + "/summary");
      sim::writeFileAtomic(tmp + "/" + name, csv);
      report.files.push_back(name);
      md << table << "\nFile: `" << name << "`.\n\n";
    }
    md << figuresSection(s, tasks, tables, cells, tmp, plots, callbacks);
  }
  md << "\nFiles: the jobs' CSVs merged under their own names (columns task, cell, replicate, seed and the grid's first; "
        "wall-time columns left out), `summary/`, `figures/`, `tasks.csv`.\n";
  sim::writeFileAtomic(tmp + "/tasks.csv", sim::readTextSource(dir + "/tasks.csv"));
  writeReport(tmp, md.str());
  staged.commit(/*replace=*/true);
  report.report_path = out + "/report.md";
  return report;
}

}  // namespace orbcal::workflow
