// Subcommands on the arm model alone: fk, configs, identifiability.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>

#include "cli.hpp"
#include "orbcal/calib/estimators.hpp"
#include "orbcal/calib/observability.hpp"
#include "orbcal/sim/arm.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/identifiability.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "progress.hpp"

namespace orbcal::tools {

namespace {

Eigen::VectorXd parseJointsDeg(const std::vector<std::string>& words, const sim::Arm& arm) {
  if (static_cast<int>(words.size()) != arm.numJoints()) {
    throw sim::InputError("joint angles: expected " + std::to_string(arm.numJoints()) + " (" + arm.source + " has " +
                          std::to_string(arm.numJoints()) + " joints), got " + std::to_string(words.size()));
  }
  Eigen::VectorXd q(arm.numJoints());
  for (int j = 0; j < arm.numJoints(); ++j) {
    char* end = nullptr;
    const double v = std::strtod(words[j].c_str(), &end);
    if (words[j].empty() || end != words[j].c_str() + words[j].size() || !std::isfinite(v)) {
      throw sim::InputError("joint angles: q" + std::to_string(j + 1) + ": expected a finite angle in degrees, got '" +
                            words[j] + "'");
    }
    q[j] = v * sim::kDegToRad;
  }
  return q;
}

}  // namespace

namespace {
void addFkCommand(CLI::App& app) {
  struct Opts {
    ArmSceneOptions as;
    std::vector<std::string> joints;
  };
  auto opt = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand("fk", "Forward kinematics: the flange pose (base frame) at the given joint angles");
  cmd->add_option("--robot", opt->as.robot, "robot description (YAML; or builtin:ssrms.yaml)")->capture_default_str();
  cmd->add_option("joints_deg", opt->joints, "joint angles [deg], one per joint")->required()->allow_extra_args();
  cmd->callback([opt] {
    const sim::Arm arm = sim::loadArm(opt->as.robot);
    const Eigen::VectorXd q = parseJointsDeg(opt->joints, arm);
    const Eigen::Isometry3d T = sim::forwardKinematics(arm, q);
    const Eigen::Vector3d p = T.translation() * 1e3;
    const Eigen::Vector3d rpy = T.linear().eulerAngles(2, 1, 0).reverse() * sim::kRadToDeg;
    std::printf("base_T_flange (%s):\n", arm.name.c_str());
    for (int r = 0; r < 3; ++r) {
      std::printf("  [% .9f % .9f % .9f]  % 12.4f mm\n", T(r, 0), T(r, 1), T(r, 2), p[r]);
    }
    std::printf("position_mm: [%.4f, %.4f, %.4f]\nrpy_deg (R = Rz Ry Rx): [%.6f, %.6f, %.6f]\n", p.x(), p.y(), p.z(),
                rpy.x(), rpy.y(), rpy.z());
    std::printf("within joint limits: %s\n", sim::withinLimits(arm, q) ? "yes" : "no");
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
  cmd->add_option("-o,--out", opt->out, "output CSV (index, q1_rad..qN_rad); written atomically")->capture_default_str();
  cmd->add_option("--select", opt->select, "choose the N configurations from a pool by this index: O1, O2, O3, O4 or O5");
  cmd->add_option("--pool", opt->pool, "pool size for --select")->capture_default_str()->check(CLI::Range(1, 1000000));
  cmd->add_option("--sigma-position-mm", opt->sigma_position_mm, "--select: pose measurement noise, position")
      ->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_option("--sigma-orientation-deg", opt->sigma_orientation_deg, "--select: pose measurement noise, orientation")
      ->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_option("--joint-noise-deg", opt->joint_noise_deg, "--select: joint control noise carried into R")
      ->capture_default_str()->check(CLI::NonNegativeNumber);
  cmd->callback([opt] {
    const sim::Arm arm = sim::loadArm(opt->as.robot);
    const sim::Scene scene = sim::loadScene(opt->as.scene);
    std::optional<calib::ObservabilityIndex> index;
    if (!opt->select.empty()) index = calib::parseObservabilityIndex(opt->select);
    if (index && opt->pool < opt->gen.count) {
      throw sim::InputError("--pool: " + std::to_string(opt->pool) + " is smaller than -n " + std::to_string(opt->gen.count));
    }
    sim::GeneratorSettings gen = opt->gen;
    if (index) gen.count = opt->pool;
    sim::GeneratorStats stats;
    Progress bar(index ? "pool configurations" : "configurations", gen.count);
    auto configs = sim::generateConfigurations(arm, scene, gen, &stats, [&](int d, int) { bar.update(d); });
    bar.finish();
    std::string selection_report;
    if (index) {
      calib::PoseNoiseModel noise;
      noise.sigma_position_m = opt->sigma_position_mm * 1e-3;
      noise.sigma_orientation_rad = opt->sigma_orientation_deg * sim::kDegToRad;
      noise.joint_noise_sigma_rad = opt->joint_noise_deg * sim::kDegToRad;
      const calib::PoseMeasurementModel model = calib::posePlanningModel(arm, configs, noise);
      const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model.numParams());
      const std::vector<int> held = calib::unidentifiableToFix(model, zero, 1e-6);
      const auto blocks = calib::observabilityBlocks(model, zero, held);
      calib::SelectionOptions so;
      so.index = *index;
      so.seed = opt->gen.seed;
      const calib::Selection sel = calib::selectConfigurations(blocks, opt->gen.count, so);
      const double random =
          calib::meanRandomIndex(blocks, opt->gen.count, *index, opt->random_subsets, opt->gen.seed);
      std::vector<Eigen::VectorXd> chosen;
      for (int k : sel.chosen) chosen.push_back(configs[static_cast<std::size_t>(k)]);
      configs = std::move(chosen);
      const std::string name = calib::observabilityIndexName(*index);
      std::string held_names;
      for (int p : held) held_names += (held_names.empty() ? "" : ", ") + model.paramName(p);
      const calib::ObservabilityIndices& r = sel.indices;
      char line[512];
      std::snprintf(line, sizeof line,
                    "selected %d of %d by %s in %.2f s (%d exchanges): %s = %.6g; random subsets of %d (mean of %d): "
                    "%s = %.6g (selected / random = %.2f)\n"
                    "selected set: O1 %.6g, O2 %.6g, O3 %.6g, O4 %.6g, O5 %.6g; rank %d of %d (held: %s)\n",
                    opt->gen.count, opt->pool, name.c_str(), sel.seconds, sel.exchanges, name.c_str(), r.value(*index),
                    opt->gen.count, opt->random_subsets, name.c_str(), random,
                    random > 0 ? r.value(*index) / random : 0.0, r.o1, r.o2, r.o3, r.o4, r.o5, r.rank, r.num_params,
                    held_names.empty() ? "none" : held_names.c_str());
      selection_report = line;
    }
    sim::writeFileAtomic(opt->out, sim::formatConfigurationsCsv(configs));
    std::printf("%d configurations (%d attempts: IK failed %d, singular %d, board not visible %d) -> %s\n",
                static_cast<int>(configs.size()), stats.attempts, stats.ik_failed, stats.singular, stats.not_visible,
                opt->out.c_str());
    if (index) std::printf("pool of %d generated; %s", stats.accepted, selection_report.c_str());
  });
}

void addIdentifiabilityCommand(CLI::App& app) {
  struct Opts {
    ArmSceneOptions as;
    std::string configs;
    sim::GeneratorSettings gen;
  };
  auto opt = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand(
      "identifiability", "Rank, condition number and unidentifiable parameter combinations of a configuration set");
  addArmSceneOptions(*cmd, opt->as);
  cmd->add_option("--configs", opt->configs, "configurations CSV (from `orbcal configs`); default: generate them");
  cmd->add_option("-n,--count", opt->gen.count, "configurations to generate when --configs is not given")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000000));
  cmd->add_option("--seed", opt->gen.seed, "random seed of the generated configurations")->capture_default_str();
  cmd->callback([opt] {
    const sim::Arm arm = sim::loadArm(opt->as.robot);
    std::vector<Eigen::VectorXd> configs;
    if (!opt->configs.empty()) {
      configs = sim::parseConfigurationsCsv(sim::readTextSource(opt->configs), opt->configs, arm.numJoints());
    } else {
      configs = sim::generateConfigurations(arm, sim::loadScene(opt->as.scene), opt->gen);
    }
    std::cout << sim::formatIdentifiability(sim::analyzeIdentifiability(arm, configs));
  });
}

}  // namespace

ORBCAL_COMMAND(20, addFkCommand);
ORBCAL_COMMAND(21, addConfigsCommand);
ORBCAL_COMMAND(22, addIdentifiabilityCommand);

}  // namespace orbcal::tools
