// What the input fuzz (tools/fuzz-inputs.py) found accepted and is now refused: each case is the
// input, the one-line message naming the file (or option) and the key, the exit status, and that no
// result that looks valid is left behind. Inputs are made by orbcal itself with fixed seeds.
#include <algorithm>
#include <catch2/catch.hpp>
#include <filesystem>

#include "orbcal/sim/camera_io.hpp"
#include "run_orbcal.hpp"
#include "test_util.hpp"

using namespace orbcal;
using Catch::Matchers::Contains;
using Catch::Matchers::StartsWith;
using test::runOrbcal;
using test::slurp;
using test::write;
namespace fs = std::filesystem;

namespace {

using test::edited;

/// Refused by orbcal's own check: exit 1, stderr exactly "orbcal: <line>".
void checkRefused(const test::OrbcalRun& r, const std::string& line) {
  INFO(r.err);
  CHECK(r.status == 1);
  CHECK(r.err == "orbcal: " + line + "\n");
}

/// Refused by the command-line check: exit 2, the option's line and CLI11's pointer to --help.
void checkOptionRefused(const test::OrbcalRun& r, const std::string& line) {
  INFO(r.err);
  CHECK(r.status == 2);
  CHECK(r.err == line + "\nRun with --help for more information.\n");
}

/// Tracker-style data of the built-in iiwa7 in DIR/data (20 samples, seed 3): the description's path
/// relative to DIR.
std::string simulated(const std::string& dir) {
  const test::OrbcalRun r = runOrbcal(dir, "simulate -o data -n 20 --seed 3 --quiet");
  REQUIRE(r.status == 0);
  return "data/measurements.yaml";
}

}  // namespace

TEST_CASE("fuzz findings: NaN and infinity pass no option's range check, and a negative seed is refused", "[e2e][fuzzfix]") {
  const std::string dir = test::tempDir("fuzzfix-options");
  const std::string desc = simulated(dir);
  // CLI11's Range compares, and every comparison with NaN is false: these passed before.
  checkOptionRefused(runOrbcal(dir, "calibrate " + desc + " -o cal --noise-position-mm nan --quiet"),
                     "--noise-position-mm: 'nan' is not a finite number");
  checkOptionRefused(runOrbcal(dir, "diagnose " + desc + " -o diag --penalty nan --quiet --no-plots"),
                     "--penalty: 'nan' is not a finite number");
  checkOptionRefused(runOrbcal(dir, "simulate -o sim -n 20 --payload-kg 0 inf --quiet"), "--payload-kg: 'inf' is not a finite number");
  // An unsigned seed of -1 would be 2^64 - 1: the same draws as --seed 18446744073709551615.
  checkOptionRefused(runOrbcal(dir, "simulate -o neg -n 20 --seed -1 --quiet"), "--seed: '-1': a seed is a whole number from 0");
  for (const char* out : {"cal", "diag", "sim", "neg"}) CHECK_FALSE(fs::exists(dir + "/" + out));
  // The bounds themselves still pass: seed 0 and a stated noise.
  CHECK(runOrbcal(dir, "simulate -o zero -n 20 --seed 0 --quiet").status == 0);
}

TEST_CASE("fuzz findings: a configurations CSV with angles beyond ten turns, junk or a bad index is refused at its cell", "[e2e][fuzzfix]") {
  const std::string dir = test::tempDir("fuzzfix-configs");
  REQUIRE(runOrbcal(dir, "configs -n 4 --seed 2 -o good.csv").status == 0);
  const std::string good = slurp(dir + "/good.csv");
  REQUIRE(runOrbcal(dir, "identifiability --configs good.csv").status == 0);  // as written, it is read
  const auto refused = [&](const std::string& text, const std::string& line) {
    write(dir + "/c.csv", text);
    const test::OrbcalRun r = runOrbcal(dir, "identifiability --configs c.csv");
    checkRefused(r, line);
    CHECK(r.out.empty());  // no table printed from the bad file
  };
  // Row 2 (line 3) of the file, its cells replaced one by one.
  const std::size_t line3 = good.find('\n', good.find('\n') + 1) + 1;
  const std::string row = good.substr(line3, good.find('\n', line3) - line3);
  const auto withRow = [&](const std::string& r) { return edited(good, row, r); };
  const std::string head = row.substr(0, row.rfind(',') + 1);
  refused(withRow(head + "1e6"), "c.csv: line 3: q7_rad: 1000000 rad is outside -62.83 rad to 62.83 rad (ten turns): no robot's joint reaches it");
  refused(withRow(head + "-1e308"),
          "c.csv: line 3: q7_rad: -1e+308 rad is outside -62.83 rad to 62.83 rad (ten turns): no robot's joint reaches it");
  refused(withRow(head + "0.5\xc3("), "c.csv: line 3: q7_rad: expected a finite number, got '0.5\\xC3('");
  refused(withRow("1.2.3" + row.substr(1)), "c.csv: line 3: index: expected a finite number, got '1.2.3'");
  refused(withRow("2.5" + row.substr(1)), "c.csv: line 3: index: expected a whole number from 0, got '2.5'");
  refused(withRow("nan" + row.substr(1)), "c.csv: line 3: index: expected a finite number, got 'nan'");
  refused(withRow("0" + row.substr(1)), "c.csv: line 3: index: configuration 0 given twice (first on line 2)");
}

TEST_CASE("fuzz findings: every URDF origin, axis and inertial is checked, on the arm's chain or not", "[e2e][fuzzfix][urdf]") {
  const std::string dir = test::tempDir("fuzzfix-urdf");
  const std::string good = slurp(test::sourcePath("tests/data/iiwa7_inertial.urdf"));
  // A side branch off the chain (a bracket on link 3), chosen away by --tip-link.
  const std::string side = "  <link name=\"bracket\"><inertial><origin xyz=\"0.05 0 0\"/><mass value=\"0.2\"/>"
                           "<inertia ixx=\"0.001\" ixy=\"0\" ixz=\"0\" iyy=\"0.001\" iyz=\"0\" izz=\"0.001\"/></inertial>"
                           "<visual><origin xyz=\"0 0 0\"/><geometry><box size=\"0.1 0.1 0.1\"/></geometry></visual></link>\n"
                           "  <joint name=\"bracket_joint\" type=\"fixed\"><parent link=\"iiwa_link_3\"/><child link=\"bracket\"/>"
                           "<origin xyz=\"0.1 0 0\"/></joint>\n</robot>";
  const std::string branched = edited(good, "</robot>", side);
  const auto run = [&](const std::string& text, const std::string& out) {
    write(dir + "/arm.urdf", text);
    return runOrbcal(dir, "simulate --robot arm.urdf --tip-link iiwa_link_ee -o " + out + " -n 10 --quiet");
  };
  REQUIRE(run(branched, "ok").status == 0);  // the branch as given is a valid arm
  checkRefused(run(edited(branched, "<origin xyz=\"0.1 0 0\"/></joint>", "<origin xyz=\"1e9 0 0\"/></joint>"), "a"),
               "arm.urdf: joint 'bracket_joint': <origin xyz>: 1e+09 m is outside -10000 m to 10000 m");
  checkRefused(run(edited(branched, "<origin xyz=\"0.05 0 0\"/>", "<origin xyz=\"0.05 -1e308 0\"/>"), "b"),
               "arm.urdf: link 'bracket': <inertial>: <origin xyz>: -1e+308 m is outside -10000 m to 10000 m");
  checkRefused(run(edited(branched, "<visual><origin xyz=\"0 0 0\"/>", "<visual><origin xyz=\"0 0 1e9\"/>"), "c"),
               "arm.urdf: link 'bracket': <visual>: <origin xyz>: 1e+09 m is outside -10000 m to 10000 m");
  // An axis of "0 0 1e9" or "0 0 -1e308" was normalized into +z or, overflowing, a zero axis.
  checkRefused(run(edited(good, "<axis xyz=\"0 0 1\"/>", "<axis xyz=\"0 0 -1e308\"/>"), "d"),
               "arm.urdf: joint 'iiwa_joint_1': <axis xyz>: '0 0 -1e+308' is not a unit vector (length 1 within 1e-3)");
  checkRefused(run(edited(good, "<axis xyz=\"0 0 1\"/>", "<axis xyz=\"1e9 0 1\"/>"), "e"),
               "arm.urdf: joint 'iiwa_joint_1': <axis xyz>: '1e+09 0 1' is not a unit vector (length 1 within 1e-3)");
  // An empty attribute is not read as zero.
  const test::OrbcalRun empty = run(edited(good, "<origin xyz=\"0 0 0.34\"", "<origin xyz=\"\""), "f");
  CHECK(empty.status == 1);
  CHECK_THAT(empty.err, StartsWith("orbcal: arm.urdf: not a valid URDF: ") && Contains("joint [iiwa_joint_2]"));
  CHECK(std::count(empty.err.begin(), empty.err.end(), '\n') == 1);
  for (const char* out : {"a", "b", "c", "d", "e", "f"}) CHECK_FALSE(fs::exists(dir + "/" + out));
}

TEST_CASE("fuzz findings: a camera file's rectification and projection matrices are finite and physically bounded", "[e2e][fuzzfix]") {
  const std::string dir = test::tempDir("fuzzfix-camera");
  const std::string good =
      "image_width: 640\nimage_height: 512\ncamera_name: quick\n"
      "camera_matrix: {rows: 3, cols: 3, data: [700.0, 0, 321.4, 0, 700.0, 254.2, 0, 0, 1]}\n"
      "distortion_model: plumb_bob\ndistortion_coefficients: {rows: 1, cols: 5, data: [0.01, -0.02, 0, 0, 0]}\n"
      "rectification_matrix: {rows: 3, cols: 3, data: [1, 0, 0, 0, 1, 0, 0, 0, 1]}\n"
      "projection_matrix: {rows: 3, cols: 4, data: [700.0, 0, 321.4, 0, 0, 700.0, 254.2, 0, 0, 0, 1, 0]}\n";
  REQUIRE_NOTHROW(sim::parseCameraFile(good, "cam.yaml"));
  const auto message = [&](const std::string& from, const std::string& to) {
    return test::inputError([&] { sim::parseCameraFile(edited(good, from, to), "cam.yaml"); });
  };
  CHECK(message("data: [700.0, 0, 321.4, 0, 0,", "data: [1e9, 0, 321.4, 0, 0,") ==
        "cam.yaml: projection_matrix.data[0]: '1e9' is outside 1 px to 1e6 px (a focal length in pixels)");
  CHECK(message("254.2, 0, 0, 0, 1, 0]", "254.2, 0, 0, 0, 1, -1e308]") ==
        "cam.yaml: projection_matrix.data[11]: '-1e308' is outside -1e6 px to 1e6 px");
  CHECK(message("321.4, 0, 0, 700.0, 254.2, 0,", "321.4, 1e9, 0, 700.0, 254.2, 0,") ==
        "cam.yaml: projection_matrix.data[3]: '1e9' is outside -7e+06 to 7e+06 (f' times a baseline within 10 km)");
  CHECK(message("data: [1, 0, 0, 0, 1,", "data: [1, 0, -1e308, 0, 1,") ==
        "cam.yaml: rectification_matrix.data[2]: '-1e308' is outside -1 to 1 (an entry of a rotation)");
  CHECK(message("data: [1, 0, 0, 0, 1,", "data: [.nan, 0, 0, 0, 1,") ==
        "cam.yaml: rectification_matrix.data[0]: expected a finite number, got '.nan'");
  // Through render: named with the scene key that named the file, refused before anything is written.
  write(dir + "/cam.yaml", edited(good, "data: [700.0, 0, 321.4, 0, 0,", "data: [1e9, 0, 321.4, 0, 0,"));
  const std::string scene = slurp(test::sourcePath("scenes/quick_scene.yaml"));
  const std::size_t cam = scene.find("camera:\n");
  REQUIRE(cam != std::string::npos);
  std::size_t end = scene.find('\n', cam) + 1;
  while (end < scene.size() && scene.compare(end, 2, "  ") == 0) end = scene.find('\n', end) + 1;
  write(dir + "/scene.yaml", scene.substr(0, cam) + "camera: {file: cam.yaml}\n" + scene.substr(end));
  checkRefused(runOrbcal(dir, "render -o out --count 2 --seed 1 --scene scene.yaml"),
               "scene.yaml: camera.file: cam.yaml: projection_matrix.data[0]: '1e9' is outside 1 px to 1e6 px (a focal length in pixels)");
  CHECK_FALSE(fs::exists(dir + "/out"));
}

TEST_CASE("fuzz findings: fk refuses joint angles no arm reaches", "[e2e][fuzzfix]") {
  const std::string dir = test::tempDir("fuzzfix-fk");
  const test::OrbcalRun ok = runOrbcal(dir, "fk --robot builtin:iiwa7.yaml 0 10 0 -90 0 45 200");
  CHECK(ok.status == 0);  // beyond joint 7's 175 deg: said, not refused
  CHECK_THAT(ok.out, Contains("within joint limits: no"));
  for (const char* angle : {"1e6", "1e308"}) {
    const test::OrbcalRun r = runOrbcal(dir, std::string("fk --robot builtin:iiwa7.yaml 0 0 0 0 0 0 ") + angle);
    INFO(r.err);
    CHECK(r.status == 1);
    CHECK_THAT(r.err, StartsWith("orbcal: forwardKinematics: joint 7 of builtin:iiwa7.yaml: ") &&
                          Contains(" deg) is more than ten turns outside its limits [-175, 175] deg: no pose of the arm"));
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    CHECK(r.out.empty());  // no pose printed
  }
}

TEST_CASE("fuzz findings: a model's sigma of .nan and a study's throttle of 0 are refused", "[e2e][fuzzfix]") {
  const std::string dir = test::tempDir("fuzzfix-model-study");
  const std::string desc = simulated(dir);
  const std::string model = dir + "/data/truth/model.yaml";
  const std::string text = slurp(model);
  const std::size_t row = text.find("  - {name: ", text.find("\nparameters:"));
  REQUIRE(row != std::string::npos);
  write(model, text.substr(0, row) + edited(text.substr(row), "sigma: 0,", "sigma: .nan,"));
  checkRefused(runOrbcal(dir, "evaluate --model data/truth/model.yaml --data " + desc + " -o eval"),
               "data/truth/model.yaml: parameters[0].sigma: expected a finite number, got '.nan'");
  CHECK_FALSE(fs::exists(dir + "/eval"));

  const std::string study = "format: orbcal-study-1\nname: t\njob: render\noptions: {count: 2, scene: \"" +
                            test::sourcePath("scenes/quick_scene.yaml") +
                            "\"}\nseeds: {first: 1, count: 1}\nslurm: {throttle: 0, time: \"00:10:00\", mem: 1G}\n";
  write(dir + "/s.yaml", study);
  checkRefused(runOrbcal(dir, "study run s.yaml -o st -j 1"), "s.yaml: slurm.throttle: expected 1 or more (leave it out for no limit)");
  CHECK_FALSE(fs::exists(dir + "/st"));
}
