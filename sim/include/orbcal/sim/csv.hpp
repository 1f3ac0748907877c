#pragma once
// Plain comma-separated tables with a header line, as orbcal writes them (no quoting: cells hold
// numbers and relative paths). Accepted as users' tools write them: a UTF-8 byte order mark, CRLF
// line endings, spaces around cells, empty lines (skipped). Errors name the file, the line and the
// column; a cell echoed in a message has non-printable bytes escaped (\xNN) and is cut at 40 characters.
#include <Eigen/Core>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace orbcal::sim {

class CsvTable {
 public:
  /// Throws InputError on an empty file, a header naming a column twice, or a row whose cell count
  /// differs from the header's.
  static CsvTable parse(const std::string& text, const std::string& source);

  int column(const std::string& name) const;          ///< -1 when absent
  const std::vector<std::string>& header() const { return header_; }
  int requireColumn(const std::string& name) const;   ///< throws "<file>: header: missing column '<name>'"
  std::size_t rows() const { return rows_.size(); }
  const std::string& cell(std::size_t row, int col) const { return rows_[row][col]; }
  /// Finite number; throws "<file>: line L: <column>: expected a finite number, got '<cell>'".
  double number(std::size_t row, int col) const;
  /// A whole number from 0 (an index); throws "<file>: line L: <column>: expected a whole number from 0, got '<cell>'".
  int wholeNumber(std::size_t row, int col) const;
  /// The cells of `cols` as numbers, or nullopt when all of them are empty.
  std::optional<Eigen::VectorXd> numbers(std::size_t row, const std::vector<int>& cols) const;
  std::string where(std::size_t row) const;  ///< "<file>: line L"
  int line(std::size_t row) const { return line_numbers_[row]; }  ///< L, 1-based, the header being line 1
  const std::string& source() const { return source_; }

 private:
  std::string source_;
  std::vector<std::string> header_;
  std::vector<std::vector<std::string>> rows_;
  std::vector<int> line_numbers_;
};

/// Row r's index (column c_index; nothing when c_index < 0, the column being optional) seen for the first
/// time: `first_line` maps each index to the line of its first row. Throws InputError "<file>: line L:
/// index: <what> N given twice (first on line M)" otherwise.
void checkIndexOnce(const CsvTable& t, std::size_t r, int c_index, std::map<int, int>& first_line, const std::string& what);

/// "%.17g": a double that reads back bit for bit.
std::string exactNumber(double v);
/// One number formatted printf-style, e.g. formatNumber("%.3f", x).
std::string formatNumber(const char* format, double value);

/// A JSON number, exactNumber(v): JSON has no NaN or infinity, so a non-finite v throws
/// std::runtime_error "<key>: <v> is not a finite number (JSON holds none); nothing written", `key`
/// naming the file and the field (e.g. "evaluation.json: position_rms_mm"). Every JSON orbcal writes
/// puts its numbers through it.
std::string jsonNumber(double v, const std::string& key);
/// A JSON string: quotes, backslashes and control characters escaped.
std::string jsonString(const std::string& text);

struct Arm;

/// Joint configurations: header "index,q1_rad,...,qN_rad", one row each, SI; with `arm`, a prismatic
/// joint's column is "qJ_m" (its value a length, m).
std::string formatConfigurationsCsv(const std::vector<Eigen::VectorXd>& configs, const Arm* arm = nullptr);
/// Reads them back, joint J from column "qJ_rad" or "qJ_m" (or "qJ_deg", an angle in degrees, converted
/// to radians: configurations written by hand or by another program): every angle finite and within
/// kMaxJointAngleRad (ten turns: no robot file's joint limits reach beyond), every length within
/// kMaxLengthM, the index column (optional) whole numbers from 0, none given twice. Throws InputError
/// naming the file, the line and the column.
std::vector<Eigen::VectorXd> parseConfigurationsCsv(const std::string& text, const std::string& source, int num_joints);

}  // namespace orbcal::sim
