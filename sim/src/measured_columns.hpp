#pragma once
// The columns of a measurement description (sim/measured.hpp): units, physical ranges, the groups of
// columns each quantity names, and the reading of their cells. Internal to sim/src/measured*.cpp.
#include <Eigen/Core>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "orbcal/sim/arm.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/measured.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::sim::measured_columns {

// ---------------------------------------------------------------------------------------------
// Units: value_SI = value * multiply / divide + offset (divide keeps mm -> m exact as v / 1000).

struct Unit {
  const char* name = "";
  double multiply = 1.0;
  double divide = 1.0;
  double offset = 0.0;
  double toSi(double v) const {
    const double scaled = v * multiply / divide;
    return offset == 0.0 ? scaled : scaled + offset;  // keeps -0.0 as written
  }
  double fromSi(double si) const { return (si - offset) * divide / multiply; }
};

inline const std::vector<Unit> kAngleUnits = {{"rad"}, {"deg", kDegToRad}};
inline const std::vector<Unit> kLengthUnits = {{"m"}, {"mm", 1.0, 1000.0}};
inline const std::vector<Unit> kTorqueUnits = {{"N*m"}, {"Nm"}};
inline const std::vector<Unit> kTemperatureUnits = {{"degC"}, {"K", 1.0, 1.0, -273.15}};
inline const std::vector<Unit> kTimeUnits = {{"s"}, {"ms", 1.0, 1000.0}, {"min", 60.0}, {"h", 3600.0}};

// ---------------------------------------------------------------------------------------------
// Physical ranges: what no real arm and instrument measure, refused at read time (SI).

struct PhysicalRange {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  const char* what = "";  ///< why, for the message; empty: no range (checked otherwise, or none)
};

inline const PhysicalRange kPositionRange{-kMaxLengthM, kMaxLengthM, "a position within 10 km"};
/// Ten times the largest joint torques of industrial arms (a few 1e4 N m at a heavy arm's base).
inline const PhysicalRange kTorqueRange{-1e6, 1e6, "a joint torque within 1e6 N*m"};
inline const PhysicalRange kTemperatureRange{kMinTemperatureC, kMaxTemperatureC, "an arm's temperature"};
inline const PhysicalRange kTimeRange{-1e10, 1e10, "a time within 1e10 s, about 300 years: Unix time stamps fit"};

/// Columns named by the description for one quantity, their unit and their physical range.
struct ColumnGroup {
  std::vector<std::string> names;  ///< empty: not in the files
  Unit unit;
  std::vector<int> index;          ///< of each name in the CSV file being read (bindColumns)
  PhysicalRange range;
  bool given() const { return !names.empty(); }
};

/// The key that named each column so far (column name -> key path): a column holds one quantity.
using ColumnClaims = std::map<std::string, std::string>;

/// The column name at `node`, which no other key may have named.
std::string claimColumn(const ConfigNode& node, ColumnClaims& claims);

/// node[key], which must hold a value: an empty one (`key:` and nothing) is an error, never a default.
ConfigNode valueOf(const ConfigNode& node, const std::string& key);

/// valueOf(node, key) when the key is present.
std::optional<ConfigNode> optionalValueOf(const ConfigNode& node, const std::string& key);

Unit readUnit(const ConfigNode& node, const std::vector<Unit>& known);

/// A sequence of exactly `count` column names; `what` says why that many.
std::vector<std::string> readNames(const ConfigNode& node, std::size_t count, const std::string& what, ColumnClaims& claims);

/// Throws unless `si` (the cell of column `col` on row r, read in `unit`) lies within `range`: the
/// message gives the value and the range in the column's unit.
void checkWithin(const CsvTable& t, std::size_t r, int col, double si, const Unit& unit, const PhysicalRange& range);

/// The cells of `g` on row r, in SI units, each within the group's range.
Eigen::VectorXd readGroup(const CsvTable& t, std::size_t r, const ColumnGroup& g);

/// The index of column `name` in `t`; a missing one is an InputError naming the file, the key of the
/// description (its file: `description`) that asked for the column (joints.columns[6], from `claims`)
/// and the header's columns.
int requireNamedColumn(const CsvTable& t, const std::string& name, const ColumnClaims& claims, const std::string& description);

/// "; read in deg it is within them: ..." where joint j's `value` (in unit `u`), outside its limits,
/// would be within them read in deg (degree columns declared rad), else "".
std::string angleUnitHint(double value, const Unit& u, const Arm& arm, int j, const std::string& description);

}  // namespace orbcal::sim::measured_columns
