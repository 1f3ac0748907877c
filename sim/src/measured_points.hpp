#pragma once
// A description's rigid body of marker points (`pose: {points: [[x1, y1, z1], ...], length_unit: m}`):
// its columns, the points of one CSV row, and the columns orbcal writes for them. Internal to
// sim/src/measured*.cpp.
#include <functional>

#include "measured_columns.hpp"

namespace orbcal::sim::measured_columns {

/// pose.points: one [x, y, z] triple of column names per marker point (at least one), in `length`.
std::vector<ColumnGroup> readPointColumns(const ConfigNode& points, const Unit& length, ColumnClaims& claims);

/// Row r's points: a copy of `row` (the sample) per point whose three cells are given, with `point` and
/// the position set (rotation unused). A point with some of its cells empty, or a row without any
/// point, is an InputError naming the file, the line (and the column).
void readPointRow(const CsvTable& t, std::size_t r, const std::vector<ColumnGroup>& points, const MeasuredPose& row,
                  std::vector<MeasuredPose>& out);

/// The columns orbcal writes for `count` points: p1_x_m, p1_y_m, p1_z_m, p2_x_m, ...
std::vector<ColumnGroup> pointOutputColumns(int count);

/// A session's CSV of rigid-body samples: consecutive poses of one configuration with rising point
/// indices share a row (as readPointRow made them); `cells(pose)` gives the row's other cells, after
/// the index, under the header `names`; a point not measured in a row leaves its cells empty.
std::string formatPointsCsv(const std::vector<const MeasuredPose*>& poses, const std::vector<std::string>& names,
                            const std::vector<ColumnGroup>& points,
                            const std::function<std::vector<double>(const MeasuredPose&)>& cells);

}  // namespace orbcal::sim::measured_columns
