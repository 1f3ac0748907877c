// Measured data: the LM fit of geometry + registration + compliance on 200 simulated tracker samples
// (iiwa7, two sessions, unknown frames), from the closed-form start; geometry + registration alone as
// the baseline of the same run.
#include <algorithm>
#include <chrono>

#include "bench.hpp"
#include "orbcal/calib/diagnose.hpp"
#include "orbcal/calib/measured_fit.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/simulate.hpp"

namespace orbcal::tools {

namespace {

void benchMeasured() {
  const sim::Arm arm = sim::loadArm(std::string(ORBCAL_SOURCE_DIR) + "/scenes/iiwa7.yaml");
  sim::SimulationSpec spec;
  spec.samples = 200;
  spec.sessions = 2;
  spec.payload_kg = {0.0, 1.25};
  spec.effects = {sim::Compliance{{1, 3}}};
  const sim::SimulatedData s = sim::simulateMeasured(arm, spec);
  const auto timed = [&](const std::string& name, const std::vector<sim::Effect>& effects, const std::string& target) {
    const std::vector<calib::MarkerObservation> obs = calib::observationsFrom(s.data, calib::needsTorque(effects));
    std::vector<double> t;
    for (int i = 0; i < 11; ++i) {
      const auto t0 = std::chrono::steady_clock::now();
      calib::FitOptions o;
      o.sigma_position_m = s.data.noise_position_m;
      o.sigma_rotation_rad = s.data.noise_rotation_rad;
      calib::fitMarkerModel(calib::startingModel(s.data, obs, effects), obs, o);
      t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    std::sort(t.begin(), t.end());
    printFigure(name, t, "ms", 1e3, target);
  };
  timed("LM fit, geometry + registration (baseline), 200 tracker samples", {}, "");
  timed("LM fit, geometry + registration + compliance:2,4, 200 tracker samples", {sim::Compliance{{1, 3}}}, "< 500 ms");

  // orbcal diagnose on 200 samples: clean data (the usual case) and data hiding compliance:2,4.
  const auto diagnoseTimed = [&](const std::string& name, const sim::SimulatedData& data) {
    const std::vector<calib::MarkerObservation> obs = calib::observationsFrom(data.data, true);
    std::vector<double> t;
    for (int i = 0; i < 3; ++i) t.push_back(calib::diagnose(data.data, obs, {}).seconds);
    std::sort(t.begin(), t.end());
    printFigure(name, t, "s ", 1.0, "< 10 s");
  };
  sim::SimulationSpec clean = spec;
  clean.effects.clear();
  diagnoseTimed("diagnose, 200 tracker samples, clean (5 folds, 2 threads)", sim::simulateMeasured(arm, clean));
  diagnoseTimed("diagnose, 200 tracker samples hiding compliance:2,4", s);
}

}  // namespace

ORBCAL_BENCH("measured", benchMeasured);

}  // namespace orbcal::tools
