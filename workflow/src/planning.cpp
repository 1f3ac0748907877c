// `orbcal fk`, `orbcal configs` and `orbcal identifiability` (planning.hpp).
#include "orbcal/workflow/planning.hpp"

#include <algorithm>
#include <cstdio>
#include <sstream>

#include "orbcal/calib/estimators.hpp"
#include "orbcal/calib/parameter_classes.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/identifiability.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::workflow {

namespace {

/// Keeps the o.gen.count configurations of `configs` that maximise the index; returns what was chosen.
std::string selectFromPool(const ConfigsOptions& o, const sim::Arm& arm, std::vector<Eigen::VectorXd>& configs) {
  const calib::ObservabilityIndex index = *o.select;
  const calib::MarkerPoseModel model = calib::posePlanningModel(arm, configs, o.noise);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model.numParams());
  const std::vector<int> held = calib::unidentifiableToFix(model, zero);
  const auto blocks = calib::observabilityBlocks(model, zero, held);
  calib::SelectionOptions so;
  so.index = index;
  so.seed = o.gen.seed;
  const calib::Selection sel = calib::selectConfigurations(blocks, o.gen.count, so);
  const double random = calib::meanRandomIndex(blocks, o.gen.count, index, o.random_subsets, o.gen.seed);
  std::vector<Eigen::VectorXd> chosen;
  for (int k : sel.chosen) chosen.push_back(configs[static_cast<std::size_t>(k)]);
  configs = std::move(chosen);
  const std::string name = calib::observabilityIndexName(index);
  std::string held_names;
  for (int p : held) held_names += (held_names.empty() ? "" : ", ") + model.paramName(p);
  const calib::ObservabilityIndices& r = sel.indices;
  char line[512];
  std::snprintf(line, sizeof line,
                "selected %d of %d by %s in %.2f s (%d exchanges): %s = %.6g; random subsets of %d (mean of %d): "
                "%s = %.6g (selected / random = %.2f)\n"
                "selected set: O1 %.6g, O2 %.6g, O3 %.6g, O4 %.6g, O5 %.6g; rank %d of %d (held: %s)\n",
                o.gen.count, o.pool, name.c_str(), sel.seconds, sel.exchanges, name.c_str(), r.value(index), o.gen.count,
                o.random_subsets, name.c_str(), random, random > 0 ? r.value(index) / random : 0.0, r.o1, r.o2, r.o3, r.o4,
                r.o5, r.rank, r.num_params, held_names.empty() ? "none" : held_names.c_str());
  return line;
}

}  // namespace

ConfigsResult runConfigs(const ConfigsOptions& o) {
  const sim::Arm robot = sim::loadArm(o.robot);
  const bool box = o.box_lower_edge.size() > 0 || o.box_upper_edge.size() > 0;
  const auto si = [&](Eigen::VectorXd v) {  // deg or mm -> rad or m; a wrong count is withJointBox's to refuse
    for (Eigen::Index j = 0; j < std::min<Eigen::Index>(v.size(), robot.numJoints()); ++j) v[j] /= sim::jointEdgeScale(robot, static_cast<int>(j));
    return v;
  };
  const sim::Arm arm = box ? sim::withJointBox(robot, si(o.box_lower_edge), si(o.box_upper_edge), "--joint-box-deg") : robot;
  const sim::Scene scene = sim::loadScene(o.scene);
  if (o.select && o.pool < o.gen.count) {
    throw sim::InputError("--pool: " + std::to_string(o.pool) + " is smaller than -n " + std::to_string(o.gen.count));
  }
  sim::GeneratorSettings gen = o.gen;
  if (o.select) gen.count = o.pool;
  ConfigsResult r;
  std::vector<Eigen::VectorXd> configs;
  {
    Progress bar(o.callbacks.progress, o.select ? "pool configurations" : "configurations", gen.count);
    configs = sim::generateConfigurations(arm, scene, gen, &r.stats, [&](int d, int) { bar.update(d); });
  }
  if (o.select) r.selection = selectFromPool(o, arm, configs);
  if (o.repeat < 1) throw sim::InputError("--repeat: expected at least 1, got " + std::to_string(o.repeat));
  std::vector<Eigen::VectorXd> repeated;
  for (const Eigen::VectorXd& q : configs) repeated.insert(repeated.end(), static_cast<std::size_t>(o.repeat), q);
  configs = std::move(repeated);
  sim::writeFileAtomic(o.out, sim::formatConfigurationsCsv(configs, &arm));
  r.written = static_cast<int>(configs.size());
  return r;
}

std::string runIdentifiability(const IdentifiabilityOptions& o) {
  const calib::MeasurementSetup& setup = o.setup;
  const sim::Arm arm = sim::loadArm(o.robot);
  const sim::KinematicModel km =
      o.base_known ? sim::flangeModel(arm)
                   : sim::makeKinematicModel(arm, 1, sim::FrameSharing::kShared, sim::FrameSharing::kKnown,
                                             {Eigen::Isometry3d::Identity()}, {Eigen::Isometry3d::Identity()}, {});
  std::vector<sim::JointSample> samples;
  if (!o.configs.empty()) {
    samples = calib::samplesOf(sim::parseConfigurationsCsv(sim::readTextSource(o.configs), o.configs, arm.numJoints()));
  } else if (setup.kind == calib::MeasurementKind::kRange) {  // random, non-singular, the beam meeting the plane
    auto rng = sim::makeRng(o.gen.seed, 0x72616e6765ULL);
    samples = calib::rangeConfigurations(calib::PlaneRangeModel(km, setup.beam, setup.plane, {}), {}, o.gen.count, rng);
  } else {  // the eye-in-hand camera sees the board
    samples = calib::samplesOf(sim::generateConfigurations(arm, sim::loadScene(o.scene), o.gen));
  }
  const auto model = calib::planningModel(setup, km, samples);
  if (model->numSamples() == 0) throw sim::InputError("--configs: no configuration gives a measurement of this kind");
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model->numParams());
  const calib::ParameterClasses classes = calib::classifyParameters(*model, zero);
  int rows = 0;
  for (int k = 0; k < model->numSamples(); ++k) rows += model->rows(k);
  char head[1024];
  std::snprintf(head, sizeof head, "Measurement: %s\nArm: %s (%s), %d configurations -> %d samples, %d rows; %d parameters%s\n\n",
                calib::measurementKindDescription(setup.kind).c_str(), arm.name.c_str(), arm.source.c_str(),
                static_cast<int>(samples.size()), model->numSamples(), rows, model->numParams(),
                o.base_known ? "" : " (the measuring system's frame unknown: base_*)");
  return head + classes.table() + "\nObservability of the minimal set: " +
         calib::formatIndices(calib::observability(*model, zero, classes.held)) + "\n";
}

std::string forwardKinematicsText(const sim::Arm& arm, const Eigen::VectorXd& q, bool json) {
  const Eigen::Isometry3d T = sim::forwardKinematics(arm, q);
  const Eigen::Vector3d p = T.translation() * 1e3;
  const Eigen::Vector3d rpy = T.linear().eulerAngles(2, 1, 0).reverse() * sim::kRadToDeg;
  const bool within = sim::withinLimits(arm, q);
  std::ostringstream out;
  if (json) {
    const auto list = [](const Eigen::VectorXd& v, const std::string& key) {
      std::string s = "[";
      for (Eigen::Index i = 0; i < v.size(); ++i) s += (i ? ", " : "") + sim::jsonNumber(v[i], "fk: " + key);
      return s + "]";
    };
    out << "{\"robot\": " << sim::jsonString(arm.name) << ", \"joints\": {";
    for (int j = 0; j < arm.numJoints(); ++j) {  // as typed: "q1_mm" for a prismatic joint, "q2_deg" for a revolute one
      const std::string key = sim::jointEdgeColumn(arm, j);
      out << (j ? ", " : "") << sim::jsonString(key) << ": " << sim::jsonNumber(q[j] * sim::jointEdgeScale(arm, j), "fk: joints: " + key);
    }
    out << "}, \"base_T_flange\": [";
    for (int r = 0; r < 4; ++r) out << (r ? ", " : "") << list(T.matrix().row(r).transpose(), "base_T_flange");
    out << "], \"position_mm\": " << list(p, "position_mm") << ", \"rpy_deg\": " << list(rpy, "rpy_deg")
        << ", \"within_limits\": " << (within ? "true" : "false") << "}\n";
    return out.str();
  }
  out << "base_T_flange (" << arm.name << "):\n";
  for (int r = 0; r < 3; ++r) {
    out << sim::formatNumber("  [% .12f", T(r, 0)) << sim::formatNumber(" % .12f", T(r, 1)) << sim::formatNumber(" % .12f]", T(r, 2))
        << sim::formatNumber("  % 16.6f mm\n", p[r]);
  }
  out << sim::formatNumber("position_mm: [%.6f, ", p.x()) << sim::formatNumber("%.6f, ", p.y()) << sim::formatNumber("%.6f]\n", p.z())
      << sim::formatNumber("rpy_deg (R = Rz Ry Rx): [%.9f, ", rpy.x()) << sim::formatNumber("%.9f, ", rpy.y())
      << sim::formatNumber("%.9f]\n", rpy.z()) << "within joint limits: " << (within ? "yes" : "no") << "\n";
  return out.str();
}

}  // namespace orbcal::workflow
