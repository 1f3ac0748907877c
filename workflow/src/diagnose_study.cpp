// `orbcal diagnose-study`: the detector's power on seeded simulated datasets (diagnose.hpp).
#include "orbcal/workflow/diagnose.hpp"

#include <algorithm>
#include <chrono>
#include <numeric>
#include <cmath>
#include <optional>
#include <random>
#include <filesystem>
#include <sstream>

#include "orbcal/workflow/calibrate.hpp"
#include "orbcal/workflow/experiment.hpp"
#include "orbcal/workflow/measured.hpp"
#include "orbcal/workflow/report_html.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/model_io.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/gravity.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/sim/simulate.hpp"
#include "orbcal/vision/measurement.hpp"

namespace orbcal::workflow {

namespace {

/// The study's injector: a cause of `kind` ("cyclic", "compliance/3": a kind and, optionally, its order)
/// on a random one of the kind's candidates for a dataset with torques, masses, temperature, time,
/// directions and two sessions; compliance only on the joints gravity loads (`loaded`).
sim::Effect drawInjected(const std::string& kind, const sim::Arm& arm, const std::vector<int>& loaded, std::mt19937_64& rng) {
  const auto slash = kind.find('/');
  const sim::EffectKind* k = sim::findEffectKind(kind.substr(0, slash));
  if (!k) throw sim::InputError("--effects: '" + kind + "': unknown effect");
  const int order = slash == std::string::npos ? k->defaultOrder() : std::atoi(kind.c_str() + slash + 1);
  sim::CandidateContext ctx;
  ctx.arm = &arm;
  ctx.joints = arm.numJoints();
  ctx.torque = ctx.masses = !arm.masses.empty();
  ctx.temperature = ctx.time = ctx.direction = true;
  ctx.sessions = 2;
  ctx.harmonics = k->defaultOrder();
  std::vector<sim::Effect> pool;
  for (const sim::Effect& e : k->candidates(ctx)) {
    const bool unloaded = k->needs().torque && std::find(loaded.begin(), loaded.end(), e.joints().front()) == loaded.end();
    if (e.order() == k->defaultOrder() && !unloaded && sim::fitsJointTypes(e, arm)) pool.emplace_back(*k, e.joints(), order);
  }
  if (pool.empty()) throw sim::InputError("--effects: '" + kind + "': this robot offers it no joint or link");
  std::uniform_int_distribution<std::size_t> pick(0, pool.size() - 1);
  const sim::Effect e = pool[pick(rng)];
  e.kind().check(e, arm.numJoints(), "--effects: '" + kind + "'");
  return e;
}

}  // namespace

StudyResult runDiagnoseStudy(const StudyOptions& o) {
  std::optional<sim::OutputFolder> folder;  // claimed before the study runs: no earlier table stays beside a failed run
  if (!o.out.empty()) folder.emplace(o.out, "orbcal diagnose-study");
  const auto t0 = std::chrono::steady_clock::now();
  const sim::Arm arm = sim::loadArm(o.robotSource());
  StudyResult out;
  std::vector<std::string> kinds = o.effects;
  kinds.push_back("clean");
  int total = 0;
  for (const std::string& k : kinds) total += k == "clean" ? o.clean : o.per_effect;
  // Compliance is drawn among the joints gravity loads: RMS torque over random configurations (with the
  // heavier payload) above 1 N m, which bends a joint of typical compliance (1e-4 rad/(N m)) by 0.006
  // deg. A joint about a vertical axis carries no gravity torque: its compliance has nothing to show.
  std::vector<int> loaded;
  {
    sim::Arm heavy = arm;
    heavy.masses.payload_kg = 1.25;
    std::mt19937_64 rng = sim::makeRng(o.seed, 0x6c6f61646564ULL);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    Eigen::VectorXd sum = Eigen::VectorXd::Zero(arm.numJoints());
    const int n = 500;
    for (int k = 0; k < n; ++k) {
      Eigen::VectorXd q(arm.numJoints());
      for (int j = 0; j < arm.numJoints(); ++j) q[j] = arm.lower_rad[j] + u(rng) * (arm.upper_rad[j] - arm.lower_rad[j]);
      sum += sim::gravityTorques(heavy, heavy.masses, q).array().square().matrix();
    }
    for (int j = 0; j < arm.numJoints(); ++j) {
      if (std::sqrt(sum[j] / n) > 1.0) loaded.push_back(j);
    }
    if (loaded.empty()) throw sim::InputError(o.robot + ": masses: no joint carries a gravity torque above 1 N m");
  }
  Progress bar(o.callbacks.progress, o.quiet ? "" : "diagnose datasets", o.quiet ? 0 : total);
  int done = 0;
  for (std::size_t ki = 0; ki < kinds.size(); ++ki) {
    const std::string& kind = kinds[ki];
    StudyRow row;
    row.injected = kind;
    const int n = kind == "clean" ? o.clean : o.per_effect;
    for (int t = 0; t < n; ++t) {
      std::mt19937_64 rng = sim::makeRng(o.seed, 1000 * ki + static_cast<std::uint64_t>(t));
      sim::SimulationSpec spec;
      spec.samples = o.samples;
      spec.sessions = 2;
      spec.payload_kg = {0.0, 1.25};
      spec.seed = rng();
      spec.geometry.seed = spec.seed;
      if (kind == "mount") spec.marker = sim::FrameSharing::kShared;  // a mount change is a change of a shared marker
      std::optional<sim::Effect> injected;
      if (kind != "clean") {
        injected = drawInjected(kind, arm, loaded, rng);
        spec.effects = {*injected};
        Eigen::VectorXd values(0);
        for (const sim::ParamBlock& b : sim::effectBlocks(*injected, arm, spec.sessions)) {
          for (const sim::ParamInfo& p : b.params) {
            std::uniform_real_distribution<double> mag(0.5, 2.0);
            values.conservativeResize(values.size() + 1);
            values[values.size() - 1] = p.typical * mag(rng) * (rng() % 2 ? 1.0 : -1.0);
          }
        }
        spec.effect_values = values;
      }
      const sim::SimulatedData s = sim::simulateMeasured(arm, spec);
      const std::vector<calib::MarkerObservation> obs = calib::observationsFrom(s.data, true);
      const calib::Diagnosis d = calib::diagnose(s.data, obs, o.diagnose);
      ++row.datasets;
      std::string named;
      for (const sim::Effect& e : d.selected) named += (named.empty() ? "" : " ") + sim::formatEffect(e);
      const std::string miss = (injected ? sim::formatEffect(*injected) : std::string("clean")) + " -> " +
                               (d.clean ? "clean" : named.empty() ? "unexplained (no cause named)" : named);
      if (d.clean) {
        ++row.clean_verdict;
        if (injected) row.misses.push_back(miss);
      } else if (injected) {
        // The right cause on the right joints, whatever order diagnose chose (cyclic:2 or cyclic:2/3).
        const auto same = [&](const sim::Effect& e) {
          return &e.kind() == &injected->kind() && e.kind().keys(e) == injected->kind().keys(*injected);
        };
        const auto kindOnly = [&](const sim::Effect& e) { return &e.kind() == &injected->kind(); };
        if (std::any_of(d.selected.begin(), d.selected.end(), same)) {
          ++row.named;
          if (d.selected.size() > 1) ++row.extra;
        } else if (std::any_of(d.selected.begin(), d.selected.end(), kindOnly)) {
          ++row.wrong_joint;
          row.misses.push_back(miss);
        } else {
          ++row.other;
          row.misses.push_back(miss);
        }
      } else {
        ++row.other;
        row.misses.push_back(miss);
      }
      bar.update(++done);
    }
    out.rows.push_back(row);
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (folder) {
    sim::writeFileAtomic(folder->path() + "/diagnose_study.csv", formatStudyCsv(out));
    writeReport(folder->path(), "# orbcal diagnose-study: what the detector names\n\n" + formatStudy(out));
    folder->commit();
  }
  return out;
}

std::string formatStudy(const StudyResult& r) {
  std::string md = "| injected | datasets | named (right joint) | same effect, wrong joint | other effects only | clean verdict | named + extra effects |\n"
                   "|---|---|---|---|---|---|---|\n";
  for (const StudyRow& row : r.rows) {
    const auto pct = [&](int k) { return std::to_string(k) + " (" + sim::formatNumber("%.0f", 100.0 * k / std::max(1, row.datasets)) + "%)"; };
    md += "| " + row.injected + " | " + std::to_string(row.datasets) + " | " + (row.injected == "clean" ? "" : pct(row.named)) + " | " +
          (row.injected == "clean" ? "" : pct(row.wrong_joint)) + " | " + pct(row.other) + " | " + pct(row.clean_verdict) + " | " +
          (row.injected == "clean" ? "" : pct(row.extra)) + " |\n";
  }
  std::string misses;
  for (const StudyRow& row : r.rows) {
    for (const std::string& m : row.misses) misses += (misses.empty() ? "" : "; ") + m;
  }
  return md + (misses.empty() ? "" : "\nNot named right (injected -> named): " + misses + "\n");
}

std::string formatStudyCsv(const StudyResult& r) {
  std::string csv = "injected,datasets,named,wrong_joint,other,clean_verdict,extra,named_rate,wrong_joint_rate,other_rate,"
                    "clean_rate,extra_rate\n";
  for (const StudyRow& row : r.rows) {
    const double n = std::max(1, row.datasets);
    csv += row.injected + "," + std::to_string(row.datasets);
    for (int k : {row.named, row.wrong_joint, row.other, row.clean_verdict, row.extra}) csv += "," + std::to_string(k);
    for (int k : {row.named, row.wrong_joint, row.other, row.clean_verdict, row.extra}) csv += "," + sim::formatNumber("%.6f", k / n);
    csv += "\n";
  }
  return csv;
}

}  // namespace orbcal::workflow
