// Subcommands on the arm model alone: fk, configs, identifiability.
#include <cmath>
#include <cstdio>
#include <iostream>

#include "cli.hpp"
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
  };
  auto opt = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand(
      "configs", "Generate joint configurations in which the eye-in-hand camera sees the whole board");
  addArmSceneOptions(*cmd, opt->as);
  cmd->add_option("-n,--count", opt->gen.count, "number of configurations")->capture_default_str()->check(CLI::Range(1, 1000000));
  cmd->add_option("--seed", opt->gen.seed, "random seed")->capture_default_str();
  cmd->add_option("-o,--out", opt->out, "output CSV (index, q1_rad..qN_rad); written atomically")->capture_default_str();
  cmd->callback([opt] {
    const sim::Arm arm = sim::loadArm(opt->as.robot);
    const sim::Scene scene = sim::loadScene(opt->as.scene);
    sim::GeneratorStats stats;
    Progress bar("configurations", opt->gen.count);
    const auto configs = sim::generateConfigurations(arm, scene, opt->gen, &stats, [&](int d, int) { bar.update(d); });
    bar.finish();
    sim::writeFileAtomic(opt->out, sim::formatConfigurationsCsv(configs));
    std::printf("%d configurations (%d attempts: IK failed %d, singular %d, board not visible %d) -> %s\n", stats.accepted,
                stats.attempts, stats.ik_failed, stats.singular, stats.not_visible, opt->out.c_str());
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
