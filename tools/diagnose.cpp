#include "diagnose.hpp"

#include <chrono>
#include <cmath>
#include <optional>
#include <random>
#include <filesystem>
#include <sstream>

#include "calibrate.hpp"
#include "experiment.hpp"
#include "measured.hpp"
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
#include "progress.hpp"

namespace orbcal::tools {

namespace {

std::string jsonString(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

std::string effectJson(const sim::Effect& e) {
  std::string j = "{\"effect\": " + jsonString(sim::effectName(e)) + ", \"joints\": [";
  const std::vector<int> joints = sim::effectJoints(e);
  for (std::size_t i = 0; i < joints.size(); ++i) j += (i ? ", " : "") + std::to_string(joints[i] + 1);
  return j + "]";
}

std::string statsJson(const calib::ResidualStats& s) {
  return "{\"position_mean_mm\": " + sim::exactNumber(s.position_mean_m * 1e3) + ", \"position_rms_mm\": " +
         sim::exactNumber(s.position_rms_m * 1e3) + ", \"position_max_mm\": " + sim::exactNumber(s.position_max_m * 1e3) +
         ", \"rotation_rms_deg\": " + sim::exactNumber(s.rotation_rms_rad * sim::kRadToDeg) + "}";
}

/// The selected effects' parameters with their 1-sigma, from the final fit.
struct EffectParams {
  sim::Effect effect;
  std::vector<std::tuple<const sim::ParamInfo*, double, double>> params;  ///< info, value, sigma (SI)
};
std::vector<EffectParams> selectedParams(const calib::Diagnosis& d) {
  std::vector<EffectParams> out;
  const sim::KinematicModel& m = d.fit.model;
  for (std::size_t k = 0; k < m.effects.size(); ++k) {
    out.emplace_back();
    EffectParams& ep = out.back();
    ep.effect = m.effects[k];
    for (const int blk : m.effect_blocks[k]) {
      const sim::ParamBlock& b = m.layout.block(blk);
      for (int i = 0; i < b.size(); ++i) {
        const int idx = b.offset + i;
        ep.params.emplace_back(&b.params[static_cast<std::size_t>(i)], d.fit.p[idx],
                               std::sqrt(std::max(0.0, d.fit.estimate.covariance(idx, idx))));
      }
    }
  }
  return out;
}

/// The variable that reveals an effect (a column of residuals.csv) and its label.
std::pair<std::string, std::string> revealingVariable(const sim::Effect& e) {
  const std::vector<int> j = sim::effectJoints(e);
  const std::string n = j.empty() ? "" : std::to_string(j.front() + 1);
  const std::string name = sim::effectName(e);
  if (name == "compliance") return {"tau" + n + "_Nm", "joint " + n + " torque (N m)"};
  if (name == "cyclic" || name == "scale") return {"q" + n + "_deg", "joint " + n + " angle (deg)"};
  if (name == "backlash") return {"dir" + n, "joint " + n + " approach direction"};
  if (name == "thermal") return {"temperature_C", "temperature (degC)"};
  if (name == "drift") return {"time_s", "time (s)"};
  return {"session", "session"};
}

}  // namespace

std::string diagnosisJson(const calib::Diagnosis& d) {
  std::ostringstream j;
  j << "{\"verdict\": " << jsonString(d.clean ? "clean" : "effects") << ",\n \"sentence\": " << jsonString(d.verdict)
    << ",\n \"selected\": [";
  const std::vector<EffectParams> sel = selectedParams(d);
  for (std::size_t k = 0; k < sel.size(); ++k) {
    j << (k ? ",\n   " : "\n   ") << effectJson(sel[k].effect) << ", \"parameters\": [";
    for (std::size_t i = 0; i < sel[k].params.size(); ++i) {
      const auto& [info, value, sigma] = sel[k].params[i];
      j << (i ? ", " : "") << "{\"name\": " << jsonString(info->name) << ", \"value\": " << sim::exactNumber(value)
        << ", \"sigma\": " << sim::exactNumber(sigma) << ", \"unit\": " << jsonString(info->unit) << "}";
    }
    j << "]}";
  }
  j << "],\n \"confounded\": [";
  for (std::size_t c = 0; c < d.confounded.size(); ++c) {
    j << (c ? ", " : "") << "[";
    for (std::size_t i = 0; i < d.confounded[c].effects.size(); ++i) j << (i ? ", " : "") << effectJson(d.confounded[c].effects[i]) << "}";
    if (d.confounded[c].with_geometry) j << (d.confounded[c].effects.empty() ? "" : ", ") << "{\"effect\": \"geometry\", \"joints\": []}";
    j << "]";
  }
  j << "],\n \"heldout\": {\"base\": " << statsJson(d.heldout.base) << ", \"selected\": " << statsJson(d.heldout.selected) << "},\n"
    << " \"seconds\": " << sim::formatNumber("%.3f", d.seconds) << "}\n";
  return j.str();
}

DiagnoseRunResult runDiagnose(const DiagnoseRunOptions& o) {
  DiagnoseRunResult r;
  sim::MeasuredData data;
  std::vector<calib::MarkerObservation> obs;
  const bool measured = std::filesystem::is_regular_file(o.input);
  if (measured) {
    data = sim::loadMeasuredData(o.input);
    obs = calib::observationsFrom(data, data.has_torque || !data.arm.masses.empty());
  } else {
    const sim::Dataset d = sim::loadDataset(o.input);
    std::vector<vision::Measurement> meas;
    {
      Progress bar(o.quiet ? "" : "measure images", o.quiet ? 0 : static_cast<int>(d.samples.size()));
      meas = vision::measureDataset(d, {}, [&](int done, int) { bar.update(done); });
    }
    std::vector<std::size_t> usable;
    for (std::size_t k = 0; k < meas.size(); ++k) {
      if (meas[k].found()) usable.push_back(k);
    }
    ImageMeasuredData im = imageMeasuredData(d, meas, usable);
    data = std::move(im.data);
    obs = std::move(im.observations);
  }
  calib::DiagnoseOptions options = o.diagnose;
  if (!measured && options.joint_noise_sigma_rad == 0.0) {
    // As orbcal calibrate: the manifest's joint noise, else seed 000's 0.01 deg.
    const sim::Dataset d = sim::loadDataset(o.input);
    options.joint_noise_sigma_rad = d.manifest.joint_noise_sigma_rad > 0.0 ? d.manifest.joint_noise_sigma_rad : 0.01 * sim::kDegToRad;
  }
  r.diagnosis = calib::diagnose(data, obs, options);
  const calib::Diagnosis& dg = r.diagnosis;

  const std::string out = o.out.empty() ? (measured ? std::filesystem::path(o.input).parent_path().string() : o.input) + "/diagnosis" : o.out;
  sim::makeDirectories(out);
  r.json_path = out + "/diagnosis.json";
  sim::writeFileAtomic(r.json_path, diagnosisJson(dg));
  const calib::CalibratedModel cm = calib::calibratedModel(dg.fit);
  r.model_path = sim::writeModelFile(cm.model, cm.p, parameterRows(dg.fit), out,
                                     "Selected by orbcal " ORBCAL_VERSION " (orbcal diagnose) from " + o.input);

  // Per-sample held-out errors with the variables, for the figures.
  std::ostringstream csv;
  const int n = data.arm.numJoints();
  csv << "index,session,base_mm,selected_mm";
  for (int j = 1; j <= n; ++j) csv << ",q" << j << "_deg";
  for (int j = 1; j <= n; ++j) csv << ",tau" << j << "_Nm";
  for (int j = 1; j <= n; ++j) csv << ",dir" << j;
  csv << ",temperature_C,time_s\n";
  for (std::size_t i = 0; i < obs.size(); ++i) {
    const sim::JointSample& s = obs[i].sample;
    csv << i << "," << s.session << "," << dg.residual_base[i].head<3>().norm() * 1e3 << ","
        << dg.residual_selected[i].head<3>().norm() * 1e3;
    for (int j = 0; j < n; ++j) csv << "," << s.q_rad[j] * sim::kRadToDeg;
    for (int j = 0; j < n; ++j) csv << "," << (s.hasTorque() ? s.tau_Nm[j] : 0.0);
    for (int j = 0; j < n; ++j) csv << "," << (s.direction.size() == n ? s.direction[j] : 0.0);
    csv << "," << (s.hasTemperature() ? s.temperature_C : 0.0) << "," << (s.hasTime() ? s.time_s : 0.0) << "\n";
  }
  sim::writeFileAtomic(out + "/residuals.csv", csv.str());
  ExperimentOptions plot;
  plot.plots = o.plots;
  std::string figures = drawFigure(plot, out, "residuals '" + out + "/residuals.csv' index 'sample'", "samples.png",
                                   "held-out position error per sample, before and after");
  for (const sim::Effect& e : dg.selected) {
    const auto [column, label] = revealingVariable(e);
    const std::string png = "residuals_" + sim::effectName(e) + std::to_string(sim::effectJoints(e).empty() ? 0 : sim::effectJoints(e)[0] + 1) + ".png";
    figures += drawFigure(plot, out, "residuals '" + out + "/residuals.csv' " + column + " '" + label + "'", png,
                          "held-out position error against " + label);
  }

  std::ostringstream md;
  md << "# Diagnosis of " << data.arm.name << "\n\n**" << dg.verdict << "**\n\n";
  for (const calib::ConfoundedSet& c : dg.confounded) {
    md << "**Confounded in this data:** ";
    for (std::size_t i = 0; i < c.effects.size(); ++i) md << (i ? ", " : "") << calib::describeEffect(c.effects[i]);
    if (c.with_geometry) md << (c.effects.empty() ? "" : " and ") << "the geometric/registration parameters";
    md << " explain the same residuals here. To separate them, " << c.separate_by << ".\n\n";
  }
  md << "Input `" << o.input << "`: " << obs.size() << " samples in " << data.numSessions() << " session(s); "
     << o.diagnose.folds << "-fold cross-validation by configuration (seed " << o.diagnose.seed << "); candidate tests at "
     << "family-wise error " << o.diagnose.alpha << " (Holm); a parameter must cut the held-out whitened squared error by "
     << o.diagnose.penalty_per_param << " to be added. " << sim::formatNumber("%.2f", dg.seconds) << " s.\n\n"
     << "## Held-out errors (cross-validated)\n\n"
     << "| model | position mean (mm) | position RMS (mm) | position max (mm) | rotation RMS (deg) | whitened SSE |\n|---|---|---|---|---|---|\n";
  const auto row = [&](const std::string& name, const calib::ResidualStats& s, double sse) {
    md << "| " << name << " | " << sim::formatNumber("%.4f", s.position_mean_m * 1e3) << " | " << sim::formatNumber("%.4f", s.position_rms_m * 1e3)
       << " | " << sim::formatNumber("%.4f", s.position_max_m * 1e3) << " | " << sim::formatNumber("%.4f", s.rotation_rms_rad * sim::kRadToDeg)
       << " | " << sim::formatNumber("%.1f", sse) << " |\n";
  };
  row("geometry + registration", dg.heldout.base, dg.cv_base);
  row(dg.clean ? "(nothing added)" : "selected model", dg.heldout.selected, dg.cv_selected);
  if (!dg.clean) {
    md << "\n## Selected effects (parameters and 1-sigma)\n\n| effect | parameter | value | 1-sigma | unit |\n|---|---|---|---|---|\n";
    for (const EffectParams& ep : selectedParams(dg)) {
      for (const auto& [info, value, sigma] : ep.params) {
        md << "| " << sim::formatEffect(ep.effect) << " | " << info->name << " | " << sim::formatNumber("%+.4g", value * info->display_scale)
           << " | " << sim::formatNumber("%.2g", sigma * info->display_scale) << " | " << info->display_unit << " |\n";
      }
    }
  }
  md << "\n## Candidates\n\nScore test of each candidate's columns beyond the current model (rank: what the model cannot "
        "absorb); the significant ones fitted and cross-validated.\n\n| step | candidate | params | rank | score | p (Holm) | CV gain |\n|---|---|---|---|---|---|---|\n";
  for (const calib::CandidateResult& c : dg.candidates) {
    if (!c.significant && c.p_adjusted > 0.5) continue;  // the long tail of nothing
    md << "| " << c.step << " | " << sim::formatEffect(c.effect) << " | " << c.params << " | " << c.rank << " | "
       << sim::formatNumber("%.1f", c.score) << " | " << sim::formatNumber("%.2g", c.p_adjusted) << (c.significant ? " *" : "") << " | "
       << (c.cv_gain ? sim::formatNumber("%.1f", *c.cv_gain) : std::string("")) << " |\n";
  }
  md << "\n(candidates with Holm-adjusted p above 0.5 not listed; * significant)\n\n"
     << "## Evidence: held-out residuals of geometry + registration against each variable\n\n"
     << "| variable | regressors | F | p (Holm) |\n|---|---|---|---|\n";
  for (const calib::VariableTest& t : dg.evidence) {
    md << "| " << t.variable << " | " << t.dof << " | " << sim::formatNumber("%.2f", t.statistic) << " | "
       << sim::formatNumber("%.2g", t.p_adjusted) << (t.p_adjusted < o.diagnose.alpha ? " *" : "") << " |\n";
  }
  md << "\n## Figures\n\n" << figures << "\nFiles: `diagnosis.json`, `model.yaml` (the selected model, for `orbcal evaluate`), "
     << "`residuals.csv`.\n";
  r.report_path = out + "/report.md";
  sim::writeFileAtomic(r.report_path, md.str());
  return r;
}

StudyResult runDiagnoseStudy(const StudyOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  const sim::Arm arm = sim::loadArm(o.robot);
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
  Progress bar(o.quiet ? "" : "diagnose datasets", o.quiet ? 0 : total);
  int done = 0;
  for (std::size_t ki = 0; ki < kinds.size(); ++ki) {
    const std::string& kind = kinds[ki];
    StudyRow row;
    row.injected = kind;
    const int n = kind == "clean" ? o.clean : o.per_effect;
    for (int t = 0; t < n; ++t) {
      std::mt19937_64 rng = sim::makeRng(o.seed, 1000 * ki + static_cast<std::uint64_t>(t));
      std::uniform_int_distribution<int> joint(0, arm.numJoints() - 1);
      sim::SimulationSpec spec;
      spec.samples = o.samples;
      spec.sessions = 2;
      spec.payload_kg = {0.0, 1.25};
      spec.seed = rng();
      spec.geometry.seed = spec.seed;
      if (kind == "mount") spec.marker = sim::FrameSharing::kShared;  // a mount change is a change of a shared marker
      std::optional<sim::Effect> injected;
      if (kind != "clean") {
        const bool joint_effect = kind == "compliance" || kind == "cyclic" || kind == "scale" || kind == "backlash";
        std::uniform_int_distribution<std::size_t> pick(0, loaded.size() - 1);
        const int j = kind == "compliance" ? loaded[pick(rng)] : joint(rng);
        injected = sim::parseEffect(joint_effect ? kind + ":" + std::to_string(j + 1) : kind, arm.numJoints(), "study");
        spec.effects = {*injected};
        Eigen::VectorXd values(0);
        for (const sim::ParamBlock& b : sim::effectBlocks(*injected, spec.sessions)) {
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
      const std::string miss = (injected ? sim::formatEffect(*injected) : std::string("clean")) + " -> " + (d.clean ? "clean" : named);
      if (d.clean) {
        ++row.clean_verdict;
        if (injected) row.misses.push_back(miss);
      } else if (injected) {
        const auto same = [&](const sim::Effect& e) { return sim::formatEffect(e) == sim::formatEffect(*injected); };
        const auto kindOnly = [&](const sim::Effect& e) { return sim::effectName(e) == kind; };
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

}  // namespace orbcal::tools
