// A rigid body's marker points in a measurement description (pose.points): each point of a row is one
// position sample with its point's index; a point's empty cells mean it was not seen; a row without any
// point, a point with some of its cells, a points entry naming a column the file lacks and a wrong
// length unit are one-line errors naming the file and the key (or line and column); what orbcal writes
// reads back bit for bit, missing points included.
#include <catch2/catch.hpp>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/measured.hpp"
#include "orbcal/sim/simulate.hpp"
#include "test_util.hpp"

using namespace orbcal::sim;
using Catch::Contains;
using orbcal::test::write;

namespace {

const char* kRobot =
    "name: two links\nconvention: standard\njoints:\n"
    "  - {a_m: 0.5, alpha_deg: 0, d_m: 0, theta_offset_deg: 0, min_deg: -90, max_deg: 90}\n"
    "  - {a_m: 0.5, alpha_deg: 0, d_m: 0, theta_offset_deg: 0, min_deg: -90, max_deg: 90}\n";

const std::string kDescription =
    "format: orbcal-measurements-1\n"
    "robot: robot.yaml\n"
    "files: [data.csv]\n"
    "joints: {columns: [j1, j2], unit: deg}\n"
    "pose: {points: [[ax, ay, az], [bx, by, bz], [cx, cy, cz]], length_unit: mm}\n"
    "registration: {base: shared, marker: shared}\n";

const std::string kHeader = "j1,j2,ax,ay,az,bx,by,bz,cx,cy,cz";

/// desc.yaml, robot.yaml and data.csv (the header, then `rows`) in a fresh folder; the description's path.
std::string writeData(const std::string& name, const std::string& description, const std::string& rows,
                      const std::string& header = kHeader) {
  const std::string dir = orbcal::test::tempDir("points-" + name);
  write(dir + "/robot.yaml", kRobot);
  write(dir + "/desc.yaml", description);
  write(dir + "/data.csv", header + "\n" + rows);
  return dir + "/desc.yaml";
}

std::string loadError(const std::string& description) {
  return orbcal::test::inputError([&] { loadMeasuredData(description); });
}

}  // namespace

TEST_CASE("rigid-body points: one sample per seen point, empty cells for a point not seen", "[sim][measured][points]") {
  const MeasuredData d = loadMeasuredData(writeData("read", kDescription, "10,20,1,2,3,4,5,6,7,8,9\n-10,5,,,,40,50,60,,,\n"));
  CHECK(d.points == 3);
  REQUIRE(d.poses.size() == 4);  // 3 points in the first row, 1 in the second
  for (int k = 0; k < 3; ++k) {
    CHECK(d.poses[k].point == k);
    CHECK_FALSE(d.poses[k].has_rotation);
    CHECK(d.poses[k].sample.q_rad == d.poses[0].sample.q_rad);
  }
  CHECK(d.poses[1].world_T_marker.translation() == Eigen::Vector3d(4e-3, 5e-3, 6e-3));  // mm -> m
  CHECK(d.poses[3].point == 1);
  CHECK(d.poses[3].world_T_marker.translation() == Eigen::Vector3d(40e-3, 50e-3, 60e-3));
  CHECK(d.poses[3].sample.q_rad[0] == Approx(-10 * kDegToRad));
}

TEST_CASE("rigid-body points: bad input is one line naming the file and the key or the line", "[sim][measured][points][badinput]") {
  const std::string good_rows = "10,20,1,2,3,4,5,6,7,8,9\n";
  CHECK_THAT(loadError(writeData("no-point", kDescription, good_rows + "0,0,,,,,,,,,\n")),
             Contains("data.csv: line 3") && Contains("no marker point"));
  CHECK_THAT(loadError(writeData("part-point", kDescription, "0,0,1,2,,4,5,6,7,8,9\n")),
             Contains("data.csv: line 2") && Contains("ax, ay, az") && Contains("all or none"));
  // A points entry naming a column the file lacks.
  const std::string missing = orbcal::test::edited(kDescription, "[cx, cy, cz]", "[cx, cy, cw]");
  CHECK_THAT(loadError(writeData("missing-column", missing, good_rows)), Contains("data.csv") && Contains("'cw'"));
  // A wrong length unit.
  const std::string unit = orbcal::test::edited(kDescription, "length_unit: mm", "length_unit: inch");
  CHECK_THAT(loadError(writeData("unit", unit, good_rows)), Contains("desc.yaml") && Contains("pose.length_unit") && Contains("inch"));
  // Three names a point; points with a quaternion; a marker per session.
  const std::string two = orbcal::test::edited(kDescription, "[ax, ay, az]", "[ax, ay]");
  CHECK_THAT(loadError(writeData("two-names", two, good_rows)), Contains("desc.yaml") && Contains("pose.points[0]"));
  const std::string per_session = orbcal::test::edited(kDescription, "marker: shared", "marker: per_session");
  CHECK_THAT(loadError(writeData("per-session", per_session, good_rows)), Contains("desc.yaml") && Contains("registration"));
}

TEST_CASE("rigid-body points written by orbcal read back bit for bit, missing points included", "[sim][measured][points]") {
  SimulationSpec spec;
  spec.samples = 30;
  spec.markers = 4;
  spec.missing_marker_rate = 0.3;
  spec.seed = 8;
  spec.rotation = false;
  const Arm arm = loadArm(orbcal::test::sourcePath("scenes/iiwa7.yaml"));
  const SimulatedData s = simulateMeasured(arm, spec);
  REQUIRE(s.data.points == 4);
  REQUIRE(s.data.poses.size() < 30u * 4u);  // the rate removed some
  REQUIRE(s.data.poses.size() >= 30u);      // every row keeps one
  const std::string dir = orbcal::test::tempDir("points-roundtrip");
  const MeasuredData back = loadMeasuredData(writeMeasuredData(s.data, dir, orbcal::test::sourcePath("scenes/iiwa7.yaml")));
  REQUIRE(back.poses.size() == s.data.poses.size());
  CHECK(back.points == 4);
  for (std::size_t i = 0; i < back.poses.size(); ++i) {
    CAPTURE(i);
    CHECK(back.poses[i].point == s.data.poses[i].point);
    CHECK(back.poses[i].sample.q_rad == s.data.poses[i].sample.q_rad);
    CHECK(back.poses[i].world_T_marker.translation() == s.data.poses[i].world_T_marker.translation());
  }
}
