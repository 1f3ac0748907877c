#include "orbcal/sim/csv.hpp"

#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <stdexcept>

#include "orbcal/sim/arm.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::sim {

namespace {
std::vector<std::string> splitLine(const std::string& line) {
  std::vector<std::string> out;
  std::string cell;
  std::istringstream ss(line);
  while (std::getline(ss, cell, ',')) {
    const auto b = cell.find_first_not_of(" \t\r");
    const auto e = cell.find_last_not_of(" \t\r");
    out.push_back(b == std::string::npos ? "" : cell.substr(b, e - b + 1));
  }
  if (!line.empty() && line.back() == ',') out.push_back("");
  return out;
}

/// Removes a leading UTF-8 byte order mark (EF BB BF), as spreadsheet programs write it.
std::string withoutBom(const std::string& text) {
  static const std::string kBom = "\xEF\xBB\xBF";
  return text.rfind(kBom, 0) == 0 ? text.substr(kBom.size()) : text;
}

void requireUniqueNames(const std::vector<std::string>& header, const std::string& source) {
  for (std::size_t i = 0; i < header.size(); ++i) {
    for (std::size_t k = 0; k < i; ++k) {
      if (header[k] == header[i]) throw InputError(source + ": header: duplicate column " + quoteInput(header[i]));
    }
  }
}
}  // namespace

CsvTable CsvTable::parse(const std::string& text, const std::string& source) {
  CsvTable t;
  t.source_ = source;
  std::istringstream in(withoutBom(text));
  std::string line;
  if (!std::getline(in, line)) throw InputError(source + ": empty file (expected a header line)");
  t.header_ = splitLine(line);
  requireUniqueNames(t.header_, source);
  int line_no = 1;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::vector<std::string> cells = splitLine(line);
    if (cells.size() != t.header_.size()) {
      throw InputError(source + ": line " + std::to_string(line_no) + ": expected " + std::to_string(t.header_.size()) +
                       " columns, got " + std::to_string(cells.size()));
    }
    t.rows_.push_back(std::move(cells));
    t.line_numbers_.push_back(line_no);
  }
  return t;
}

int CsvTable::column(const std::string& name) const {
  for (std::size_t i = 0; i < header_.size(); ++i) {
    if (header_[i] == name) return static_cast<int>(i);
  }
  return -1;
}

int CsvTable::requireColumn(const std::string& name) const {
  const int c = column(name);
  if (c < 0) throw InputError(source_ + ": header: missing column '" + name + "'");
  return c;
}

std::string CsvTable::where(std::size_t row) const { return source_ + ": line " + std::to_string(line_numbers_[row]); }

double CsvTable::number(std::size_t row, int col) const {
  const std::string& s = rows_[row][col];
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || end != s.c_str() + s.size() || !std::isfinite(v)) {
    throw InputError(where(row) + ": " + header_[col] + ": expected a finite number, got " + quoteInput(s));
  }
  return v;
}

int CsvTable::wholeNumber(std::size_t row, int col) const {
  const double v = number(row, col);
  if (!(v >= 0 && v <= 1e9 && v == std::floor(v))) {
    throw InputError(where(row) + ": " + header_[col] + ": expected a whole number from 0, got " + quoteInput(rows_[row][col]));
  }
  return static_cast<int>(v);
}

std::optional<Eigen::VectorXd> CsvTable::numbers(std::size_t row, const std::vector<int>& cols) const {
  if (cols.empty()) return std::nullopt;
  bool all_empty = true;
  for (int c : cols) all_empty &= rows_[row][c].empty();
  if (all_empty) return std::nullopt;
  Eigen::VectorXd v(static_cast<Eigen::Index>(cols.size()));
  for (std::size_t i = 0; i < cols.size(); ++i) v[static_cast<Eigen::Index>(i)] = number(row, cols[i]);
  return v;
}

std::string exactNumber(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string formatNumber(const char* format, double value) {
  char buf[64];
  const int n = std::snprintf(buf, sizeof buf, format, value);
  if (n < 0) throw std::invalid_argument(std::string("formatNumber: cannot format with '") + format + "'");
  if (static_cast<std::size_t>(n) < sizeof buf) return std::string(buf, static_cast<std::size_t>(n));
  std::string out(static_cast<std::size_t>(n) + 1, '\0');  // longer than the buffer ("%.100f", "%f" of 1e300)
  std::snprintf(out.data(), out.size(), format, value);
  out.resize(static_cast<std::size_t>(n));
  return out;
}

std::string jsonNumber(double v, const std::string& key) {
  if (!std::isfinite(v)) throw std::runtime_error(key + ": " + exactNumber(v) + " is not a finite number (JSON holds none); nothing written");
  return exactNumber(v);
}

std::string jsonString(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(c)));
      out += buf;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

std::string formatConfigurationsCsv(const std::vector<Eigen::VectorXd>& configs, const Arm* arm) {
  std::ostringstream out;
  out << "index";
  const Eigen::Index n = configs.empty() ? 0 : configs.front().size();
  for (Eigen::Index j = 0; j < n; ++j) out << ",q" << j + 1 << "_" << (arm ? jointSiUnit(*arm, static_cast<int>(j)) : "rad");
  out << "\n";
  for (std::size_t k = 0; k < configs.size(); ++k) {
    out << k;
    for (Eigen::Index j = 0; j < n; ++j) out << "," << exactNumber(configs[k][j]);
    out << "\n";
  }
  return out.str();
}

void checkIndexOnce(const CsvTable& t, std::size_t r, int c_index, std::map<int, int>& first_line, const std::string& what) {
  if (c_index < 0) return;
  const auto [it, fresh] = first_line.emplace(t.wholeNumber(r, c_index), t.line(r));
  if (fresh) return;
  throw InputError(t.where(r) + ": index: " + what + " " + std::to_string(it->first) + " given twice (first on line " +
                   std::to_string(it->second) + ")");
}

std::vector<Eigen::VectorXd> parseConfigurationsCsv(const std::string& text, const std::string& source, int n) {
  const CsvTable t = CsvTable::parse(text, source);
  std::vector<int> cols;
  std::vector<bool> metres, degrees;  // a prismatic joint's column: qJ_m; an angle in degrees: qJ_deg
  for (int j = 1; j <= n; ++j) {
    const std::string q = "q" + std::to_string(j);
    metres.push_back(t.column(q + "_m") >= 0);
    degrees.push_back(!metres.back() && t.column(q + "_deg") >= 0);
    cols.push_back(metres.back() ? t.column(q + "_m") : degrees.back() ? t.column(q + "_deg") : t.requireColumn(q + "_rad"));
  }
  for (const char* unit : {"_rad", "_deg", "_m"}) {
    if (t.column("q" + std::to_string(n + 1) + unit) < 0) continue;
    throw InputError(source + ": header: column 'q" + std::to_string(n + 1) + unit + "' but the robot has " + std::to_string(n) + " joints");
  }
  const int c_index = t.column("index");
  std::map<int, int> index_line;  // index -> line of its first row
  std::vector<Eigen::VectorXd> configs;
  for (std::size_t r = 0; r < t.rows(); ++r) {
    checkIndexOnce(t, r, c_index, index_line, "configuration");
    auto q = t.numbers(r, cols);
    if (!q) throw InputError(t.where(r) + ": q1_rad: joint angles are empty");
    for (int j = 0; j < n; ++j) {
      if (degrees[static_cast<std::size_t>(j)]) (*q)[j] *= kDegToRad;
      if (metres[static_cast<std::size_t>(j)]) {
        if (std::abs((*q)[j]) <= kMaxLengthM) continue;
        throw InputError(t.where(r) + ": q" + std::to_string(j + 1) + "_m: " + formatNumber("%.9g", (*q)[j]) +
                         " m is outside 10 km: no robot's joint reaches it");
      }
      if (std::abs((*q)[j]) <= kMaxJointAngleRad) continue;
      const bool deg = degrees[static_cast<std::size_t>(j)];
      throw InputError(t.where(r) + ": q" + std::to_string(j + 1) + (deg ? "_deg: " : "_rad: ") +
                       formatNumber("%.9g", deg ? (*q)[j] / kDegToRad : (*q)[j]) + (deg ? " deg" : " rad") + " is outside " +
                       kMaxJointAngleText + ": no robot's joint reaches it");
    }
    configs.push_back(*q);
  }
  return configs;
}

}  // namespace orbcal::sim
