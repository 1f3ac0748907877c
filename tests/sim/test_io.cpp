// Bad input gets a one-line error naming the file and the key; outputs are never half-written.
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/io.hpp"
#include "test_util.hpp"

using namespace orbcal::sim;

namespace {
using orbcal::test::slurp;

using orbcal::test::inputError;
using orbcal::test::write;

/// The SSRMS file with one line replaced.
std::string ssrmsWith(const std::string& from, const std::string& to) {
  std::string text = slurp(orbcal::test::sourcePath("scenes/ssrms.yaml"));
  const auto at = text.find(from);
  REQUIRE(at != std::string::npos);
  return text.replace(at, from.size(), to);
}
}  // namespace

TEST_CASE("built-in files are the shipped scene files", "[sim][io]") {
  CHECK(readTextSource(kDefaultRobot) == slurp(orbcal::test::sourcePath("scenes/ssrms.yaml")));
  CHECK(readTextSource(kDefaultScene) == slurp(orbcal::test::sourcePath("scenes/default_scene.yaml")));
  CHECK_THROWS_WITH(readTextSource("builtin:nope.yaml"), Catch::StartsWith("builtin:nope.yaml: no such built-in file"));
}

TEST_CASE("malformed robot files name the file and the key", "[sim][io][badinput]") {
  const std::string dir = orbcal::test::tempDir("robot-io");
  const std::string f = dir + "/robot.yaml";

  CHECK(inputError([&] { loadArm(dir + "/missing.yaml"); }) == dir + "/missing.yaml: cannot read: no such file or not readable");

  write(f, "name: x\njoints: [ {a_m: 1\n");
  CHECK_THAT(inputError([&] { loadArm(f); }), Catch::StartsWith(f + ": line ") && Catch::Contains("YAML syntax error"));

  write(f, ssrmsWith("d_m: 0.5692, theta_offset_deg: -90.0,", "theta_offset_deg: -90.0,"));
  CHECK(inputError([&] { loadArm(f); }) == f + ": joints[2].d_m: missing");

  write(f, ssrmsWith("d_m: 0.475,", "d_m: abc,"));
  CHECK(inputError([&] { loadArm(f); }) == f + ": joints[3].d_m: expected a number, got 'abc'");

  write(f, ssrmsWith("d_m: 0.475,", "d_m: .nan,"));
  CHECK(inputError([&] { loadArm(f); }) == f + ": joints[3].d_m: expected a finite number, got '.nan'");

  write(f, ssrmsWith("convention: modified", "convention: craig"));
  CHECK(inputError([&] { loadArm(f); }) == f + ": convention: expected 'modified' (Craig), 'standard', 'hayati' or 'urdf', got 'craig'");

  write(f, ssrmsWith("d_m: 0.475,", "d_m: 0.475, beta_deg: 0.1,"));
  CHECK(inputError([&] { loadArm(f); }) == f + ": joints[3].beta_deg: is accepted only with convention hayati, not modified");

  write(f, ssrmsWith("d_m: 0.475,", "dd_m: 0.475,"));
  CHECK_THAT(inputError([&] { loadArm(f); }), Catch::StartsWith(f + ": joints[3].dd_m: unknown key"));

  write(f, ssrmsWith("d_m: 1.3589, theta_offset_deg: 0.0,   min_deg: -270, max_deg: 270}  # row 7",
                     "d_m: 1.3589, theta_offset_deg: 0.0,   min_deg: 270, max_deg: -270}  # row 7"));
  CHECK(inputError([&] { loadArm(f); }) == f + ": joints[6].max_deg: must be greater than min_deg");

  write(f, "name: empty\nconvention: modified\njoints: []\n");
  CHECK(inputError([&] { loadArm(f); }) == f + ": joints: expected at least one joint");
}

TEST_CASE("a Hayati robot file round-trips through formatArm, beta included", "[sim][io]") {
  const std::string dir = orbcal::test::tempDir("robot-hayati");
  Arm arm = loadArm(orbcal::test::sourcePath("scenes/ssrms_hayati.yaml"));
  REQUIRE(arm.convention == DhConvention::kHayati);
  for (int j = 0; j < arm.numJoints(); ++j) arm.joints[j].beta_rad = 0.01 * (j + 1) / 3.0;
  const std::string text = formatArm(arm, "round trip");
  CHECK(text.find("convention: hayati\n") != std::string::npos);
  CHECK(text.find("beta_deg: ") != std::string::npos);
  write(dir + "/arm.yaml", text);
  const Arm back = loadArm(dir + "/arm.yaml");
  REQUIRE(back.convention == DhConvention::kHayati);
  REQUIRE(back.numJoints() == arm.numJoints());
  for (int j = 0; j < arm.numJoints(); ++j) {
    CHECK(back.joints[j].beta_rad == Approx(arm.joints[j].beta_rad).epsilon(1e-15));
    CHECK(back.joints[j].a_m == arm.joints[j].a_m);
    CHECK(back.joints[j].alpha_rad == Approx(arm.joints[j].alpha_rad).epsilon(1e-15));
  }
  // A standard or modified arm's file has no beta_deg (unchanged format).
  CHECK(formatArm(loadArm(orbcal::test::sourcePath("scenes/ssrms.yaml"))).find("beta") == std::string::npos);
}

TEST_CASE("malformed scene files name the file and the key", "[sim][io][badinput]") {
  const std::string dir = orbcal::test::tempDir("scene-io");
  const std::string f = dir + "/scene.yaml";
  const std::string good = slurp(orbcal::test::sourcePath("scenes/default_scene.yaml"));
  const auto with = [&](const std::string& from, const std::string& to) {
    std::string t = good;
    const auto at = t.find(from);
    REQUIRE(at != std::string::npos);
    write(f, t.replace(at, from.size(), to));
  };
  with("inner_corners_y: 6", "inner_corners_y: 7");
  CHECK_THAT(inputError([&] { loadScene(f); }), Catch::StartsWith(f + ": board: inner_corners_x and inner_corners_y must differ in parity"));
  with("fx_px: 1400.0", "fx_px: -1");
  CHECK_THAT(inputError([&] { loadScene(f); }), Catch::StartsWith(f + ": camera.fx_px: '-1' is outside 1 px to 1e6 px"));
  with("base_T_board: {xyz_m: [6.0, 4.0, 6.0],", "base_T_board: {xyz_m: [6.0, 4.0],");
  CHECK(inputError([&] { loadScene(f); }) == f + ": base_T_board.xyz_m: expected a sequence of 3 numbers");
  with("distance_m: [1.5, 2.5]", "distance_m: [2.5, 1.5]");
  CHECK(inputError([&] { loadScene(f); }) == f + ": views.distance_m: expected [min, max] with 0 < min < max");
  with("locked_joint: 2 ", "locked_joint: -1 ");
  CHECK(inputError([&] { loadScene(f); }) == f + ": views.locked_joint: must be a joint number (1-based) or 0 for none");
  with("camera:", "kamera:");
  CHECK_THAT(inputError([&] { loadScene(f); }), Catch::StartsWith(f + ": kamera: unknown key"));
}

TEST_CASE("configuration files: wrong joint count and NaN are named", "[sim][io][badinput]") {
  CHECK(inputError([] { parseConfigurationsCsv("index,q1_rad,q2_rad\n0,1,2\n", "c.csv", 7); }) ==
        "c.csv: header: missing column 'q3_rad'");
  CHECK(inputError([] { parseConfigurationsCsv("index,q1_rad,q2_rad,q3_rad\n0,1,2,3\n", "c.csv", 2); }) ==
        "c.csv: header: column 'q3_rad' but the robot has 2 joints");
  CHECK(inputError([] { parseConfigurationsCsv("index,q1_rad,q2_rad\n0,1,2\n1,nan,2\n", "c.csv", 2); }) ==
        "c.csv: line 3: q1_rad: expected a finite number, got 'nan'");
  CHECK(inputError([] { parseConfigurationsCsv("index,q1_rad,q2_rad\n0,1\n", "c.csv", 2); }) ==
        "c.csv: line 2: expected 3 columns, got 2");
  const std::vector<Eigen::VectorXd> qs{Eigen::Vector2d(0.1, -1.0 / 3.0), Eigen::Vector2d(1e-17, 3.0)};
  const auto back = parseConfigurationsCsv(formatConfigurationsCsv(qs), "round.csv", 2);
  REQUIRE(back.size() == 2);
  CHECK(back[0] == qs[0]);  // bit for bit
  CHECK(back[1] == qs[1]);
}

TEST_CASE("a failed write (full disk) leaves the previous file intact and no temporary behind", "[sim][io][badinput]") {
  const std::string dir = orbcal::test::tempDir("atomic");
  const std::string f = dir + "/out.txt";
  writeFileAtomic(f, "previous content\n");
  REQUIRE(slurp(f) == "previous content\n");
  // A child process with a 1 kB file-size limit stands in for a full disk: its writes fail with EFBIG.
  const pid_t pid = fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    std::signal(SIGXFSZ, SIG_IGN);
    rlimit lim{1024, 1024};
    setrlimit(RLIMIT_FSIZE, &lim);
    try {
      writeFileAtomic(f, std::string(1 << 20, 'x'));
      _exit(3);  // should have thrown
    } catch (const InputError& e) {
      _exit(std::string(e.what()).rfind(f + ": cannot write: ", 0) == 0 ? 0 : 4);
    }
  }
  int status = 0;
  waitpid(pid, &status, 0);
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 0);
  CHECK(slurp(f) == "previous content\n");
  int files = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++files;
  CHECK(files == 1);
  CHECK_THROWS_WITH(writeFileAtomic(dir + "/no/such/folder/x.txt", "x"), Catch::Contains("no/such/folder/x.txt: cannot write"));
}

TEST_CASE("formatArm writes a robot file that loads back to the same kinematics", "[sim][io]") {
  const std::string dir = orbcal::test::tempDir("format-arm");
  for (const char* file : {"scenes/ssrms.yaml", "scenes/iiwa7.yaml"}) {
    Arm arm = loadArm(orbcal::test::sourcePath(file));
    arm.joints[2].a_m += 1.234e-4;  // an identified error, so the numbers are not the file's
    arm.joints[5].alpha_rad -= 3e-5;
    const std::string path = dir + "/robot.yaml";
    writeFileAtomic(path, formatArm(arm, "calibrated\nby a test"));
    const Arm back = loadArm(path);
    REQUIRE(back.numJoints() == arm.numJoints());
    CHECK(back.convention == arm.convention);
    CHECK(back.lower_rad.isApprox(arm.lower_rad, 1e-14));
    for (const Eigen::VectorXd& q : {Eigen::VectorXd(Eigen::VectorXd::Zero(7)), Eigen::VectorXd(Eigen::VectorXd::LinSpaced(7, -2.0, 2.5))}) {
      CAPTURE(file, q.transpose());
      // Degrees in the file: the angles round-trip to ~1e-16 relative; 1e-12 m on a 20 m arm.
      CHECK((forwardKinematics(back, q).matrix() - forwardKinematics(arm, q).matrix()).norm() < 1e-12);
    }
    CHECK(slurp(path).rfind("# calibrated\n# by a test\n", 0) == 0);
  }
}

TEST_CASE("formatNumber keeps every character of a long number", "[sim][io]") {
  // printf's own output is the reference: a fixed-point 1e100 has 101 digits before the point.
  const double big = 1e100;
  char reference[256];
  std::snprintf(reference, sizeof reference, "%.3f", big);
  const std::string text = formatNumber("%.3f", big);
  CHECK(text.size() == std::string(reference).size());
  CHECK(text.size() > 100);
  CHECK(text == reference);
  CHECK(std::stod(text) == big);
  // Short ones as before; exactly at the former 63-character limit and one past it.
  CHECK(formatNumber("%.4f", 0.12345) == "0.1235");
  CHECK(formatNumber("%.61f", 0.5).size() == 63);
  CHECK(formatNumber("%.62f", 0.5).size() == 64);
  CHECK(formatNumber("%.62f", 0.5).back() == '0');
}
