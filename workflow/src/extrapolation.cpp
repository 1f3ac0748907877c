// Where an evaluated model extrapolates, and how far its confounded alternatives part from it there.
#include "extrapolation.hpp"

#include <cmath>
#include <sstream>

#include "orbcal/calib/marker_model.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/model_io.hpp"

namespace orbcal::workflow::extrapolation {

bool beyond(const std::vector<sim::RangeExcess>& excess, std::size_t i) {
  for (const sim::RangeExcess& x : excess) {
    if (x.excess[i] > 0.0) return true;
  }
  return false;
}

std::vector<AlternativePrediction> compareAlternatives(const std::vector<std::string>& alternatives, const sim::MeasuredData& data,
                                                       const std::vector<calib::MarkerObservation>& obs, const calib::FitOptions& fo,
                                                       const calib::Fit& model, const std::vector<sim::RangeExcess>& excess) {
  std::vector<AlternativePrediction> out;
  for (const std::string& path : alternatives) {
    const sim::LoadedModel alt = sim::loadModelFile(path);
    if (alt.model.arm.numJoints() != data.arm.numJoints()) throw sim::InputError(path + ": robot: not the evaluated model's arm");
    const calib::Fit fit = calib::predictWithModel({alt.model, alt.p}, data, obs, fo);
    AlternativePrediction a;
    a.path = path;
    for (const sim::Effect& e : alt.model.effects) a.effects += (a.effects.empty() ? "" : " ") + sim::formatEffect(e);
    a.residuals = fit.residuals;
    double ss_beyond = 0.0, ss_within = 0.0;
    for (std::size_t i = 0; i < obs.size(); ++i) {
      // Both residuals are the measurement minus a prediction: their difference is the predictions' (position).
      const Eigen::VectorXd r = calib::markerResidual(model.model, model.p, obs[i]);
      const Eigen::VectorXd q = calib::markerResidual(fit.model, fit.p, obs[i]);
      const double d = (r.head<3>() - q.head<3>()).norm();
      a.divergence_m.push_back(d);
      if (beyond(excess, i)) {
        ++a.beyond;
        ss_beyond += d * d;
        a.beyond_max_m = std::max(a.beyond_max_m, d);
      } else {
        ss_within += d * d;
      }
    }
    const auto within = static_cast<double>(obs.size()) - a.beyond;
    a.beyond_rms_m = a.beyond > 0 ? std::sqrt(ss_beyond / a.beyond) : 0.0;
    a.within_rms_m = within > 0 ? std::sqrt(ss_within / within) : 0.0;
    out.push_back(std::move(a));
  }
  return out;
}

std::string csvHeader(const EvaluateResult& r) {
  std::string h = ",beyond_range";
  for (std::size_t k = 0; k < r.alternatives.size(); ++k) h += ",alternative" + std::to_string(k + 1) + "_mm";
  return h;
}

std::string csvCells(const EvaluateResult& r, std::size_t i) {
  std::string cell;
  for (const sim::RangeExcess& x : r.excess) {
    if (x.excess[i] <= 0.0) continue;
    cell += (cell.empty() ? "" : "; ") + x.variable.name + " +" + sim::formatNumber("%.3g", x.excess[i]) + " " + x.variable.unit;
  }
  std::string out = "," + cell;
  for (const AlternativePrediction& a : r.alternatives) out += "," + sim::formatNumber("%.6g", a.divergence_m[i] * 1e3);
  return out;
}

std::string reportSection(const EvaluateResult& r) {
  if (r.warnings.empty() && r.alternatives.empty()) return "";
  std::size_t n = 0;
  for (std::size_t i = 0; i < static_cast<std::size_t>(r.fit.residuals.samples); ++i) n += beyond(r.excess, i);
  std::ostringstream md;
  md << "\n## Where the model extrapolates\n\n"
     << (r.excess.empty() ? std::string("The model file records no fitted range of its effects.")
                          : std::to_string(n) + " of " + std::to_string(r.fit.residuals.samples) +
                                " samples leave the range of the data the model's effects were fitted on (`beyond_range` in "
                                "`residuals.csv`).")
     << "\n";
  for (const std::string& w : r.warnings) md << "\n**Warning:** " << w << ".\n";
  if (!r.alternatives.empty()) {
    md << "\nThe alternatives the fitting data could not tell from this model (diagnose's confounded sets), predicting this "
          "data the same way, and how far their predicted positions lie from this model's (RMS; `alternativeN_mm` in "
          "`residuals.csv`):\n\n| alternative | its position RMS (mm) | apart beyond the ranges: RMS (mm) | max (mm) | apart within: RMS (mm) |\n"
          "|---|---|---|---|---|\n";
    const auto mm = [](double m) { return sim::formatNumber("%.4f", m * 1e3); };
    md << "| this model | " << mm(r.fit.residuals.position_rms_m) << " | 0 | 0 | 0 |\n";
    for (const AlternativePrediction& a : r.alternatives) {
      md << "| `" << a.effects << "` | " << mm(a.residuals.position_rms_m) << " | " << (a.beyond ? mm(a.beyond_rms_m) : "-") << " | "
         << (a.beyond ? mm(a.beyond_max_m) : "-") << " | " << mm(a.within_rms_m) << " |\n";
    }
  }
  return md.str();
}

std::string jsonFields(const EvaluateResult& r, const std::string& key) {
  std::ostringstream j;
  j << ", \"beyond_range\": [";
  for (std::size_t k = 0; k < r.excess.size(); ++k) {
    const sim::RangeExcess& x = r.excess[k];
    j << (k ? ", " : "") << "{\"effect\": " << sim::jsonString(x.effect) << ", \"variable\": " << sim::jsonString(x.variable.column)
      << ", \"lo\": " << sim::jsonNumber(x.range.lo, key + ": beyond_range.lo") << ", \"hi\": "
      << sim::jsonNumber(x.range.hi, key + ": beyond_range.hi") << ", \"samples_outside\": " << x.outside
      << ", \"max_excess\": " << sim::jsonNumber(x.max_excess, key + ": beyond_range.max_excess") << "}";
  }
  j << "], \"alternatives\": [";
  for (std::size_t k = 0; k < r.alternatives.size(); ++k) {
    const AlternativePrediction& a = r.alternatives[k];
    j << (k ? ", " : "") << "{\"model\": " << sim::jsonString(a.path) << ", \"effects\": " << sim::jsonString(a.effects)
      << ", \"position_rms_mm\": " << sim::jsonNumber(a.residuals.position_rms_m * 1e3, key + ": alternatives.position_rms_mm")
      << ", \"samples_beyond\": " << a.beyond
      << ", \"apart_beyond_rms_mm\": " << sim::jsonNumber(a.beyond_rms_m * 1e3, key + ": alternatives.apart_beyond_rms_mm")
      << ", \"apart_beyond_max_mm\": " << sim::jsonNumber(a.beyond_max_m * 1e3, key + ": alternatives.apart_beyond_max_mm")
      << ", \"apart_within_rms_mm\": " << sim::jsonNumber(a.within_rms_m * 1e3, key + ": alternatives.apart_within_rms_mm") << "}";
  }
  j << "]";
  return j.str();
}

}  // namespace orbcal::workflow::extrapolation
