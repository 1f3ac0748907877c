// Measured data (sim/measured.hpp): users' CSV files as their tools write them are read, every bad
// cell is named by file, line and column in one line, and what orbcal writes reads back bit for bit.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <random>

#include "orbcal/sim/joint_limits.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/measured.hpp"
#include "orbcal/sim/se3.hpp"
#include "test_util.hpp"

using namespace orbcal::sim;
using Catch::Contains;

namespace {

using orbcal::test::write;

// Two joints of +-90 deg.
const char* kRobot =
    "name: two links\nconvention: standard\njoints:\n"
    "  - {a_m: 0.5, alpha_deg: 0, d_m: 0, theta_offset_deg: 0, min_deg: -90, max_deg: 90}\n"
    "  - {a_m: 0.5, alpha_deg: 0, d_m: 0, theta_offset_deg: 0, min_deg: -90, max_deg: 90}\n";

const char* kMatrixDescription =
    "format: orbcal-measurements-1\n"
    "robot: robot.yaml\n"
    "files: [data.csv]\n"
    "joints: {columns: [j1, j2], unit: deg}\n"
    "pose: {matrix: [m00, m01, m02, m03, m10, m11, m12, m13, m20, m21, m22, m23, m30, m31, m32, m33], length_unit: mm}\n"
    "covariates: {torque: {columns: [t1, t2], unit: Nm}}\n"
    "registration: {base: shared, marker: per_session}\n";

const std::string kHeader = "j1,j2,m00,m01,m02,m03,m10,m11,m12,m13,m20,m21,m22,m23,m30,m31,m32,m33,t1,t2";
const std::string kRowA = "10,-20,1,0,0,100,0,1,0,200,0,0,1,300,0,0,0,1,0.5,-0.25";  // line 2
const std::string kRowB = "30,40,0,-1,0,1,1,0,0,2,0,0,1,3,0,0,0,1,1,2";               // line 3: 90 deg about z

/// A folder holding robot.yaml, desc.yaml and data.csv.
struct Files {
  std::string dir, description, csv;
};

Files writeFiles(const std::string& name, const std::string& description, const std::string& csv) {
  Files f;
  f.dir = orbcal::test::tempDir("measured-" + name);  // = folderOf(name), emptied
  f.description = f.dir + "/desc.yaml";
  f.csv = f.dir + "/data.csv";
  write(f.dir + "/robot.yaml", kRobot);
  write(f.description, description);
  write(f.csv, csv);
  return f;
}

/// `text` with `from` replaced by `to` (which must occur).
std::string with(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  REQUIRE(at != std::string::npos);
  return text.replace(at, from.size(), to);
}

/// The one-line InputError message of loading `description`; fails the test when there is none.
std::string loadError(const std::string& description) {
  return orbcal::test::inputError([&] { loadMeasuredData(description); });
}

/// The message of loading the matrix description with data.csv = header, row A, `row_b`.
std::string csvError(const std::string& name, const std::string& row_b, const std::string& header = kHeader) {
  return loadError(writeFiles(name, kMatrixDescription, header + "\n" + kRowA + "\n" + row_b + "\n").description);
}

/// The message of loading a description (`from` replaced by `to` in the matrix one) with good data.
std::string descriptionError(const std::string& name, const std::string& from, const std::string& to) {
  const Files f = writeFiles(name, with(kMatrixDescription, from, to), kHeader + "\n" + kRowA + "\n" + kRowB + "\n");
  return loadError(f.description);
}

/// The folder writeFiles(name, ...) writes into (without emptying it, unlike tempDir).
std::string folderOf(const std::string& name) {
  return orbcal::test::tempPath("measured-" + name);
}

std::string csvPath(const std::string& name) { return folderOf(name) + "/data.csv"; }

}  // namespace

TEST_CASE("CsvTable: a BOM, CRLF, spaces and trailing empty lines are accepted, a duplicate column is not",
          "[sim][measured][csv]") {
  const CsvTable t = CsvTable::parse("\xEF\xBB\xBF" "a, b\r\n1, 2\r\n\r\n3 ,4\r\n\r\n\r\n", "t.csv");
  CHECK(t.column("a") == 0);  // the BOM is not part of the first name
  CHECK(t.column("b") == 1);
  REQUIRE(t.rows() == 2);
  CHECK(t.cell(0, 1) == "2");  // no trailing \r
  CHECK(t.number(1, 0) == 3.0);
  CHECK(t.where(1) == "t.csv: line 4");
  CHECK_THROWS_WITH(CsvTable::parse("a,b,a\n1,2,3\n", "d.csv"), "d.csv: header: duplicate column 'a'");
}

TEST_CASE("measured data: a BOM, CRLF, spaces after commas and trailing empty lines are accepted and units convert",
          "[sim][measured]") {
  std::string csv = "\xEF\xBB\xBF" + kHeader + "\r\n" + kRowA + "\r\n" + kRowB + "\r\n\r\n\r\n";
  for (std::size_t at = csv.find(','); at != std::string::npos; at = csv.find(',', at + 2)) csv.insert(at + 1, " ");
  const Files f = writeFiles("accepted", kMatrixDescription, csv);
  const MeasuredData d = loadMeasuredData(f.description);
  CHECK(d.robot_file == f.dir + "/robot.yaml");
  REQUIRE(d.files == std::vector<std::string>{f.csv});
  REQUIRE(d.poses.size() == 2);
  const MeasuredPose& a = d.poses[0];
  CHECK(a.sample.q_rad[0] == 10.0 * kDegToRad);
  CHECK(a.sample.q_rad[1] == -20.0 * kDegToRad);
  CHECK(a.world_T_marker.translation() == Eigen::Vector3d(100.0 / 1000, 200.0 / 1000, 300.0 / 1000));
  CHECK(a.world_T_marker.linear() == Eigen::Matrix3d::Identity());
  CHECK(a.where == f.csv + ": line 2");
  CHECK(a.has_rotation);
  CHECK(a.sample.tau_Nm == Eigen::Vector2d(0.5, -0.25));
  Eigen::Matrix3d rz90;
  rz90 << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  CHECK(d.poses[1].world_T_marker.linear() == rz90);
  CHECK(d.has_torque);
  CHECK_FALSE(d.has_temperature);
  CHECK_FALSE(d.has_direction);
  CHECK(d.base == FrameSharing::kShared);
  CHECK(d.marker == FrameSharing::kPerSession);
  CHECK_FALSE(d.noise_position_m.has_value());
  // Directions filled from the order: both joints moved up from row A to row B.
  CHECK(d.poses[0].sample.direction == Eigen::Vector2d(0, 0));
  CHECK(d.poses[1].sample.direction == Eigen::Vector2d(1, 1));
}

TEST_CASE("measured data: position-only poses, temperature in K, time in min, sessions in two folders",
          "[sim][measured]") {
  const std::string description =
      "format: orbcal-measurements-1\n"
      "robot: robot.yaml\n"
      "files: [a.csv, sub/b.csv]\n"
      "joints: {columns: [j1, j2], unit: rad}\n"
      "pose: {position: [x, y, z], length_unit: m}\n"
      "covariates:\n"
      "  temperature: {column: T, unit: K}\n"
      "  time: {column: t, unit: min}\n"
      "registration: {base: known, marker: shared}\n"
      "world_T_base: {xyz_m: [1, 2, 3], rpy_deg: [0, 0, 90]}\n"
      "noise: {position_mm: 0.05, rotation_deg: 0.01, joint_deg: 0.005}\n";
  const Files f = writeFiles("position-only", description, "unused");
  std::filesystem::create_directories(f.dir + "/sub");
  write(f.dir + "/a.csv", "x,y,z,j1,j2,T,t\n0.1,0.2,0.3,0.5,-0.5,300,2\n");
  write(f.dir + "/sub/b.csv", "t,T,j1,j2,x,y,z\n0.5,293.15,0,0,1,2,3\n1,293.15,0,0,1,2,3\n");
  const MeasuredData d = loadMeasuredData(f.description);
  REQUIRE(d.numSessions() == 2);
  CHECK(d.files[1] == f.dir + "/sub/b.csv");
  REQUIRE(d.poses.size() == 3);
  CHECK_FALSE(d.poses[0].has_rotation);
  CHECK(d.poses[0].world_T_marker.linear() == Eigen::Matrix3d::Identity());
  CHECK(d.poses[0].world_T_marker.translation() == Eigen::Vector3d(0.1, 0.2, 0.3));
  CHECK(d.poses[0].sample.temperature_C == 300.0 - 273.15);
  CHECK(d.poses[0].sample.time_s == 120.0);
  CHECK(d.poses[2].sample.time_s == 60.0);
  CHECK(d.poses[0].sample.session == 0);
  CHECK(d.poses[1].sample.session == 1);
  CHECK(d.poses[2].sample.session == 1);
  CHECK(d.poses[1].sample.direction == Eigen::Vector2d(0, 0));  // first of its session, not after pose 0
  CHECK_FALSE(d.poses[0].sample.hasTorque());
  CHECK(d.has_temperature);
  CHECK(d.has_time);
  CHECK(d.base == FrameSharing::kKnown);
  CHECK((d.world_T_base.translation() - Eigen::Vector3d(1, 2, 3)).norm() < 1e-15);
  CHECK((d.world_T_base.linear() * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitY()).norm() < 1e-15);
  CHECK(*d.noise_position_m == Approx(5e-5).epsilon(1e-15));
  CHECK(*d.noise_rotation_rad == Approx(0.01 * kDegToRad).epsilon(1e-15));
  CHECK(*d.noise_joint_rad == Approx(0.005 * kDegToRad).epsilon(1e-15));
}

TEST_CASE("measured data: every bad cell is named by file, line and column", "[sim][measured][badinput]") {
  CHECK(csvError("nan", with(kRowB, "30,40", "30,nan")) == csvPath("nan") + ": line 3: j2: expected a finite number, got 'nan'");
  CHECK(csvError("text", with(kRowB, ",1,2", ",abc,2")) ==
        csvPath("text") + ": line 3: t1: expected a finite number, got 'abc'");
  CHECK(csvError("empty-cell", with(kRowB, ",1,2", ",,2")) ==
        csvPath("empty-cell") + ": line 3: t1: expected a finite number, got ''");

  SECTION("binary junk is escaped and cut, never echoed raw") {
    const std::string junk = "\x01\xff\x7f" + std::string(60, 'A');
    const std::string msg = csvError("junk", with(kRowB, ",1,2", ",1," + junk));
    CHECK_THAT(msg, Contains(csvPath("junk") + ": line 3: t2: expected a finite number, got '\\x01\\xFF\\x7FAAA"));
    CHECK_THAT(msg, Contains("AAA...'"));
    CHECK(msg.find('\x01') == std::string::npos);
    CHECK(msg.find('\xff') == std::string::npos);
    CHECK(msg.find(std::string(41, 'A')) == std::string::npos);
  }
  SECTION("a column of the description missing from the file") {
    const std::string header = with(kHeader, ",t2", ",t_2");
    // The key that asked for it, in which file, and what the header has instead.
    CHECK(csvError("missing-column", kRowB, header) ==
          csvPath("missing-column") + ": header: missing column 't2', which covariates.torque.columns[1] of " +
              folderOf("missing-column") + "/desc.yaml names (the header has: j1, j2, m00, m01, m02, m03, m10, m11, m12, "
              "m13, m20, m21, m22, m23, m30, m31, m32, m33, t1, t_2)");
    CHECK_THAT(csvError("missing-joint", kRowB, with(kHeader, "j1,", "joint1,")),
               Contains(": header: missing column 'j1', which joints.columns[0] of "));
  }
  SECTION("degrees declared rad: outside the limits in rad, within them in deg, joints.unit is named") {
    const std::string desc = with(kMatrixDescription, "unit: deg}", "unit: rad}");
    const Files f = writeFiles("deg-as-rad", desc, kHeader + "\n" + kRowA + "\n" + kRowB + "\n");
    CHECK(loadError(f.description) == f.csv + ": line 2: j1: 10 rad (572.958 deg) is outside the joint limits [-90, 90] deg of " +
                                          f.dir + "/robot.yaml by more than 2% of the joint's range (3.6 deg); read in deg it is "
                                          "within them: if the columns hold degrees, write joints.unit: deg in " + f.description);
    // A value beyond the limits in either unit gets no such hint.
    const Files g = writeFiles("far-out", desc, kHeader + "\n" + with(kRowA, "10,-20,", "100,-20,") + "\n");
    CHECK_THAT(loadError(g.description), Contains("100 rad (5729.58 deg) is outside the joint limits") && !Contains("joints.unit"));
  }
  SECTION("a duplicate column name") {
    CHECK(csvError("duplicate", kRowB, with(kHeader, ",t2", ",t1")) ==
          folderOf("duplicate") + "/desc.yaml: files[0]: " + csvPath("duplicate") + ": header: duplicate column 't1'");
  }
  SECTION("a row with the wrong cell count") {
    // A file that is no table at all: named with the description's key too (it may be a wrong path).
    CHECK(csvError("count", kRowB + ",7") ==
          folderOf("count") + "/desc.yaml: files[0]: " + csvPath("count") + ": line 3: expected 20 columns, got 21");
  }
  SECTION("a rotation that is not orthonormal, or a reflection") {
    CHECK_THAT(csvError("orthonormal", with(kRowB, "30,40,0,", "30,40,0.1,")),
               Contains(csvPath("orthonormal") + ": line 3: m00..m22: rotation is not orthonormal"));
    CHECK_THAT(csvError("reflection", with(kRowB, ",0,0,1,3,", ",0,0,-1,3,")),
               Contains(csvPath("reflection") + ": line 3: m00..m22: rotation is a reflection"));
    // 1e-8 off is within the tolerance of 1e-6.
    const Files f = writeFiles("near-orthonormal", kMatrixDescription,
                               kHeader + "\n" + with(kRowA, "10,-20,1,", "10,-20,1.00000001,") + "\n");
    CHECK(loadMeasuredData(f.description).poses.size() == 1);
  }
  SECTION("a bottom row other than [0 0 0 1]") {
    CHECK(csvError("bottom", with(kRowB, ",3,0,0,0,1,", ",3,0,0,0.5,1,")) ==
          csvPath("bottom") + ": line 3: m30..m33: bottom row of the pose matrix is [0 0 0.5 1], expected [0 0 0 1]");
  }
  SECTION("a joint reading outside the robot's limits") {
    const Files f = writeFiles("limits", kMatrixDescription, kHeader + "\n" + with(kRowA, "10,-20", "10,-95") + "\n");
    CHECK(loadError(f.description) ==
          f.csv + ": line 2: j2: -95 deg is outside the joint limits [-90, 90] deg of " + f.dir +
              "/robot.yaml by more than 2% of the joint's range (3.6 deg)");
  }
  SECTION("a joint reading past a limit by less than 2% of the joint's range: accepted, with a warning naming joint and excess") {
    const Files f = writeFiles("near-limits", kMatrixDescription, kHeader + "\n" + with(kRowA, "10,-20", "10,-91.5") + "\n");
    const MeasuredData d = loadMeasuredData(f.description);
    REQUIRE(d.poses.size() == 1);
    CHECK(d.poses[0].sample.q_rad[1] == Approx(-91.5 * kDegToRad));
    std::vector<Eigen::VectorXd> q;
    for (const MeasuredPose& p : d.poses) q.push_back(p.sample.q_rad);
    const std::vector<std::string> warnings = nearLimitWarnings(d.arm, q);
    REQUIRE(warnings.size() == 1);
    CHECK_THAT(warnings[0], Catch::StartsWith("joint 2: 1 reading past its lower limit -90 deg of " + f.dir + "/robot.yaml, by up to 1.5 deg"));
  }
  SECTION("a file without data rows") {
    const Files f = writeFiles("no-rows", kMatrixDescription, kHeader + "\n\n\n");
    CHECK_THAT(loadError(f.description), Catch::StartsWith(f.csv + ": no data rows"));
  }
  SECTION("an approach direction other than -1, 0, 1") {
    // t1, t2 read as directions (a column holds one quantity: not as torques as well).
    const std::string description =
        with(kMatrixDescription, "torque: {columns: [t1, t2], unit: Nm}", "direction: {columns: [t1, t2]}");
    const Files f = writeFiles("direction", description, kHeader + "\n" + with(kRowA, "0.5,-0.25", "1,-0.25") + "\n");
    CHECK(loadError(f.description) == f.csv + ": line 2: t2: expected an approach direction of -1, 0 or 1, got -0.25");
  }
}

TEST_CASE("measured data: quaternions off unit norm are named, those within 1e-6 normalised",
          "[sim][measured][badinput]") {
  const std::string description =
      with(with(kMatrixDescription, "{matrix: [m00, m01, m02, m03, m10, m11, m12, m13, m20, m21, m22, m23, m30, m31, m32, m33]",
                "{position: [x, y, z], quaternion_wxyz: [qw, qx, qy, qz]"),
           "covariates: {torque: {columns: [t1, t2], unit: Nm}}\n", "");
  const std::string header = "j1,j2,x,y,z,qw,qx,qy,qz\n";
  const Files bad = writeFiles("quaternion-bad", description, header + "0,0,1,2,3,1,0,0,0\n0,0,1,2,3,0.6,0.8,0.01,0\n");
  CHECK_THAT(loadError(bad.description), Contains(bad.csv + ": line 3: qw..qz: quaternion norm 1.00005 ") &&
                                             Contains("differs from 1 by more than 1e-6"));
  const double s = 1.0 + 5e-7;
  const Files near = writeFiles("quaternion-near", description,
                                header + "0,0,1,2,3," + exactNumber(0.6 * s) + "," + exactNumber(0.8 * s) + ",0,0\n");
  const MeasuredData d = loadMeasuredData(near.description);
  REQUIRE(d.poses.size() == 1);
  const Eigen::Matrix3d R = d.poses[0].world_T_marker.linear();
  CHECK((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-15);
  CHECK(d.poses[0].world_T_marker.translation() == Eigen::Vector3d(1e-3, 2e-3, 3e-3));
}

TEST_CASE("measured data: a bad description names the file and the key", "[sim][measured][badinput]") {
  const std::string desc = folderOf("desc") + "/desc.yaml";
  const auto error = [&](const std::string& from, const std::string& to) { return descriptionError("desc", from, to); };
  CHECK(error("joints: {columns: [j1, j2]", "joints: {columns: [j1]") ==
        desc + ": joints.columns: expected 2 column names (one per joint of " +
            folderOf("desc") + "/robot.yaml), got 1");
  CHECK_THAT(error("{torque:", "{torq:"), Catch::StartsWith(desc + ": covariates.torq: unknown key"));
  CHECK_THAT(error("registration:", "registraton:"), Catch::StartsWith(desc + ": registraton: unknown key"));
  CHECK(error("unit: deg}", "unit: }") == desc + ": line 4: joints.unit: empty value");
  CHECK(error("covariates: {torque: {columns: [t1, t2], unit: Nm}}", "covariates:") == desc + ": line 6: covariates: empty value");
  CHECK(error("length_unit: mm", "length_unit: cm") == desc + ": pose.length_unit: expected one of: m, mm, got 'cm'");
  CHECK(error("unit: deg", "unit: grad") == desc + ": joints.unit: expected one of: rad, deg, got 'grad'");
  CHECK(error("unit: Nm", "unit: Nmm") == desc + ": covariates.torque.unit: expected one of: N*m, Nm, got 'Nmm'");
  CHECK(error("measurements-1", "measurements-2") ==
        desc + ": format: expected 'orbcal-measurements-1', got 'orbcal-measurements-2'");
  CHECK(error("marker: per_session", "marker: each") ==
        desc + ": registration.marker: expected shared, per_session or known, got 'each'");
  CHECK(error("base: shared", "base: known") == desc + ": world_T_base: missing (registration.base is 'known')");
  CHECK(error("registration:", "flange_T_marker: {xyz_m: [0, 0, 0], rpy_deg: [0, 0, 0]}\nregistration:") ==
        desc + ": flange_T_marker: given, but registration.marker is not 'known'");
  CHECK(error("files: [data.csv]", "files: []") == desc + ": files: expected at least one CSV file");
  CHECK(error("files: [data.csv]", "files: [nothing.csv]") ==
        desc + ": files[0]: " + folderOf("desc") + "/nothing.csv: cannot read: no such file or not readable");
  CHECK_THAT(error("{matrix:", "{position: [x, y, z], matrix:"), Catch::StartsWith(desc + ": pose: expected either 'matrix'"));
  // A quaternion x, y, z, w: the key to write instead, with the columns in orbcal's order.
  CHECK(error("{matrix: [m00, m01, m02, m03, m10, m11, m12, m13, m20, m21, m22, m23, m30, m31, m32, m33]",
              "{position: [m03, m13, m23], quaternion_xyzw: [m00, m01, m02, m10]") ==
        desc + ": pose.quaternion_xyzw: orbcal reads a quaternion's columns in w, x, y, z order: list the same columns in that "
               "order under quaternion_wxyz (here quaternion_wxyz: [m10, m00, m01, m02])");
  CHECK(error("registration: {base: shared, marker: per_session}\n",
              "registration: {base: shared, marker: per_session}\nnoise: {position_mm: 0}\n") ==
        desc + ": noise.position_mm: '0' is outside 1e-06 mm to 100 mm (1 sigma per axis)");
  CHECK_THAT(error("registration: {base: shared, marker: per_session}\n",
                   "registration: {base: shared, marker: per_session}\nnoise: {joint_deg: -0.01}\n"),
             Catch::StartsWith(desc + ": noise.joint_deg:") && Catch::Contains("0 to 10 deg"));
}

TEST_CASE("fillApproachDirections: the sign of each joint's last move within a session", "[sim][measured]") {
  std::vector<MeasuredPose> poses(5);
  const double q[5][2] = {{0.0, 0.0}, {0.1, 0.0}, {0.05, 5e-7}, {1.0, 1.0}, {1.0, 0.5}};
  const int session[5] = {0, 0, 0, 1, 1};
  for (int k = 0; k < 5; ++k) {
    poses[k].sample.q_rad = Eigen::Vector2d(q[k][0], q[k][1]);
    poses[k].sample.session = session[k];
  }
  fillApproachDirections(poses);
  CHECK(poses[0].sample.direction == Eigen::Vector2d(0, 0));   // first of session 0
  CHECK(poses[1].sample.direction == Eigen::Vector2d(1, 0));   // joint 2 did not move
  CHECK(poses[2].sample.direction == Eigen::Vector2d(-1, 0));  // 5e-7 rad is below the 1e-6 threshold; no move yet
  CHECK(poses[3].sample.direction == Eigen::Vector2d(0, 0));   // first of session 1
  CHECK(poses[4].sample.direction == Eigen::Vector2d(0, -1));
  fillApproachDirections(poses, 1e-7);
  CHECK(poses[2].sample.direction == Eigen::Vector2d(-1, 1));
  // A joint that stops keeps the direction of its last move.
  std::vector<MeasuredPose> stop(3);
  const double qs[3] = {0.0, 0.2, 0.2};
  for (int k = 0; k < 3; ++k) stop[k].sample.q_rad = Eigen::VectorXd::Constant(1, qs[k]);
  fillApproachDirections(stop);
  CHECK(stop[2].sample.direction[0] == 1.0);
}

TEST_CASE("writeMeasuredData: loadMeasuredData reads the same samples back bit for bit", "[sim][measured]") {
  const std::string dir = orbcal::test::tempDir("measured-roundtrip");
  write(dir + "/robot.yaml", kRobot);
  MeasuredData d;
  d.arm = loadArm(dir + "/robot.yaml");
  d.files = {"one.csv", "two.csv"};
  d.has_torque = d.has_temperature = d.has_time = d.has_direction = true;
  d.base = FrameSharing::kKnown;
  d.world_T_base = fromXyzRpy(Eigen::Vector3d(0.1, -0.2, 0.3), Eigen::Vector3d(0.4, -0.5, 2.9));
  d.marker = FrameSharing::kPerSession;
  d.noise_position_m = 3.7e-5;
  d.noise_rotation_rad = 1.1e-4;
  d.noise_joint_rad = 2.3e-5;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  for (int k = 0; k < 6; ++k) {
    MeasuredPose p;
    p.sample.q_rad = Eigen::Vector2d(u(rng), u(rng));
    p.sample.tau_Nm = Eigen::Vector2d(u(rng) * 30, u(rng) * 1e-3);
    p.sample.temperature_C = 20 + u(rng);
    p.sample.time_s = 1e4 * k + u(rng);
    p.sample.session = k / 4;
    p.sample.direction = Eigen::Vector2d(k % 3 - 1.0, 1.0);
    p.world_T_marker = fromXyzRpy(Eigen::Vector3d(u(rng), u(rng), u(rng)), Eigen::Vector3d(u(rng), u(rng), 2 * u(rng)));
    d.poses.push_back(p);
  }
  const std::string path = writeMeasuredData(d, dir + "/out", "../robot.yaml");
  CHECK(path == dir + "/out/measurements.yaml");
  const MeasuredData back = loadMeasuredData(path);
  CHECK(back.robot_file == dir + "/robot.yaml");  // written as ../robot.yaml, read back as a clean path
  REQUIRE(back.numSessions() == 2);
  REQUIRE(back.poses.size() == d.poses.size());
  for (std::size_t k = 0; k < d.poses.size(); ++k) {
    const JointSample &a = d.poses[k].sample, &b = back.poses[k].sample;
    CHECK(b.q_rad == a.q_rad);
    CHECK(b.tau_Nm == a.tau_Nm);
    CHECK(b.temperature_C == a.temperature_C);
    CHECK(b.time_s == a.time_s);
    CHECK(b.session == a.session);
    CHECK(b.direction == a.direction);
    CHECK(back.poses[k].world_T_marker.translation() == d.poses[k].world_T_marker.translation());
    // Through a quaternion: the rotation to rounding.
    CHECK((back.poses[k].world_T_marker.linear() - d.poses[k].world_T_marker.linear()).cwiseAbs().maxCoeff() < 1e-15);
    CHECK(back.poses[k].has_rotation);
  }
  CHECK(back.has_torque);
  CHECK(back.has_temperature);
  CHECK(back.has_time);
  CHECK(back.has_direction);
  CHECK(back.base == FrameSharing::kKnown);
  CHECK(back.marker == FrameSharing::kPerSession);
  CHECK((back.world_T_base.matrix() - d.world_T_base.matrix()).cwiseAbs().maxCoeff() < 1e-14);
  CHECK(*back.noise_position_m == Approx(*d.noise_position_m).epsilon(1e-15));
  CHECK(*back.noise_rotation_rad == Approx(*d.noise_rotation_rad).epsilon(1e-15));
  CHECK(*back.noise_joint_rad == Approx(*d.noise_joint_rad).epsilon(1e-15));

  SECTION("position-only data, directions from the order, no covariates") {
    MeasuredData p = back;
    p.has_torque = p.has_temperature = p.has_time = p.has_direction = false;
    p.base = FrameSharing::kShared;
    p.marker = FrameSharing::kKnown;
    p.flange_T_marker = fromXyzRpy(Eigen::Vector3d(0, 0, 0.05), Eigen::Vector3d(0, 0, 0.5));
    p.noise_position_m.reset();
    p.noise_rotation_rad.reset();
    p.noise_joint_rad.reset();
    for (MeasuredPose& m : p.poses) {
      m.has_rotation = false;
      m.world_T_marker.linear().setIdentity();
    }
    fillApproachDirections(p.poses);
    const std::string desc = writeMeasuredData(p, dir + "/positions", "../robot.yaml", "desc.yaml");
    const std::string text = orbcal::test::slurp(desc);
    CHECK_THAT(text, Contains("pose: {position: [x_m, y_m, z_m], length_unit: m}\n"));
    CHECK(text.find("qw") == std::string::npos);
    CHECK(text.find("covariates") == std::string::npos);
    CHECK(text.find("noise") == std::string::npos);
    const MeasuredData again = loadMeasuredData(desc);
    REQUIRE(again.poses.size() == p.poses.size());
    CHECK_FALSE(again.poses[0].has_rotation);
    CHECK_FALSE(again.has_torque);
    CHECK(again.base == FrameSharing::kShared);
    CHECK(again.marker == FrameSharing::kKnown);
    CHECK((again.flange_T_marker.matrix() - p.flange_T_marker.matrix()).cwiseAbs().maxCoeff() < 1e-15);
    for (std::size_t k = 0; k < p.poses.size(); ++k) {
      CHECK(again.poses[k].sample.q_rad == p.poses[k].sample.q_rad);
      CHECK(again.poses[k].sample.direction == p.poses[k].sample.direction);
      CHECK(again.poses[k].world_T_marker.matrix() == p.poses[k].world_T_marker.matrix());
    }
  }
  SECTION("a session without samples is the caller's error") {
    MeasuredData gap = back;
    gap.files.push_back("three.csv");
    CHECK_THROWS_AS(writeMeasuredData(gap, dir + "/gap", "../robot.yaml"), std::invalid_argument);
  }
}

TEST_CASE("the real iiwa7 measurements load through scenes/iiwa7_measurements.yaml", "[sim][measured][real]") {
  const std::string data = orbcal::test::sharedDataPath("iiwa7");
  if (!std::filesystem::exists(data + "/run1_0kg.csv")) {
    ORBCAL_SKIP("" << data << " absent (the real iiwa7 measurements are not part of the repository)");
    return;
  }
  const MeasuredData d = loadMeasuredData(orbcal::test::sourcePath("scenes/iiwa7_measurements.yaml"));
  CHECK(d.arm.numJoints() == 7);
  REQUIRE(d.numSessions() == 2);
  REQUIRE(d.poses.size() == 198 + 198);
  CHECK(d.poses[197].sample.session == 0);
  CHECK(d.poses[198].sample.session == 1);
  CHECK(d.has_torque);
  CHECK(d.poses[0].sample.tau_Nm.size() == 7);
  // tau_2 of the first line of run1_0kg.csv, negated: the description says `sense: load`.
  CHECK(d.poses[0].sample.tau_Nm[1] == -0.159293592453003);
  CHECK(d.marker == FrameSharing::kPerSession);
  CHECK(d.base == FrameSharing::kShared);
  // m_03, m_13, m_23 of the first line of run1_0kg.csv, in mm.
  CHECK(d.poses[0].world_T_marker.translation() ==
        Eigen::Vector3d(2.402905556711266 / 1000, 2.500145721663168 / 1000, 1327.855596387197693 / 1000));
  CHECK(d.poses[0].sample.q_rad[0] == 0.000331543616995);
}
