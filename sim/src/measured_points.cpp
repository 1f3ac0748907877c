#include "measured_points.hpp"

#include <algorithm>
#include <sstream>
#include <stdexcept>

namespace orbcal::sim::measured_columns {

std::vector<ColumnGroup> readPointColumns(const ConfigNode& points, const Unit& length, ColumnClaims& claims) {
  if (points.size() == 0) points.fail("expected at least one point, [x, y, z] column names each");
  std::vector<ColumnGroup> out;
  for (std::size_t k = 0; k < points.size(); ++k) {
    ColumnGroup g;
    g.names = readNames(points[k], 3, "x, y, z of one marker point", claims);
    g.unit = length;
    g.range = kPositionRange;
    out.push_back(std::move(g));
  }
  return out;
}

void readPointRow(const CsvTable& t, std::size_t r, const std::vector<ColumnGroup>& points, const MeasuredPose& row,
                  std::vector<MeasuredPose>& out) {
  const std::size_t before = out.size();
  for (std::size_t k = 0; k < points.size(); ++k) {
    const ColumnGroup& g = points[k];
    const int empty = static_cast<int>(std::count_if(g.index.begin(), g.index.end(), [&](int c) { return t.cell(r, c).empty(); }));
    if (empty == 3) continue;  // this marker was not seen in this row
    if (empty > 0) {
      throw InputError(t.where(r) + ": " + g.names[0] + ", " + g.names[1] + ", " + g.names[2] + ": marker point " +
                       std::to_string(k + 1) + " has " + std::to_string(3 - empty) + " of its 3 cells (all or none)");
    }
    MeasuredPose p = row;
    p.point = static_cast<int>(k);
    p.has_rotation = false;
    p.world_T_marker = Eigen::Isometry3d::Identity();
    p.world_T_marker.translation() = readGroup(t, r, g);
    out.push_back(std::move(p));
  }
  if (out.size() == before) {
    throw InputError(t.where(r) + ": no marker point (every point's cells are empty); a row must measure at least one");
  }
}

std::vector<ColumnGroup> pointOutputColumns(int count) {
  std::vector<ColumnGroup> out;
  for (int k = 1; k <= count; ++k) {
    ColumnGroup g;
    for (const char* axis : {"x", "y", "z"}) g.names.push_back("p" + std::to_string(k) + "_" + axis + "_m");
    out.push_back(std::move(g));
  }
  return out;
}

namespace {
bool sameRow(const MeasuredPose& a, const MeasuredPose& b) {
  return b.point > a.point && a.sample.session == b.sample.session && a.sample.q_rad == b.sample.q_rad;
}
}  // namespace

std::string formatPointsCsv(const std::vector<const MeasuredPose*>& poses, const std::vector<std::string>& names,
                            const std::vector<ColumnGroup>& points,
                            const std::function<std::vector<double>(const MeasuredPose&)>& cells) {
  std::ostringstream out;
  out << "index";
  for (const std::string& n : names) out << "," << n;
  for (const ColumnGroup& g : points) {
    for (const std::string& n : g.names) out << "," << n;
  }
  out << "\n";
  int row = 0;
  for (std::size_t k = 0; k < poses.size(); ++row) {
    std::vector<const MeasuredPose*> seen(points.size(), nullptr);
    const std::size_t first = k;
    do {
      const int point = poses[k]->point;
      if (point < 0 || point >= static_cast<int>(points.size())) {
        throw std::invalid_argument("writeMeasuredData: " + poses[k]->where + ": marker point " + std::to_string(point + 1) +
                                    " of " + std::to_string(points.size()));
      }
      seen[static_cast<std::size_t>(point)] = poses[k];
      ++k;
    } while (k < poses.size() && sameRow(*poses[k - 1], *poses[k]));
    out << row;
    for (double v : cells(*poses[first])) out << "," << exactNumber(v);
    for (const MeasuredPose* p : seen) {
      for (int a = 0; a < 3; ++a) out << "," << (p ? exactNumber(p->world_T_marker.translation()[a]) : std::string());
    }
    out << "\n";
  }
  return out.str();
}

}  // namespace orbcal::sim::measured_columns
