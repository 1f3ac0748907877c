// The repeated-run presets: table5 (noise levels), fig8 (identification set size), floor.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <sstream>

#include "orbcal/workflow/experiment.hpp"
#include "orbcal/workflow/report_html.hpp"
#include "orbcal/calib/synthetic.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::workflow {

namespace {

std::string fmt(const char* f, double v) { return formatNumber(f, v); }

struct Setup {
  sim::Arm nominal;
  sim::Scene scene;
  sim::TrueArm truth;      ///< the plant: DH errors, and the effects of an error-set file
  Eigen::VectorXd y_true;  ///< its DH errors
};
Setup setup(const ExperimentOptions& o) {
  Setup s{sim::loadArm(o.robotSource()), sim::loadScene(o.scene), {}, {}};
  s.truth = sim::makeTrueArm(s.nominal, o.errors, "--errors");
  s.y_true = s.truth.geometryErrors();
  return s;
}

std::vector<Eigen::VectorXd> generate(const Setup& s, int count, std::uint64_t seed) {
  sim::GeneratorSettings g;
  g.count = count;
  g.seed = seed;
  return sim::generateConfigurations(s.nominal, s.scene, g);
}

/// Repetition r's validation plant: its own configurations and joint noise.
calib::PlantSamples validationPlant(const ExperimentOptions& o, const Setup& s, int r) {
  auto rng = sim::makeRng(o.seed + kValidationSeedOffset + r, 0x76616c6964ULL);
  return calib::simulatePlant(s.truth, generate(s, o.validation, o.seed + kValidationSeedOffset + r),
                              o.joint_noise_sigma_rad, rng);
}

std::vector<calib::MethodSpec> mainMethods(double joint_sigma) {
  const auto all = calib::comparisonMethods(joint_sigma);
  return {calib::findMethod(all, "LSE (paper)"), calib::findMethod(all, "EKF (paper)"), calib::findMethod(all, "EKF"),
          calib::findMethod(all, "LM")};
}

}  // namespace

void runTable5(const ExperimentOptions& o) {
  const Setup s = setup(o);
  sim::OutputFolder output(o.out + "/table5", "orbcal experiment");  // written as a whole
  const std::string& folder = output.path();
  struct Column {
    std::string name;
    double sp_m, so_rad;  // synthetic pose noise; images when sp < 0
  };
  const std::vector<Column> columns{{"0.01mm/0.01deg", 0.01e-3, 0.01 * sim::kDegToRad},
                                    {"0.01mm/0.5deg", 0.01e-3, 0.5 * sim::kDegToRad},
                                    {"0.3mm/0.01deg", 0.3e-3, 0.01 * sim::kDegToRad},
                                    {"0.3mm/0.5deg", 0.3e-3, 0.5 * sim::kDegToRad},
                                    {"images", -1.0, -1.0}};
  const auto methods = chosenMethods(o, mainMethods(o.joint_noise_sigma_rad));
  // (column, method) -> per-repetition average and extreme position error; pooled errors for plots.
  std::map<std::pair<std::string, std::string>, std::vector<std::pair<double, double>>> results;
  std::ostringstream rows, pooled;
  rows << "column,repetition,method,avg_position_mm,max_position_mm,floor_avg_mm\n";
  double floor_avg = 0.0;  // mean over repetitions; the same validation plants serve every column
  pooled << "model,sample,position_mm,x_deg,y_deg,z_deg\n";
  for (int r = 0; r < o.repetitions; ++r) {
    std::cerr << (o.quiet ? "" : "table5: repetition " + std::to_string(r + 1) + "/" + std::to_string(o.repetitions) + "\n");
    const calib::PlantSamples valid = validationPlant(o, s, r);
    floor_avg += calib::summarize(calib::poseErrors(s.truth, valid)).position_avg_m / o.repetitions;
    auto rng = sim::makeRng(o.seed + r, 0x7461626c6535ULL);
    const calib::PlantSamples ident =
        calib::simulatePlant(s.truth, generate(s, o.identification, o.seed + r), o.joint_noise_sigma_rad, rng);
    for (const Column& col : columns) {
      std::vector<calib::PoseObservation> obs;
      if (col.sp_m >= 0) {
        obs = calib::syntheticObservations(ident, col.sp_m, col.so_rad, rng);
      } else {
        obs = renderAndMeasure(o, "table5-ident", o.identification, o.seed + r).observations;
      }
      const calib::Comparison c = calib::compareMethods(s.nominal, s.truth, obs, valid, methods);
      for (const calib::MethodOutcome& m : c.methods) {
        results[{col.name, m.method.name}].emplace_back(m.summary.position_avg_m, m.summary.position_max_m);
        rows << col.name << "," << r << "," << m.method.name << "," << fmt("%.6f", m.summary.position_avg_m * 1e3) << ","
             << fmt("%.6f", m.summary.position_max_m * 1e3) << "," << fmt("%.6f", c.floor.position_avg_m * 1e3) << "\n";
        for (std::size_t k = 0; k < m.errors.position_m.size(); ++k) {
          const Eigen::Vector3d d = m.errors.orientation_rad[k] * sim::kRadToDeg;
          pooled << col.name << " " << m.method.name << "," << k << "," << fmt("%.6f", m.errors.position_m[k] * 1e3)
                 << "," << fmt("%.7f", d.x()) << "," << fmt("%.7f", d.y()) << "," << fmt("%.7f", d.z()) << "\n";
        }
      }
    }
  }
  sim::writeFileAtomic(folder + "/table5.csv", rows.str());
  sim::writeFileAtomic(folder + "/validation_errors.csv", pooled.str());
  std::ostringstream md;
  md << "# Table 5: position error after calibration at four measurement-noise levels, and from images\n\n"
     << "Wang et al. 2023's Table 5 (synthetic pose noise, 0.01 deg control noise, " << o.identification << " identification + "
     << o.validation << " validation configurations) with " << o.repetitions
     << " repetitions instead of the paper's single runs, and a fifth column measured from rendered images. "
     << "Each cell: mean over repetitions of the average (and of the extreme) validation position error, mm; "
     << "+- the standard deviation over repetitions.\n\n" << injectedEffects(s.truth, o.errors.name) << "| method |";
  for (const Column& c : columns) md << " " << c.name << " avg | ext |";
  md << "\n|---|";
  for (std::size_t i = 0; i < columns.size(); ++i) md << "---|---|";
  md << "\n";
  for (const auto& m : methods) {
    md << "| " << m.name << " |";
    for (const Column& c : columns) {
      std::vector<double> averages, extremes;
      for (const auto& [a, e] : results[{c.name, m.name}]) {
        averages.push_back(a);
        extremes.push_back(e);
      }
      const auto [avg, sd] = meanAndStd(averages);
      md << " " << fmt("%.3f", avg * 1e3) << " +- " << fmt("%.3f", sd * 1e3) << " | " << fmt("%.3f", meanAndStd(extremes).first * 1e3)
         << " |";
    }
    md << "\n";
  }
  md << "| floor (true parameters) |";
  for (std::size_t i = 0; i < columns.size(); ++i) md << " " << fmt("%.3f", floor_avg * 1e3) << " | |";
  md << "\n\nWang et al. 2023's single-run values for reference: LSE 1.9356/5.8736, 3.1832/8.3625, 1.4362/6.0831, "
        "4.7239/13.5341; EKF 1.9463/5.9541, 1.9687/6.0528, 1.8125/6.6727, 2.4368/7.3659 (avg/ext, mm).\n\n"
     << drawFigure(o, folder, "boxplot " + shellQuote(folder + "/validation_errors.csv"), "validation_boxplot.png",
                   "validation errors")
     << "\nFiles: `table5.csv` (every repetition), `validation_errors.csv` (pooled validation errors).\n";
  writeReport(folder, md.str());
  output.commit();
  std::cout << md.str();
}

void runFig8(const ExperimentOptions& o) {
  const Setup s = setup(o);
  sim::OutputFolder output(o.out + "/fig8", "orbcal experiment");  // written as a whole
  const std::string& folder = output.path();
  const int n_max = std::max(10, o.identification);
  const auto methods = chosenMethods(o, mainMethods(o.joint_noise_sigma_rad));
  std::ostringstream rows;
  rows << "method,n,repetition,avg_position_mm,max_position_mm,floor_mm\n";
  std::map<std::pair<std::string, int>, std::vector<double>> avg;
  for (int r = 0; r < o.repetitions; ++r) {
    std::cerr << (o.quiet ? "" : "fig8: repetition " + std::to_string(r + 1) + "/" + std::to_string(o.repetitions) + "\n");
    const calib::PlantSamples valid = validationPlant(o, s, r);
    // One pool of n_max identification samples per repetition; set size n uses its first n
    // (rendered once, reused for every n: nested subsets of one honest sample).
    std::vector<calib::PoseObservation> pool;
    if (o.source == "images") {
      pool = renderAndMeasure(o, "fig8-pool", n_max, o.seed + r).observations;
    } else {
      auto rng = sim::makeRng(o.seed + r, 0x66696738ULL);
      const calib::PlantSamples ident = calib::simulatePlant(s.truth, generate(s, n_max, o.seed + r), o.joint_noise_sigma_rad, rng);
      pool = calib::syntheticObservations(ident, 0.3e-3, 0.5 * sim::kDegToRad, rng);  // the paper's noise
    }
    const double floor = calib::summarize(calib::poseErrors(s.truth, valid)).position_avg_m;
    for (int n = 10; n <= n_max && n <= static_cast<int>(pool.size()); n += 10) {
      const std::vector<calib::PoseObservation> obs(pool.begin(), pool.begin() + n);
      const calib::Comparison c = calib::compareMethods(s.nominal, s.truth, obs, valid, methods);
      for (const calib::MethodOutcome& m : c.methods) {
        avg[{m.method.name, n}].push_back(m.summary.position_avg_m);
        rows << m.method.name << "," << n << "," << r << "," << fmt("%.6f", m.summary.position_avg_m * 1e3) << ","
             << fmt("%.6f", m.summary.position_max_m * 1e3) << "," << fmt("%.6f", floor * 1e3) << "\n";
      }
    }
  }
  sim::writeFileAtomic(folder + "/fig8.csv", rows.str());
  std::ostringstream md;
  md << "# Fig. 8: validation position error against the identification set size\n\n"
     << "Measurements: " << (o.source == "images" ? "rendered images" : "synthetic poses, 0.3 mm / 0.5 deg")
     << "; " << o.repetitions << " repetitions; mean of the average validation position error (mm) over them.\n\n"
     << injectedEffects(s.truth, o.errors.name)
     << "| n |";
  for (const auto& m : methods) md << " " << m.name << " |";
  md << "\n|---|";
  for (std::size_t i = 0; i < methods.size(); ++i) md << "---|";
  md << "\n";
  for (int n = 10; n <= n_max; n += 10) {
    md << "| " << n << " |";
    for (const auto& m : methods) {
      const auto& v = avg[{m.name, n}];
      double mean = 0;
      for (double x : v) mean += x / v.size();
      md << " " << (v.empty() ? std::string("-") : fmt("%.3f", mean * 1e3)) << " |";
    }
    md << "\n";
  }
  md << "\n" << drawFigure(o, folder, "curve " + shellQuote(folder + "/fig8.csv"), "fig8.png", "validation error against set size")
     << "\nFile: `fig8.csv` (every run).\n";
  writeReport(folder, md.str());
  output.commit();
  std::cout << md.str();
}

void runFloor(const ExperimentOptions& o) {
  const Setup s = setup(o);
  sim::OutputFolder output(o.out + "/floor", "orbcal experiment");  // written as a whole
  const std::string& folder = output.path();
  std::ostringstream rows, md;
  rows << "repetition,avg_position_mm,max_position_mm,avg_x_deg,avg_y_deg,avg_z_deg\n";
  double mean = 0, worst = 0;
  for (int r = 0; r < o.repetitions; ++r) {
    const calib::ErrorSummary f = calib::summarize(calib::poseErrors(s.truth, validationPlant(o, s, r)));
    mean += f.position_avg_m / o.repetitions;
    worst = std::max(worst, f.position_max_m);
    const Eigen::Vector3d d = f.orientation_avg_rad * sim::kRadToDeg;
    rows << r << "," << fmt("%.6f", f.position_avg_m * 1e3) << "," << fmt("%.6f", f.position_max_m * 1e3) << ","
         << fmt("%.7f", d.x()) << "," << fmt("%.7f", d.y()) << "," << fmt("%.7f", d.z()) << "\n";
  }
  sim::writeFileAtomic(folder + "/floor.csv", rows.str());
  md << "# Floor: the validation error the control noise alone leaves\n\n"
     << "The true parameters, " << o.validation << " validation configurations, joint control noise "
     << fmt("%.4g", o.joint_noise_sigma_rad * sim::kRadToDeg) << " deg (1 sigma), " << o.repetitions
     << " repetitions: no estimator can do better on average.\n\n" << injectedEffects(s.truth, o.errors.name)
     << "- mean of the average position error: **" << fmt("%.4f", mean * 1e3) << " mm**\n"
     << "- largest position error seen: " << fmt("%.4f", worst * 1e3) << " mm\n\nFile: `floor.csv`.\n";
  writeReport(folder, md.str());
  output.commit();
  std::cout << md.str();
}

}  // namespace orbcal::workflow
