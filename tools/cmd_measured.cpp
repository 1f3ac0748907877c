// `orbcal evaluate` (predict measured data with a calibrated model) and `orbcal simulate` (tracker-style
// measured data with hidden effects, and its truth).
#include <cstdio>

#include "cli.hpp"
#include "orbcal/workflow/measured.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/effect_syntax.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::tools {

namespace {

void addEvaluateCommand(CLI::App& app) {
  struct Opts {
    std::string model, data, out;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand(
      "evaluate",
      "Predict measured data with a calibrated model (model.yaml of orbcal calibrate, or a simulation's truth): every "
      "geometric and effect parameter is the model's, only the per-session frames of the new data are refitted. "
      "Writes evaluation.json (position mean/RMS/max in mm, rotation RMS in deg where rotations are measured, and the same "
      "for the baseline: the nominal arm with its frames fitted to the data), residuals.csv (per sample), evaluation.md and "
      "report.html (the list: docs/reports.md).");
  cmd->add_option("--model", o->model, "model file (model.yaml)")->required();
  cmd->add_option("--data", o->data, "measurement description (.yaml) of the data to predict")->required();
  cmd->add_option("-o,--out", o->out, "output folder")->required();
  cmd->callback([o] {
    const workflow::EvaluateResult r = workflow::runEvaluate(o->model, o->data, o->out);
    const calib::ResidualStats& s = r.fit.residuals;
    std::printf("%d samples, %d parameters refitted: position mean %.4f mm, RMS %.4f mm, max %.4f mm", s.samples, r.refitted,
                s.position_mean_m * 1e3, s.position_rms_m * 1e3, s.position_max_m * 1e3);
    if (s.rotation_samples > 0) std::printf("; rotation RMS %.4f deg", s.rotation_rms_rad * sim::kRadToDeg);
    std::printf("\nbaseline (nominal arm, frames fitted): position RMS %.4f mm\n", r.baseline.position_rms_m * 1e3);
    for (const std::string& w : r.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
    std::printf("evaluation: %s\n", r.json_path.c_str());
  });
}

void addSimulateCommand(CLI::App& app) {
  struct Opts {
    std::string robot = "builtin:iiwa7.yaml", base_link, tip_link, out;
    sim::SimulationSpec spec;
    std::vector<std::string> inject;
    std::vector<double> values;
    std::string geometry = "random";
    double error_angle_deg = 0.05, error_length_mm = 0.5, noise_position_mm = 0.05, noise_rotation_deg = 0.01;
    double joint_noise_deg = 0.0;
    bool position_only = false, quiet = false;
    std::string base = "shared", marker = "per_session";
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand(
      "simulate",
      "Simulate tracker-style measured data: random configurations of an arm whose true model has DH errors and the "
      "injected effects, seen in an unknown tracker frame through an unknown marker, with noise, gravity torques "
      "(robot file masses + payload), a warm-up temperature and time. Writes measurements.yaml + CSVs, and the truth as "
      "truth/model.yaml (loadable by orbcal evaluate).");
  addRobotOptions(*cmd, o->robot, o->base_link, o->tip_link, "robot, with masses for torques");
  cmd->add_option("-o,--out", o->out, "output folder")->required();
  cmd->add_option("-n,--samples", o->spec.samples, "samples in all")->capture_default_str()->check(CLI::Range(1, 1000000));
  cmd->add_option("--sessions", o->spec.sessions, "sessions (files), samples split evenly")->capture_default_str()->check(CLI::Range(1, 1000));
  cmd->add_option("--payload-kg", o->spec.payload_kg, "payload per session [kg] (one value: all sessions)")->capture_default_str();
  cmd->add_option("--seed", o->spec.seed, "seed of everything drawn")->capture_default_str();
  cmd->add_option("--inject", o->inject,
                  "effects in the true arm, e.g. compliance:2 cyclic:4 thermal; the catalog: " + sim::effectSyntaxList() +
                      " (J a joint from 1, K the order)");
  cmd->add_option("--values", o->values,
                  "their parameter values in SI, in layout order (default: drawn, at least half a typical magnitude)");
  cmd->add_option("--geometry", o->geometry, "DH errors of the true arm: random, zero or table3")
      ->capture_default_str()
      ->check(CLI::IsMember({"random", "zero", "table3"}));
  cmd->add_option("--error-angle-deg", o->error_angle_deg, "spread of random theta/alpha errors [deg]")->capture_default_str();
  cmd->add_option("--error-length-mm", o->error_length_mm, "spread of random a/d errors [mm]")->capture_default_str();
  cmd->add_option("--noise-position-mm", o->noise_position_mm, "tracker noise, 1 sigma per axis [mm]")
      ->capture_default_str()
      ->check(CLI::Range(sim::kMinNoisePositionMm, sim::kMaxNoisePositionMm));
  cmd->add_option("--noise-rotation-deg", o->noise_rotation_deg, "tracker noise, 1 sigma per axis [deg]")
      ->capture_default_str()
      ->check(CLI::Range(sim::kMinNoiseRotationDeg, sim::kMaxNoiseRotationDeg));
  cmd->add_option("--joint-noise-deg", o->joint_noise_deg, "joint readings vs true angles, 1 sigma [deg]")
      ->capture_default_str()
      ->check(CLI::Range(0.0, sim::kMaxNoiseJointDeg));
  cmd->add_flag("--position-only", o->position_only, "the tracker measures positions only");
  cmd->add_option("--markers", o->spec.markers,
                  "motion capture: a rigid body of N marker points on the tool, measured as positions (pose.points), each "
                  "at its own offset (0: one marker)")
      ->capture_default_str()
      ->check(CLI::Range(0, 100));
  cmd->add_option("--missing-markers", o->spec.missing_marker_rate,
                  "with --markers: the share of marker points missing from the rows (empty cells; a row keeps one at least)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 0.99));
  cmd->add_flag("--quiet", o->quiet, "no progress output (simulate shows none; taken as the other commands take it)");
  cmd->add_option("--base", o->base, "tracker frame: shared, per_session or known")->capture_default_str()
      ->check(CLI::IsMember({"shared", "per_session", "known"}));
  cmd->add_option("--marker", o->marker, "marker frame: shared, per_session or known")->capture_default_str()
      ->check(CLI::IsMember({"shared", "per_session", "known"}));
  cmd->callback([o] {
    sim::SimulationSpec s = o->spec;
    const sim::Arm arm = sim::loadArm(sim::RobotSource{o->robot, o->base_link, o->tip_link});
    for (const std::string& e : o->inject) s.effects.push_back(sim::parseEffect(e, arm.numJoints(), "--inject"));
    s.effect_values = Eigen::Map<const Eigen::VectorXd>(o->values.data(), static_cast<Eigen::Index>(o->values.size()));
    s.geometry = {o->geometry, o->error_angle_deg * sim::kDegToRad, o->error_length_mm * 1e-3, o->spec.seed};
    s.noise_position_m = o->noise_position_mm * 1e-3;
    s.noise_rotation_rad = o->noise_rotation_deg * sim::kDegToRad;
    s.joint_noise_rad = o->joint_noise_deg * sim::kDegToRad;
    s.rotation = !o->position_only && s.markers == 0;  // a rigid body's points are positions
    const auto sharing = [](const std::string& v) {
      return v == "shared" ? sim::FrameSharing::kShared : v == "per_session" ? sim::FrameSharing::kPerSession : sim::FrameSharing::kKnown;
    };
    s.base = sharing(o->base);
    s.marker = sharing(o->marker);
    const sim::SimulatedData d = workflow::runSimulate(arm, s, o->out);
    std::printf("%d samples in %d session(s)%s: %s\ntruth: %s/truth/model.yaml\n", s.samples, s.sessions,
                d.data.has_torque ? " with torques" : " (no masses in the robot file: no torques)", d.data.description.c_str(),
                o->out.c_str());
  });
}

}  // namespace

ORBCAL_COMMAND(46, addEvaluateCommand);
ORBCAL_COMMAND(47, addSimulateCommand);

}  // namespace orbcal::tools
