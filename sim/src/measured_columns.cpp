#include "measured_columns.hpp"

#include <algorithm>

namespace orbcal::sim::measured_columns {

/// The column name at `node`, which no other key may have named.
std::string claimColumn(const ConfigNode& node, ColumnClaims& claims) {
  const std::string name = node.asString();
  const auto [it, fresh] = claims.emplace(name, node.path());
  if (!fresh) node.fail("column " + quoteInput(name) + " is named twice (also at " + it->second + "); a column holds one quantity");
  return name;
}

/// node[key], which must hold a value: an empty one (`key:` and nothing) is an error, never a default.
ConfigNode valueOf(const ConfigNode& node, const std::string& key) {
  const ConfigNode child = node[key];
  if (!child.defined()) child.fail("empty value");
  return child;
}

/// valueOf(node, key) when the key is present.
std::optional<ConfigNode> optionalValueOf(const ConfigNode& node, const std::string& key) {
  if (!node.has(key)) return std::nullopt;
  return valueOf(node, key);
}

Unit readUnit(const ConfigNode& node, const std::vector<Unit>& known) {
  const std::string name = node.asString();
  std::string list;
  for (const Unit& u : known) {
    if (name == u.name) return u;
    list += (list.empty() ? "" : ", ") + std::string(u.name);
  }
  node.fail("expected one of: " + list + ", got " + quoteInput(name));
}

/// A sequence of exactly `count` column names; `what` says why that many.
std::vector<std::string> readNames(const ConfigNode& node, std::size_t count, const std::string& what, ColumnClaims& claims) {
  if (node.size() != count) {
    node.fail("expected " + std::to_string(count) + " column names (" + what + "), got " + std::to_string(node.size()));
  }
  std::vector<std::string> names;
  for (std::size_t i = 0; i < count; ++i) names.push_back(claimColumn(node[i], claims));
  return names;
}

/// Throws unless `si` (the cell of column `col` on row r, read in `unit`) lies within `range`: the
/// message gives the value and the range in the column's unit.
void checkWithin(const CsvTable& t, std::size_t r, int col, double si, const Unit& unit, const PhysicalRange& range) {
  if (si >= range.lo && si <= range.hi) return;
  const auto in = [&unit](double v) { return formatNumber("%.9g", v) + " " + unit.name; };
  const double a = unit.fromSi(range.lo), b = unit.fromSi(range.hi);  // in the file's sense (torques: maybe negated)
  throw InputError(t.where(r) + ": " + t.header()[static_cast<std::size_t>(col)] + ": " + in(unit.fromSi(si)) + " is outside " +
                   in(std::min(a, b)) + " to " + in(std::max(a, b)) + " (" + range.what + ")");
}

/// The cells of `g` on row r, in SI units, each within the group's range.
Eigen::VectorXd readGroup(const CsvTable& t, std::size_t r, const ColumnGroup& g) {
  Eigen::VectorXd v(static_cast<Eigen::Index>(g.index.size()));
  for (std::size_t i = 0; i < g.index.size(); ++i) {
    const double si = g.unit.toSi(t.number(r, g.index[i]));
    checkWithin(t, r, g.index[i], si, g.unit, g.range);
    v[static_cast<Eigen::Index>(i)] = si;
  }
  return v;
}

/// The index of column `name` in `t`; a missing one is an InputError naming the file, the
/// description's key that asked for the column (joints.columns[6]) and the header's columns.
int requireNamedColumn(const CsvTable& t, const std::string& name, const ColumnClaims& claims, const std::string& description) {
  const int c = t.column(name);
  if (c >= 0) return c;
  const auto key = claims.find(name);
  std::string header;
  for (std::size_t i = 0; i < t.header().size() && i < 24; ++i) header += (i ? ", " : "") + printable(t.header()[i], 40);
  if (t.header().size() > 24) header += ", ... (" + std::to_string(t.header().size()) + " in all)";
  throw InputError(t.source() + ": header: missing column " + quoteInput(name) + ", which " +
                   (key != claims.end() ? key->second : std::string("a key")) + " of " + description +
                   " names (the header has: " + header + ")");
}

/// "; read in deg it is within them: ..." where a revolute joint's value outside its limits in rad
/// would be within them in deg (degree columns declared rad), else "".
std::string angleUnitHint(double value, const Unit& u, const Arm& arm, int j, const std::string& description) {
  if (std::string(u.name) != "rad" || arm.isPrismatic(j)) return "";
  const double as_deg = value * kDegToRad;
  if (!(as_deg >= arm.lower_rad[j] && as_deg <= arm.upper_rad[j])) return "";
  return "; read in deg it is within them: if the columns hold degrees, write joints.unit: deg in " + description;
}

}  // namespace orbcal::sim::measured_columns
