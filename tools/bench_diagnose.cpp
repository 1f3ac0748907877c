// `orbcal-bench diagnose`: the wall time of calib::diagnose on the real KUKA iiwa7 runs (both runs and
// the 0 kg run alone; from ../shared/data/iiwa7 beside the project, said so when absent) and on
// seeded simulated iiwa7 data of growing size (how the time grows with the samples). With --baseline
// every dataset is also diagnosed with every fold refitted to convergence with full fits
// (DiagnoseOptions::lean_fits and one_step_folds off) in the same run, and the verdicts are compared.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <stdexcept>

#include "bench.hpp"
#include "orbcal/calib/diagnose.hpp"
#include "orbcal/calib/measured_fit.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/model.hpp"
#include "orbcal/sim/simulate.hpp"

namespace orbcal::tools {

namespace {

struct DiagnoseBenchOptions {
  std::vector<int> samples{200, 400, 800, 1600};
  int repeats = 1;
  int seeds = 1;                  ///< simulated datasets per size (seeds 1..N)
  bool real = true;               ///< the iiwa7 runs, where the data is present
  bool baseline = false;          ///< also the full-fit path, verdicts compared
  std::string inject = "compliance:2,4";  ///< hidden in the simulated data ("" for clean data)
};

void printDiagnoseHelp(std::ostream& os) {
  os << "orbcal-bench diagnose [options]: seconds per calib::diagnose run (median of --repeats) and the verdict.\n"
        "  --samples LIST  simulated iiwa7 samples, comma-separated (default 200,400,800,1600; 0: none)\n"
        "  --seeds N       simulated datasets per size, seeds 1..N (default 1)\n"
        "  --repeats N     runs per dataset (default 1)\n"
        "  --inject SPEC   effect hidden in the simulated data (default compliance:2,4; 'none': clean)\n"
        "  --no-real       skip the real iiwa7 runs (scenes/iiwa7_measurements.yaml)\n"
        "  --baseline      also diagnose with every fold refitted to convergence, with full fits, and\n"
        "                  compare the verdicts\n"
        "Simulated data: two sessions (0 and 1.25 kg), the tracker noise stated as the simulation's.\n";
}

/// The decision of a diagnosis in one line: the selected effects (or clean) and what is left.
std::string decision(const calib::Diagnosis& d) {
  std::string s = d.clean ? "clean" : "";
  for (const sim::Effect& e : d.selected) s += (s.empty() ? "" : " ") + sim::formatEffect(e);
  if (d.unexplained) s += s.empty() ? "unexplained" : " + unexplained";
  return s.empty() ? "(nothing selected)" : s;
}

void timeOne(const std::string& name, const sim::MeasuredData& data, const DiagnoseBenchOptions& o) {
  const std::vector<calib::MarkerObservation> obs = calib::observationsFrom(data, data.has_torque || !data.arm.masses.empty());
  const auto run = [&](bool lean, calib::Diagnosis& last) {
    calib::DiagnoseOptions d;
    d.lean_fits = lean;
    d.one_step_folds = lean;
    return timeRepeats(o.repeats, [&] { last = calib::diagnose(data, obs, d); });
  };
  calib::Diagnosis fast;
  const std::vector<double> t = run(true, fast);
  printFigure(name + ", " + std::to_string(obs.size()) + " samples", t, "s ", 1.0, "");
  std::printf("    verdict: %s\n", decision(fast).c_str());
  if (!o.baseline) return;
  calib::Diagnosis full;
  const std::vector<double> tb = run(false, full);
  printFigure("  baseline (every fold refitted, full fits)", tb, "s ", 1.0, "");
  const bool same = decision(full) == decision(fast) && full.verdict == fast.verdict;
  std::printf("    baseline verdict: %s  [%s; %.1fx faster]\n", decision(full).c_str(), same ? "same" : "DIFFERENT",
              tb[tb.size() / 2] / t[t.size() / 2]);
  if (!same) std::printf("    lean:     %s\n    baseline: %s\n", fast.verdict.c_str(), full.verdict.c_str());
}

/// The first session's samples alone.
sim::MeasuredData firstSession(const sim::MeasuredData& data) {
  sim::MeasuredData one = data;
  one.files.resize(1);
  one.poses.clear();
  for (const sim::MeasuredPose& p : data.poses) {
    if (p.sample.session == 0) one.poses.push_back(p);
  }
  return one;
}

void benchReal(const DiagnoseBenchOptions& o) {
  const std::string yaml = std::string(ORBCAL_SOURCE_DIR) + "/scenes/iiwa7_measurements.yaml";
  const std::filesystem::path csv = std::filesystem::path(ORBCAL_SOURCE_DIR) / "../shared/data/iiwa7/run1_0kg.csv";
  if (!std::filesystem::exists(csv)) {
    std::printf("  real iiwa7 runs: skipped, %s is absent\n", csv.lexically_normal().c_str());
    return;
  }
  const sim::MeasuredData data = sim::loadMeasuredData(yaml);
  timeOne("real iiwa7, both runs", data, o);
  timeOne("real iiwa7, run 1 (0 kg) alone", firstSession(data), o);
}

void benchSimulated(const DiagnoseBenchOptions& o) {
  const sim::Arm arm = sim::loadArm(std::string(ORBCAL_SOURCE_DIR) + "/scenes/iiwa7.yaml");
  for (const int n : o.samples) {
    for (int seed = 1; seed <= o.seeds; ++seed) {
      sim::SimulationSpec spec;
      spec.samples = n;
      spec.sessions = 2;
      spec.payload_kg = {0.0, 1.25};
      spec.seed = static_cast<std::uint64_t>(seed);
      if (o.inject != "none" && !o.inject.empty()) spec.effects = {sim::parseEffect(o.inject, arm.numJoints(), "--inject")};
      const sim::SimulatedData s = sim::simulateMeasured(arm, spec);
      timeOne("simulated iiwa7 (" + (spec.effects.empty() ? std::string("clean") : o.inject) + ", seed " + std::to_string(seed) + ")",
              s.data, o);
    }
  }
}

std::vector<int> parseSizes(const std::string& text) {
  std::vector<int> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) {
    const int v = std::stoi(item);
    if (v < 0 || v > 100000) throw std::invalid_argument("diagnose: --samples: out of range: " + item);
    if (v > 0) out.push_back(v);
  }
  return out;
}

int benchDiagnose(int argc, char** argv) {
  DiagnoseBenchOptions o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument("diagnose: " + a + " needs a value");
      return argv[++i];
    };
    if (a == "--help" || a == "-h") {
      printDiagnoseHelp(std::cout);
      return 0;
    } else if (a == "--samples") {
      o.samples = parseSizes(value());
    } else if (a == "--seeds") {
      o.seeds = std::max(1, std::stoi(value()));
    } else if (a == "--repeats") {
      o.repeats = std::max(1, std::stoi(value()));
    } else if (a == "--inject") {
      o.inject = value();
    } else if (a == "--no-real") {
      o.real = false;
    } else if (a == "--baseline") {
      o.baseline = true;
    } else {
      printDiagnoseHelp(std::cerr);
      throw std::invalid_argument("diagnose: unknown option " + a);
    }
  }
  std::printf("[diagnose]\n");
  if (o.real) benchReal(o);
  benchSimulated(o);
  return 0;
}

}  // namespace

ORBCAL_BENCH_WITH_OPTIONS("diagnose", benchDiagnose);

}  // namespace orbcal::tools
