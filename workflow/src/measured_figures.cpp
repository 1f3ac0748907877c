#include "measured_figures.hpp"

#include <cmath>
#include <sstream>

#include "orbcal/calib/lack_of_fit.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/workflow/measured.hpp"

namespace orbcal::workflow::measured_detail {

NoiseFloor noiseFloor(const calib::Fit& fit, const std::vector<calib::MarkerObservation>& held,
                      const std::vector<Eigen::VectorXd>& after) {
  NoiseFloor floor;
  floor.position_m = std::sqrt(calib::heldoutNoise(fit, held, fit.noise, after, 1).position_ms_m2);
  floor.rotation_rad = std::sqrt(3.0) * fit.noise.sigma_rotation_rad;
  return floor;
}

namespace {

/// heldout.csv: one row per held-out sample, in mm and deg.
std::string heldoutCsv(const std::vector<calib::MarkerObservation>& held, const std::vector<Eigen::VectorXd>& before,
                       const std::vector<Eigen::VectorXd>& after, const NoiseFloor& floor) {
  std::ostringstream csv;
  csv << "sample,session,before_mm,after_mm,floor_mm,before_deg,after_deg,floor_deg\n";
  for (std::size_t k = 0; k < held.size(); ++k) {
    csv << k << "," << held[k].sample.session << "," << before[k].head<3>().norm() * 1e3 << ","
        << after[k].head<3>().norm() * 1e3 << "," << floor.position_m * 1e3;
    if (held[k].has_rotation && after[k].size() >= 6) {
      csv << "," << before[k].tail<3>().norm() * sim::kRadToDeg << "," << after[k].tail<3>().norm() * sim::kRadToDeg << ","
          << floor.rotation_rad * sim::kRadToDeg << "\n";
    } else {
      csv << ",,,\n";
    }
  }
  return csv.str();
}

}  // namespace

std::string measuredFigures(const Callbacks& callbacks, bool plots, const std::string& out, const calib::Fit& fit,
                            const std::vector<calib::MarkerObservation>& held, const std::vector<Eigen::VectorXd>& before,
                            const std::vector<Eigen::VectorXd>& after, bool accepted) {
  std::string figures;
  if (!held.empty()) {
    sim::writeFileAtomic(out + "/heldout.csv", heldoutCsv(held, before, after, noiseFloor(fit, held, after)));
    figures += drawFigure(callbacks, plots, out, "heldout " + shellQuote(out + "/heldout.csv"), "heldout.png",
                          "held-out error per sample, nominal arm and calibrated, with the noise floor");
  }
  if (!accepted) return figures;
  sim::writeFileAtomic(out + "/estimates.csv", estimatesCsv(fit));
  if (plots || held.empty()) {  // one --no-plots line is enough
    figures += drawFigure(callbacks, plots, out, "parameters " + shellQuote(out + "/estimates.csv"), "parameters.png",
                          "parameter estimates with their 1-sigma");
  }
  return figures;
}

}  // namespace orbcal::workflow::measured_detail
