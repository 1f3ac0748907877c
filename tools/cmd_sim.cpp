// Subcommands on the arm model alone: fk, configs, identifiability.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>

#include "cli.hpp"
#include "orbcal/calib/estimators.hpp"
#include "orbcal/calib/observability.hpp"
#include "orbcal/calib/parameter_classes.hpp"
#include "orbcal/calib/planning.hpp"
#include "orbcal/sim/arm.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/identifiability.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/workflow/planning.hpp"
#include "progress.hpp"

namespace orbcal::tools {

namespace {
void addFkCommand(CLI::App& app) {
  struct Opts {
    ArmSceneOptions as;
    std::vector<std::string> joints;
    bool json = false;
  };
  auto opt = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand(
      "fk", "Forward kinematics: the flange pose (base frame) at the given joint angles (position to the nanometre; "
            "--json: every number exact); revolute joints in deg, prismatic in mm");
  addRobotOptions(*cmd, opt->as);
  cmd->add_option("joints", opt->joints, "joint values, one per joint: revolute [deg], prismatic [mm]")->required()->allow_extra_args();
  cmd->add_flag("--json", opt->json, "print JSON (joints as qN_deg / qN_mm, base_T_flange in m, position_mm, rpy_deg) with every number exact (%.17g)");
  cmd->callback([opt] {
    const sim::Arm arm = sim::loadArm(opt->as.robotSource());
    std::printf("%s", workflow::forwardKinematicsText(arm, sim::parseEdgeJointValues(arm, opt->joints), opt->json).c_str());
  });
}

void addConfigsCommand(CLI::App& app) {
  struct Opts {
    ArmSceneOptions as;
    sim::GeneratorSettings gen;
    std::string out = "configurations.csv";
    std::string select;
    int pool = 1000;
    calib::PoseNoiseModel noise;
    double sigma_position_mm = 0.3, sigma_orientation_deg = 0.5, joint_noise_deg = 0.01;
    int random_subsets = 100;
    int repeat = 1;
    std::vector<double> joint_box_deg;
  };
  auto opt = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand(
      "configs", "Generate joint configurations in which the eye-in-hand camera sees the whole board");
  cmd->footer(
      "With --select, a pool of --pool configurations is generated and the N that maximise the chosen observability "
      "index are kept (greedy start, DETMAX and pair exchanges): O1 Borm & Menq (geometric mean of the singular "
      "values / sqrt(N)), O2 inverse condition number, O3 smallest singular value, O4 noise amplification index "
      "sigma_min^2 / sigma_max, O5 1 / sum(1 / sigma_i); of the whitened pose Jacobian (R from the sigmas below) "
      "with columns in units of each parameter's typical magnitude, unidentifiable parameters left out.");
  addArmSceneOptions(*cmd, opt->as);
  cmd->add_option("-n,--count", opt->gen.count, "number of configurations")->capture_default_str()->check(CLI::Range(1, 1000000));
  cmd->add_option("--seed", opt->gen.seed, "random seed")->capture_default_str();
  cmd->add_option("-o,--out", opt->out, "output CSV (index, q1_rad..qN_rad, SI: a prismatic joint's qJ_m); written atomically")->capture_default_str();
  cmd->add_option("--select", opt->select, "choose the N configurations from a pool by this index: O1, O2, O3, O4 or O5");
  cmd->add_option("--pool", opt->pool, "pool size for --select")->capture_default_str()->check(CLI::Range(1, 1000000));
  cmd->add_option("--repeat", opt->repeat,
                  "write each configuration N times in a row: measured so, their scatter is the noise (pure error) diagnose "
                  "judges residuals against when the description states none")
      ->capture_default_str()
      ->check(CLI::Range(1, 100));
  cmd->add_option("--sigma-position-mm", opt->sigma_position_mm, "--select: pose measurement noise, position")
      ->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_option("--sigma-orientation-deg", opt->sigma_orientation_deg, "--select: pose measurement noise, orientation")
      ->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_option("--joint-noise-deg", opt->joint_noise_deg, "--select: joint control noise carried into R")
      ->capture_default_str()->check(CLI::NonNegativeNumber);
  cmd->add_option("--joint-box-deg", opt->joint_box_deg,
                  "joint box narrower than the robot's limits: a lower and an upper bound per joint [deg; mm for a prismatic joint], "
                  "lo1 hi1 lo2 hi2 ... (e.g. the travel a cell allows)");
  cmd->add_option_function<double>(
      "--floor-z-m", [opt](double z) { opt->gen.floor_z_m = z; },
      "floor plane z = FLOOR in the base frame [m]: every joint origin and the flange stay above it");
  cmd->callback([opt] {
    workflow::ConfigsOptions c;
    c.robot = opt->as.robotSource();
    c.scene = opt->as.scene;
    c.gen = opt->gen;
    c.out = opt->out;
    if (!opt->select.empty()) c.select = calib::parseObservabilityIndex(opt->select);
    c.pool = opt->pool;
    c.noise.sigma_position_m = opt->sigma_position_mm * 1e-3;
    c.noise.sigma_orientation_rad = opt->sigma_orientation_deg * sim::kDegToRad;
    c.noise.joint_noise_sigma_rad = opt->joint_noise_deg * sim::kDegToRad;
    c.random_subsets = opt->random_subsets;
    c.repeat = opt->repeat;
    c.callbacks.progress = terminalProgress();
    if (opt->joint_box_deg.size() % 2 != 0) throw sim::InputError("--joint-box-deg: expected pairs of bounds, lo hi per joint");
    const Eigen::Index n = static_cast<Eigen::Index>(opt->joint_box_deg.size() / 2);
    const Eigen::Map<const Eigen::VectorXd, 0, Eigen::InnerStride<2>> lo(opt->joint_box_deg.data(), n), hi(opt->joint_box_deg.data() + 1, n);
    c.box_lower_edge = lo;
    c.box_upper_edge = hi;
    const workflow::ConfigsResult r = workflow::runConfigs(c);
    std::printf("%d configurations (%d attempts: IK failed %d, singular %d, board not visible %d, below the floor %d) -> %s\n",
                r.written, r.stats.attempts, r.stats.ik_failed, r.stats.singular, r.stats.not_visible, r.stats.below_floor,
                c.out.c_str());
    if (c.select) std::printf("pool of %d generated; %s", r.stats.accepted, r.selection.c_str());
  });
}

void addIdentifiabilityCommand(CLI::App& app) {
  struct Opts {
    ArmSceneOptions as;
    std::string configs;
    sim::GeneratorSettings gen;
    std::string model = "pose", pairs = "reference", base = "known";
    double sigma_position_mm = 0.3, sigma_orientation_deg = 0.5, sigma_range_mm = 0.2;
    int repeats = 10;
    std::vector<double> plane{0.0, 1.0, 4.6, -0.69}, beam_origin_mm{0.0, 0.0, 0.0}, beam_direction{0.0, 0.0, 1.0};
    std::vector<std::string> plane_identified{"nz"};
  };
  auto opt = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand(
      "identifiability",
      "Identifiability of a configuration set for a measurement kind: every parameter independent, relative (tied to "
      "others: the observable combination) or ineffective; the minimal identifiable set; observability indices O1-O5");
  cmd->footer(
      "Measurement kinds (--model): pose (Wang et al. 2023), position, distance, rotation, dr (distance and rotation "
      "between pairs, Jia et al. 2019), range (laser range to a plane, Liu et al. 2012). Rows are whitened by the "
      "noise sigmas below; O1-O5 are of the minimal identifiable set with columns in units of each parameter's typical "
      "magnitude (see `orbcal configs --help`).");
  addArmSceneOptions(*cmd, opt->as);
  cmd->add_option("--model", opt->model, "measurement kind: pose, position, distance, rotation, dr or range")
      ->capture_default_str();
  cmd->add_option("--configs", opt->configs,
                  "configurations CSV (from `orbcal configs`); default: generate them (pose kinds: the camera sees the "
                  "board; range: the beam meets the plane)");
  cmd->add_option("-n,--count", opt->gen.count, "configurations to generate when --configs is not given")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000000));
  cmd->add_option("--seed", opt->gen.seed, "random seed of the generated configurations")->capture_default_str();
  cmd->add_option("--pairs", opt->pairs, "distance/rotation/dr: pairs against the first configuration, or consecutive")
      ->capture_default_str()
      ->check(CLI::IsMember({"reference", "consecutive"}));
  cmd->add_option("--base", opt->base, "the measuring system's frame: known, or unknown (estimated with the arm)")
      ->capture_default_str()
      ->check(CLI::IsMember({"known", "unknown"}));
  cmd->add_option("--sigma-position-mm", opt->sigma_position_mm, "pose noise per axis, position [mm]")
      ->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_option("--sigma-orientation-deg", opt->sigma_orientation_deg, "pose noise per axis, orientation [deg]")
      ->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_option("--plane", opt->plane, "range: plane nx ny nz f (base frame, f in m): nx x + ny y + nz z + f = 0")
      ->capture_default_str()->expected(4);
  cmd->add_option("--plane-identified", opt->plane_identified, "range: plane coefficients identified (nx, ny, nz, f)")
      ->capture_default_str()->check(CLI::IsMember({"nx", "ny", "nz", "f"}));
  cmd->add_option("--beam-origin-mm", opt->beam_origin_mm, "range: beam origin in the flange frame [mm]")
      ->capture_default_str()->expected(3);
  cmd->add_option("--beam-direction", opt->beam_direction, "range: beam direction in the flange frame")
      ->capture_default_str()->expected(3);
  cmd->add_option("--sigma-range-mm", opt->sigma_range_mm, "range: noise of one reading [mm]")
      ->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_option("--repeats", opt->repeats, "range: readings averaged per configuration")
      ->capture_default_str()->check(CLI::Range(1, 1000000));
  cmd->callback([opt] {
    calib::MeasurementSetup setup;
    setup.kind = calib::parseMeasurementKind(opt->model, "--model");
    setup.pairing = opt->pairs == "reference" ? calib::Pairing::kReference : calib::Pairing::kConsecutive;
    setup.noise.sigma_position_m = opt->sigma_position_mm * 1e-3;
    setup.noise.sigma_rotation_rad = opt->sigma_orientation_deg * sim::kDegToRad;
    setup.range_sigma_m = opt->sigma_range_mm * 1e-3;
    setup.range_repeats = opt->repeats;
    setup.beam.origin = Eigen::Vector3d(opt->beam_origin_mm[0], opt->beam_origin_mm[1], opt->beam_origin_mm[2]) * 1e-3;
    setup.beam.direction = Eigen::Vector3d(opt->beam_direction[0], opt->beam_direction[1], opt->beam_direction[2]);
    if (!(setup.beam.direction.norm() > 0.0) || !setup.beam.origin.allFinite()) {
      throw sim::InputError("--beam-direction: must be a finite nonzero vector");
    }
    setup.beam.direction.normalize();
    setup.plane = calib::Plane{Eigen::Vector3d(opt->plane[0], opt->plane[1], opt->plane[2]), opt->plane[3], {}};
    if (!(setup.plane.n.norm() > 0.0) || !std::isfinite(setup.plane.f)) throw sim::InputError("--plane: the normal must be finite and nonzero");
    const std::vector<std::string> coefficient{"nx", "ny", "nz", "f"};
    for (const std::string& c : opt->plane_identified) {
      const int i = static_cast<int>(std::find(coefficient.begin(), coefficient.end(), c) - coefficient.begin());
      if (std::find(setup.plane.identified.begin(), setup.plane.identified.end(), i) != setup.plane.identified.end()) {
        throw sim::InputError("--plane-identified: '" + c + "' given twice");
      }
      setup.plane.identified.push_back(i);
    }
    workflow::IdentifiabilityOptions io;
    io.robot = opt->as.robotSource();
    io.scene = opt->as.scene;
    io.configs = opt->configs;
    io.gen = opt->gen;
    io.setup = setup;
    io.base_known = opt->base == "known";
    std::printf("%s", workflow::runIdentifiability(io).c_str());
  });
}

}  // namespace

ORBCAL_COMMAND(20, addFkCommand);
ORBCAL_COMMAND(21, addConfigsCommand);
ORBCAL_COMMAND(22, addIdentifiabilityCommand);

}  // namespace orbcal::tools
