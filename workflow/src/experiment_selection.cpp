// `orbcal experiment --preset selection`: configurations chosen from a pool by an observability index
// (Liu et al. 2012 choose by O3; O1 is D-optimal, Borm & Menq 1991) against random ones at equal
// counts, for every measurement kind, and in the main job's own setting (rendered images, 0.01 deg
// control noise), where the question is how close to the control-noise floor selection gets.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>

#include "orbcal/workflow/experiment.hpp"
#include "orbcal/workflow/report_html.hpp"
#include "orbcal/calib/observability.hpp"
#include "orbcal/calib/planning.hpp"
#include "orbcal/calib/relative_models.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::workflow {

namespace {

std::string fmt(const char* f, double v) { return formatNumber(f, v); }

constexpr int kCounts[] = {15, 25, 50};

/// How a subset of the pool is chosen: at random (the generator's own order is random, so the first n
/// are a random subset), or by maximising an observability index (calib::selectConfigurations).
struct Chooser {
  std::string name;
  std::optional<calib::ObservabilityIndex> index;
};
const std::vector<Chooser>& choosers() {
  static const std::vector<Chooser> c{{"random", std::nullopt}, {"O3", calib::ObservabilityIndex::kO3}, {"O1", calib::ObservabilityIndex::kO1}};
  return c;
}

/// n of the pool's samples (blocks from calib::observabilityBlocks), and the chosen set's indices.
std::vector<int> choose(const Chooser& c, const std::vector<Eigen::MatrixXd>& blocks, int n, std::uint64_t seed,
                        calib::ObservabilityIndices* indices) {
  std::vector<int> chosen;
  if (c.index) {
    calib::SelectionOptions so;
    so.index = *c.index;
    so.seed = seed;
    const calib::Selection s = calib::selectConfigurations(blocks, n, so);
    chosen = s.chosen;
    *indices = s.indices;
  } else {
    for (int k = 0; k < n; ++k) chosen.push_back(k);
    *indices = calib::observabilityIndices(calib::stackBlocks(blocks, chosen), n);
  }
  return chosen;
}

std::vector<Eigen::VectorXd> generate(const sim::Arm& arm, const sim::Scene& scene, int count, std::uint64_t seed) {
  sim::GeneratorSettings g;
  g.count = count;
  g.seed = seed;
  return sim::generateConfigurations(arm, scene, g);
}

/// For a relative kind, the configuration each pair of the planning model measures against the
/// reference (pool[0]); for the others, the identity.
std::vector<int> sampleConfigurations(const calib::MeasurementModel& model, calib::MeasurementKind kind,
                                      const std::vector<Eigen::VectorXd>& pool) {
  std::vector<int> out;
  if (!calib::isRelativeKind(kind)) {
    for (int k = 0; k < model.numSamples(); ++k) out.push_back(k);
    return out;
  }
  const auto& relative = dynamic_cast<const calib::RelativePoseModel&>(model);
  std::size_t j = 1;
  for (const calib::RelativeObservation& o : relative.observations()) {
    while (j < pool.size() && pool[j] != o.b.q_rad) ++j;  // pairs keep the pool's order; the guard may skip some
    out.push_back(static_cast<int>(j++));
  }
  return out;
}

struct SyntheticRow {
  std::string kind, chooser;
  int n = 0, repetition = 0;
  calib::ObservabilityIndices indices;
  double validation_avg_m = 0.0;
};

/// Part 1: every pose kind on the scene's arm, synthetic measurements.
std::vector<SyntheticRow> syntheticPart(const ExperimentOptions& o, const sim::Arm& nominal, const sim::Scene& scene,
                                        const Eigen::VectorXd& y_true, const calib::MeasurementSetup& base, int pool_size) {
  const std::vector<calib::MeasurementKind> kinds{calib::MeasurementKind::kPose, calib::MeasurementKind::kPosition,
                                                  calib::MeasurementKind::kDistanceRotation};
  const sim::KinematicModel km = sim::flangeModel(nominal);
  const sim::Arm true_arm = calib::calibratedArm(nominal, y_true);
  std::vector<SyntheticRow> rows;
  Progress bar(o.callbacks.progress, o.quiet ? "" : "selection: synthetic trials", o.quiet ? 0 : o.repetitions * static_cast<int>(kinds.size()));
  int done = 0;
  for (int r = 0; r < o.repetitions; ++r) {
    const std::vector<Eigen::VectorXd> pool = generate(nominal, scene, pool_size + 1, o.seed + r);
    const std::vector<Eigen::VectorXd> valid = generate(nominal, scene, o.validation, o.seed + kValidationSeedOffset + r);
    std::mt19937_64 no_noise;  // the validation plant: true joints = commanded (measurement noise only, no control noise)
    const calib::PlantSamples plant = calib::simulatePlant(true_arm, valid, 0.0, no_noise);
    for (calib::MeasurementKind kind : kinds) {
      calib::MeasurementSetup setup = base;
      setup.kind = kind;
      // The relative kinds pair every configuration with pool[0]; the absolute ones use pool[1..].
      std::vector<Eigen::VectorXd> candidates = pool;
      if (!calib::isRelativeKind(kind)) candidates.erase(candidates.begin());
      const auto planning = calib::planningModel(setup, km, calib::samplesOf(candidates));
      const Eigen::VectorXd zero = Eigen::VectorXd::Zero(planning->numParams());
      const std::vector<int> held = calib::unidentifiableToFix(*planning, zero);
      const auto blocks = calib::observabilityBlocks(*planning, zero, held);
      const std::vector<int> config_of = sampleConfigurations(*planning, kind, candidates);
      for (int n : kCounts) {
        for (std::size_t c = 0; c < choosers().size(); ++c) {
          SyntheticRow row;
          row.kind = calib::measurementKindName(kind);
          row.chooser = choosers()[c].name;
          row.n = n;
          row.repetition = r;
          const std::vector<int> chosen = choose(choosers()[c], blocks, n, o.seed + r, &row.indices);
          std::vector<Eigen::VectorXd> configs;
          if (calib::isRelativeKind(kind)) configs.push_back(candidates[0]);
          for (int k : chosen) configs.push_back(candidates[static_cast<std::size_t>(config_of[static_cast<std::size_t>(k)])]);
          std::mt19937_64 rng = sim::makeRng(o.seed + r, 0x73656c656374ULL + 1000 * static_cast<std::uint64_t>(kind) + 10 * n + c);
          const auto poses = calib::simulatePoses(km, y_true, calib::samplesOf(configs), 0.0, setup.noise, rng);
          const auto model = calib::modelFromPoses(setup, km, poses);
          calib::LseOptions lse;
          lse.weighted = true;
          const calib::Estimate e = calib::runLse(*model, lse);
          const Eigen::VectorXd y = e.y.head(nominal.numParams());
          row.validation_avg_m = calib::summarize(calib::poseErrors(calib::calibratedArm(nominal, y), plant)).position_avg_m;
          rows.push_back(row);
        }
      }
      bar.update(++done);
    }
  }
  bar.finish();
  return rows;
}

/// Part 1b: the range kind on Liu et al. 2012's setting: the PUMA-like arm of scenes/puma_hayati.yaml,
/// the plane y + 4.6 z - 0.69 = 0 (its coefficient 4.6 off by 0.005 in the plant), a ranger of 0.2 mm
/// averaged over 10 readings, thermal length errors and 3.49 mrad angle errors (calib/range_experiment.hpp).
std::vector<SyntheticRow> rangePart(const ExperimentOptions& o, int pool_size) {
  const sim::Arm arm = sim::loadArm("builtin:puma_hayati.yaml");
  const sim::KinematicModel km = sim::flangeModel(arm);
  calib::MeasurementSetup setup;
  setup.kind = calib::MeasurementKind::kRange;
  const calib::PlaneRangeModel probe(km, setup.beam, setup.plane, {});
  std::vector<SyntheticRow> rows;
  Progress bar(o.callbacks.progress, o.quiet ? "" : "selection: range trials", o.quiet ? 0 : o.repetitions);
  for (int r = 0; r < o.repetitions; ++r) {
    Eigen::VectorXd p_true = Eigen::VectorXd::Zero(probe.numParams());
    p_true.head(arm.numParams()) = sim::thermalErrors(arm, 3.49e-3, 1e-3, o.seed + r);
    p_true.tail(1)[0] = 0.005;  // the plane coefficient c: 4.6 in the model, 4.605 in the plant
    auto pool_rng = sim::makeRng(o.seed + r, 0x72616e6765ULL);
    const std::vector<sim::JointSample> pool = calib::rangeConfigurations(probe, {}, pool_size, pool_rng);
    calib::RangeConfigurationSettings anywhere;
    anywhere.beam_must_hit = false;
    auto valid_rng = sim::makeRng(o.seed + kValidationSeedOffset + r, 0x72616e6765ULL);
    std::vector<Eigen::VectorXd> valid;
    for (const sim::JointSample& s : calib::rangeConfigurations(probe, {}, o.validation, valid_rng, anywhere)) valid.push_back(s.q_rad);
    std::mt19937_64 no_noise;
    const calib::PlantSamples plant = calib::simulatePlant(calib::calibratedArm(arm, p_true.head(arm.numParams())), valid, 0.0, no_noise);
    const auto planning = calib::planningModel(setup, km, pool);
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(planning->numParams());
    const auto blocks = calib::observabilityBlocks(*planning, zero, calib::unidentifiableToFix(*planning, zero));
    for (int n : kCounts) {
      for (std::size_t c = 0; c < choosers().size(); ++c) {
        SyntheticRow row;
        row.kind = "range";
        row.chooser = choosers()[c].name;
        row.n = n;
        row.repetition = r;
        std::vector<sim::JointSample> chosen;
        for (int k : choose(choosers()[c], blocks, n, o.seed + r, &row.indices)) chosen.push_back(pool[static_cast<std::size_t>(k)]);
        std::mt19937_64 rng = sim::makeRng(o.seed + r, 0x72616e676573ULL + 10 * n + c);
        const calib::PlaneRangeModel model(km, setup.beam, setup.plane,
                                           calib::simulateRanges(probe, p_true, chosen, setup.range_sigma_m, setup.range_repeats, rng));
        calib::LseOptions lse;
        lse.weighted = true;
        const Eigen::VectorXd y = calib::runLse(model, lse).y.head(arm.numParams());
        row.validation_avg_m = calib::summarize(calib::poseErrors(calib::calibratedArm(arm, y), plant)).position_avg_m;
        rows.push_back(row);
      }
    }
    bar.update(r + 1);
  }
  bar.finish();
  return rows;
}

struct RenderedRow {
  std::string chooser, method;
  int repetition = 0, used = 0;
  double o3 = 0.0, validation_avg_m = 0.0, floor_avg_m = 0.0;
};

/// Part 2: the main job's setting. One rendered pool per repetition; each chooser's n of it (chosen on
/// the nominal arm before anything is measured: an image that then shows no board is lost, as it would
/// be), every estimator, validated against the control-noise floor.
std::vector<RenderedRow> renderedPart(const ExperimentOptions& o, const sim::Arm& nominal, const sim::Scene& scene,
                                      const sim::TrueArm& truth, int pool_size) {
  const auto all = calib::comparisonMethods(o.joint_noise_sigma_rad);
  const std::vector<calib::MethodSpec> methods{calib::findMethod(all, "LSE (weighted)"), calib::findMethod(all, "EKF"),
                                               calib::findMethod(all, "LM")};
  calib::PoseNoiseModel planning_noise;  // about what the camera measures (docs: 0.078 mm, 0.011 deg), plus the control noise
  planning_noise.sigma_position_m = 0.1e-3;
  planning_noise.sigma_orientation_rad = 0.01 * sim::kDegToRad;
  planning_noise.joint_noise_sigma_rad = o.joint_noise_sigma_rad;
  std::vector<RenderedRow> rows;
  for (int r = 0; r < o.repetitions; ++r) {
    if (!o.quiet) std::cerr << "selection: rendered pool " << r + 1 << "/" << o.repetitions << "\n";
    const MeasuredSet pool = renderAndMeasure(o, "selection-pool", pool_size, o.seed + r);
    auto vrng = sim::makeRng(o.seed + kValidationSeedOffset + r, 0x76616c6964ULL);
    const calib::PlantSamples valid =
        calib::simulatePlant(truth, generate(nominal, scene, o.validation, o.seed + kValidationSeedOffset + r), o.joint_noise_sigma_rad, vrng);
    const std::vector<Eigen::VectorXd>& configs = pool.plant.q_commanded;
    const calib::MarkerPoseModel planning = calib::posePlanningModel(nominal, configs, planning_noise);
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(planning.numParams());
    const auto blocks = calib::observabilityBlocks(planning, zero, calib::unidentifiableToFix(planning, zero));
    for (const Chooser& c : choosers()) {
      calib::ObservabilityIndices indices;
      const std::vector<int> chosen = choose(c, blocks, o.identification, o.seed + r, &indices);
      std::vector<calib::PoseObservation> obs;
      for (int k : chosen) {
        const vision::Measurement& m = pool.measurements[static_cast<std::size_t>(k)];
        if (m.found()) obs.push_back({configs[static_cast<std::size_t>(k)], m.base_T_flange, m.covariance});
      }
      const calib::Comparison cmp = calib::compareMethods(nominal, truth, obs, valid, methods);
      for (const calib::MethodOutcome& m : cmp.methods) {
        rows.push_back({c.name, m.method.name, r, static_cast<int>(obs.size()), indices.o3, m.summary.position_avg_m,
                        cmp.floor.position_avg_m});
      }
    }
  }
  return rows;
}

}  // namespace

void runSelection(const ExperimentOptions& o) {
  sim::OutputFolder output(o.out + "/selection", "orbcal experiment");  // written as a whole
  const std::string& folder = output.path();
  const sim::Arm nominal = sim::loadArm(o.robotSource());
  const sim::Scene scene = sim::loadScene(o.scene);
  const sim::TrueArm truth = sim::makeTrueArm(nominal, o.errors, "--errors");
  const int synthetic_pool = 300, rendered_pool = 200;
  if (o.identification > rendered_pool) {
    throw sim::InputError("--ident: at most " + std::to_string(rendered_pool) + " (the rendered pool) for the selection preset");
  }
  // Synthetic part: the injected DH errors with joint 1's set to zero, as Jia et al. 2019 inject none
  // there: a frame-free measurement cannot see a rigid motion of the whole arm, and the kinds compare
  // on what each can see.
  Eigen::VectorXd y_true = truth.geometryErrors();
  const sim::ParamBlock geometry = sim::geometryBlock(nominal);
  for (int i = 0; i < geometry.size(); ++i) {
    if (geometry.params[static_cast<std::size_t>(i)].joint == 0) y_true[i] = 0.0;
  }
  calib::MeasurementSetup base;
  base.noise.sigma_position_m = 0.1e-3;
  base.noise.sigma_rotation_rad = 0.05 * sim::kDegToRad;
  std::vector<SyntheticRow> synthetic = syntheticPart(o, nominal, scene, y_true, base, synthetic_pool);
  const std::vector<SyntheticRow> range = rangePart(o, synthetic_pool);
  synthetic.insert(synthetic.end(), range.begin(), range.end());
  const auto rendered = renderedPart(o, nominal, scene, truth, rendered_pool);

  std::ostringstream csv, rcsv, curve;
  csv << "kind,n,chooser,repetition,o1,o3,avg_position_mm\n";
  curve << "method,n,repetition,avg_position_mm,max_position_mm,floor_mm\n";  // plot_report.py's curve layout
  std::map<std::tuple<std::string, int, std::string>, std::vector<double>> err, o3;
  for (const SyntheticRow& s : synthetic) {
    csv << s.kind << "," << s.n << "," << s.chooser << "," << s.repetition << "," << fmt("%.6g", s.indices.o1) << ","
        << fmt("%.6g", s.indices.o3) << "," << fmt("%.6f", s.validation_avg_m * 1e3) << "\n";
    curve << s.kind << " " << s.chooser << "," << s.n << "," << s.repetition << "," << fmt("%.6f", s.validation_avg_m * 1e3)
          << ",,\n";
    err[{s.kind, s.n, s.chooser}].push_back(s.validation_avg_m);
    o3[{s.kind, s.n, s.chooser}].push_back(s.indices.o3);
  }
  rcsv << "chooser,method,repetition,images_used,o3,avg_position_mm,floor_mm,x_floor\n";
  std::map<std::pair<std::string, std::string>, std::vector<double>> ratio;
  std::map<std::string, std::vector<double>> used, ro3;
  for (const RenderedRow& r : rendered) {
    rcsv << r.chooser << "," << r.method << "," << r.repetition << "," << r.used << "," << fmt("%.6g", r.o3) << ","
         << fmt("%.6f", r.validation_avg_m * 1e3) << "," << fmt("%.6f", r.floor_avg_m * 1e3) << ","
         << fmt("%.5f", r.validation_avg_m / r.floor_avg_m) << "\n";
    ratio[{r.chooser, r.method}].push_back(r.validation_avg_m / r.floor_avg_m);
    if (r.method == "LM") {
      used[r.chooser].push_back(r.used);
      ro3[r.chooser].push_back(r.o3);
    }
  }
  sim::writeFileAtomic(folder + "/synthetic.csv", csv.str());
  sim::writeFileAtomic(folder + "/synthetic_curve.csv", curve.str());
  sim::writeFileAtomic(folder + "/rendered.csv", rcsv.str());

  std::ostringstream md;
  md << "# Pose selection: configurations chosen by an observability index against random ones\n\n"
     << "Robot `" << o.robot << "`, scene `" << o.scene << "`, " << o.repetitions << " repetitions (seeds " << o.seed << ".."
     << o.seed + o.repetitions - 1 << "); each repetition draws its own pool and its own " << o.validation
     << " validation configurations. Chosen by: **random** (the first n of the generator's random order), **O3** "
        "(smallest singular value, Nahvi, Hollerbach & Hayward 1994; Liu et al. 2012's criterion; ties within 0.1% by "
        "log det), **O1** (D-optimal, Borm & Menq 1991): greedy start, DETMAX and pair exchanges "
        "(calib/observability.hpp) on the whitened Jacobian of the nominal arm, columns in typical magnitudes, before "
        "anything is measured.\n\n"
     << "## Every measurement kind (synthetic measurements)\n\n"
     << "Pool of " << synthetic_pool << " board-visible configurations. Injected errors `" << o.errors.name
     << "` with joint 1's set to zero (as Jia et al. 2019: a frame-free measurement cannot see a rigid motion of the "
        "whole arm). Pose noise " << fmt("%.3g", base.noise.sigma_position_m * 1e3) << " mm / "
     << fmt("%.3g", base.noise.sigma_rotation_rad * sim::kRadToDeg)
     << " deg per axis (dr: between pairs, sqrt 2 of it per pair, every pair against one reference configuration); no "
        "control noise. Identified by iterated weighted least squares (Gauss-Newton, pseudo-inverse, the unidentifiable "
        "parameters held). The range kind is Liu et al. 2012's setting instead: the PUMA-like arm of "
        "`scenes/puma_hayati.yaml`, the plane y + 4.6 z - 0.69 = 0 (4.605 in the plant, c identified), a laser ranger of "
        "0.2 mm averaged over 10 readings, thermal length errors (1 mm per metre) and 3.49 mrad angle errors, a pool of "
     << synthetic_pool << " configurations whose beam meets the plane, validation anywhere in the workspace. Cell: mean +- std "
        "over repetitions of the average validation position error (mm); n is the number of measurements "
        "(configurations, or pairs).\n\n"
     << "| kind | n | random | O3 | O1 | gain O3 | gain O1 | O3 index: random / O3 / O1 |\n|---|---|---|---|---|---|---|---|\n";
  for (const std::string kind : {"pose", "position", "dr", "range"}) {
    for (int n : kCounts) {
      const auto [rm, rs] = meanAndStd(err[{kind, n, "random"}]);
      const auto [sm, ss] = meanAndStd(err[{kind, n, "O3"}]);
      const auto [dm, ds] = meanAndStd(err[{kind, n, "O1"}]);
      md << "| " << kind << " | " << n << " | " << fmt("%.3f", rm * 1e3) << " +- " << fmt("%.3f", rs * 1e3) << " | "
         << fmt("%.3f", sm * 1e3) << " +- " << fmt("%.3f", ss * 1e3) << " | " << fmt("%.3f", dm * 1e3) << " +- "
         << fmt("%.3f", ds * 1e3) << " | " << fmt("%+.0f%%", 100.0 * (rm - sm) / rm) << " | "
         << fmt("%+.0f%%", 100.0 * (rm - dm) / rm) << " | " << fmt("%.3g", meanAndStd(o3[{kind, n, "random"}]).first) << " / "
         << fmt("%.3g", meanAndStd(o3[{kind, n, "O3"}]).first) << " / " << fmt("%.3g", meanAndStd(o3[{kind, n, "O1"}]).first)
         << " |\n";
    }
  }
  md << "\n(gain: the validation error selection saves against random sets of the same size. A range is one number per "
        "configuration: at 15 and 25 the set is smaller than the 26 parameters the range identifies, every O3 is 0 and "
        "the estimate is least squares' minimum-norm one.)\n\n"
     << drawFigure(o, folder, "curve " + shellQuote(folder + "/synthetic_curve.csv"), "synthetic.png",
                   "validation error against the number of measurements, per kind and chooser")
     << "\n## The main job's setting: rendered images, " << fmt("%.3g", o.joint_noise_sigma_rad * sim::kRadToDeg)
     << " deg control noise\n\n"
     << "Per repetition one pool of " << rendered_pool << " board-visible configurations is rendered and measured; each "
        "chooser takes " << o.identification << " of it (planned with 0.1 mm / 0.01 deg pose noise plus the control noise; "
        "an image whose board the true arm moves out of view is lost). Injected errors `" << o.errors.name
     << "` (all joints). Cell: mean +- std over repetitions of the average validation position error over the floor "
        "(the error the control noise alone leaves with the true parameters: 1.00 is perfect).\n\n"
     << "| chosen by | images used | O3 | LSE (weighted) | EKF | LM |\n|---|---|---|---|---|---|\n";
  for (const Chooser& c : choosers()) {
    md << "| " << c.name << " | " << fmt("%.1f", meanAndStd(used[c.name]).first) << " | " << fmt("%.3g", meanAndStd(ro3[c.name]).first)
       << " |";
    for (const char* m : {"LSE (weighted)", "EKF", "LM"}) {
      const auto [mm, ms] = meanAndStd(ratio[{c.name, m}]);
      md << " " << fmt("%.3f", mm) << " +- " << fmt("%.3f", ms) << " |";
    }
    md << "\n";
  }
  md << "\nFiles: `synthetic.csv`, `synthetic_curve.csv`, `rendered.csv` (every trial).\n";
  writeReport(folder, md.str());
  output.commit();
  std::cout << md.str();
}

}  // namespace orbcal::workflow
