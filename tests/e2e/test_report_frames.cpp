// The registration frames in the reports of measured data (calibrate, evaluate, diagnose) are frames:
// position in mm and roll, pitch, yaw in deg, per session as frames.yaml numbers them, equal to the
// frames the run writes; the parameter table no longer lists their raw increments.
#include <catch2/catch.hpp>
#include <cmath>
#include <map>
#include <regex>
#include <sstream>

#include <Eigen/Geometry>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/model_io.hpp"
#include "orbcal/sim/simulate.hpp"
#include "orbcal/workflow/diagnose.hpp"
#include "orbcal/workflow/measured.hpp"
#include "test_util.hpp"

using namespace orbcal;
using Catch::Matchers::Contains;

namespace {

constexpr double kPositionTolMm = 6e-4;   // printed with 3 decimals (0.0005 mm) plus round-off
constexpr double kRotationTol = 3e-6;     // rpy printed with 4 decimals in deg: 0.00005 deg = 8.7e-7 rad each

struct FrameRow {
  Eigen::Vector3d position_mm, rpy_deg;
  std::string rest;  ///< the 1-sigma and held cells
};

Eigen::Vector3d triple(const std::string& cell) {
  Eigen::Vector3d v;
  char comma = 0;
  std::istringstream in(cell);
  in >> v.x() >> comma >> v.y() >> comma >> v.z();
  REQUIRE_FALSE(in.fail());
  return v;
}

/// The rows of a report's "Registration frames" table by "frame|session".
std::map<std::string, FrameRow> frameRows(const std::string& report) {
  const std::size_t at = report.find("Registration frames");
  REQUIRE(at != std::string::npos);
  std::map<std::string, FrameRow> rows;
  const std::regex row(R"(\| (world_T_base|flange_T_marker) \| ([^|]+) \| ([^|]+) \| ([^|]+) \| (.*) \|)");
  std::istringstream lines(report.substr(at));
  for (std::string line; std::getline(lines, line);) {
    std::smatch m;
    if (std::regex_match(line, m, row)) rows[m[1].str() + "|" + m[2].str()] = {triple(m[3]), triple(m[4]), m[5]};
  }
  return rows;
}

/// R = Rz(yaw) Ry(pitch) Rx(roll), as a URDF's rpy (written here, not orbcal's).
Eigen::Matrix3d fromRpyDeg(const Eigen::Vector3d& rpy_deg) {
  const Eigen::Vector3d r = rpy_deg * sim::kDegToRad;
  return (Eigen::AngleAxisd(r.z(), Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(r.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(r.x(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

/// The row shows frame T: its position and rotation to the printed digits.
void checkRow(const FrameRow& row, const Eigen::Isometry3d& T) {
  CHECK((row.position_mm - T.translation() * 1e3).cwiseAbs().maxCoeff() < kPositionTolMm);
  CHECK((fromRpyDeg(row.rpy_deg) - T.linear()).cwiseAbs().maxCoeff() < kRotationTol);
}

}  // namespace

TEST_CASE("reports show the registration frames as frames: calibrate, evaluate and diagnose", "[e2e][report]") {
  const std::string dir = test::tempDir("report-frames");
  sim::SimulationSpec spec;
  spec.samples = 120;
  spec.sessions = 2;
  spec.seed = 21;
  const sim::SimulatedData d = workflow::runSimulate(sim::loadArm(test::sourcePath("scenes/iiwa7.yaml")), spec, dir + "/data");
  REQUIRE(d.data.marker == sim::FrameSharing::kPerSession);

  // calibrate: one shared base, a marker per session, each row the frame model.yaml (and frames.yaml) holds.
  workflow::MeasuredCalibrateOptions o;
  o.description = d.data.description;
  o.out = dir + "/cal";
  o.plots = false;
  const workflow::MeasuredCalibrateResult c = workflow::runMeasuredCalibrate(o);
  REQUIRE_FALSE(c.model_path.empty());
  const std::string report = test::slurp(c.report_path);
  const sim::LoadedModel written = sim::loadModelFile(c.model_path);
  std::map<std::string, FrameRow> rows = frameRows(report);
  REQUIRE(rows.size() == 3);
  checkRow(rows.at("world_T_base|all (shared)"), written.model.world_T_base.front());
  checkRow(rows.at("flange_T_marker|1"), written.model.flange_T_marker.at(0));
  checkRow(rows.at("flange_T_marker|2"), written.model.flange_T_marker.at(1));
  // The frames are fitted: a 1-sigma in mm, below the tracker's 0.05 mm noise (60 samples a session), and
  // nothing held with position + rotation data.
  const std::string& rest = rows.at("flange_T_marker|2").rest;
  const Eigen::Vector3d sigma_mm = triple(rest.substr(0, rest.find(" | ")));
  CHECK(sigma_mm.minCoeff() > 0.0);
  CHECK(sigma_mm.maxCoeff() < 0.05);
  CHECK(rest.find("held") == std::string::npos);
  // The tracker sits metres from the base: a table of identities would fail.
  CHECK(rows.at("world_T_base|all (shared)").position_mm.norm() > 100.0);
  // The parameter table leaves the increments out; estimates.csv keeps them.
  CHECK_THAT(report, !Contains("| base_x |") && !Contains("| marker1_x |") && !Contains("| marker2_rz |"));
  CHECK_THAT(report, Contains("| theta2 |"));
  CHECK_THAT(test::slurp(dir + "/cal/estimates.csv"), Contains("marker2_rz,marker,"));

  // evaluate with the truth: the base is the model's; the marker of each session is refitted to this data
  // and lands on the simulated truth's (0.05 mm / 0.01 deg tracker noise, 60 samples a session).
  const sim::LoadedModel truth = sim::loadModelFile(dir + "/data/truth/model.yaml");
  const workflow::EvaluateResult e = workflow::runEvaluate(dir + "/data/truth/model.yaml", d.data.description, dir + "/eval");
  rows = frameRows(test::slurp(e.report_path));
  REQUIRE(rows.size() == 3);
  checkRow(rows.at("world_T_base|all (the model's)"), truth.model.world_T_base.front());
  for (int s = 0; s < 2; ++s) {
    const FrameRow& m = rows.at("flange_T_marker|" + std::to_string(s + 1));
    const Eigen::Isometry3d& true_marker = truth.model.flange_T_marker.at(static_cast<std::size_t>(s));
    CHECK((m.position_mm - true_marker.translation() * 1e3).norm() < 0.05);
    const Eigen::AngleAxisd apart(fromRpyDeg(m.rpy_deg).transpose() * true_marker.linear());
    CHECK(apart.angle() * sim::kRadToDeg < 0.01);
  }
  // The two sessions' markers differ (re-mounted): a row repeated for both would fail above or here.
  CHECK((rows.at("flange_T_marker|1").position_mm - rows.at("flange_T_marker|2").position_mm).norm() > 1.0);

  // diagnose: the selected model's frames, as its model.yaml writes them.
  workflow::DiagnoseRunOptions g;
  g.input = d.data.description;
  g.out = dir + "/diag";
  g.plots = false;
  g.quiet = true;
  const workflow::DiagnoseRunResult dg = workflow::runDiagnose(g);
  const sim::LoadedModel selected = sim::loadModelFile(dg.model_path);
  rows = frameRows(test::slurp(dg.report_path));
  REQUIRE(rows.size() == 3);
  checkRow(rows.at("world_T_base|all (shared)"), selected.model.world_T_base.front());
  checkRow(rows.at("flange_T_marker|2"), selected.model.flange_T_marker.at(1));
}
