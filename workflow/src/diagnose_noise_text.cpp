#include "diagnose_noise_text.hpp"

#include <algorithm>
#include <cmath>

#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/workflow/measured.hpp"

namespace orbcal::workflow {

namespace {

/// The estimated components' 1-sigma uncertainty (REML), and the pairs this data cannot tell apart.
std::string componentsSentence(const calib::Diagnosis& dg) {
  const calib::NoiseComponents& c = dg.noise.survived;
  static const char* kNames[3] = {"position", "rotation", "joint readings"};
  std::string parts;
  for (int k = 0; k < 3; ++k) {
    if (!c.estimated[static_cast<std::size_t>(k)]) continue;
    const double scale = k == 0 ? 1e3 : sim::kRadToDeg;
    parts += std::string(parts.empty() ? "" : ", ") + kNames[k] + " " + sim::formatNumber("%.3g", std::sqrt(std::max(0.0, c.variance[k])) * scale) +
             " +- " + sim::formatNumber("%.2g", c.sigmaSd(k) * scale) + (k == 0 ? " mm" : " deg");
  }
  if (parts.empty()) return "";
  std::string s = " With " + std::string(dg.selected.empty() ? "geometry + registration" : "the selected model") +
                  " and the empirical corrections, the components and their 1-sigma (restricted maximum likelihood): " + parts + ".";
  for (int a = 0; a < 3; ++a) {
    for (int b = a + 1; b < 3; ++b) {
      const double r = c.correlation(a, b);
      if (std::abs(r) > 0.9) {
        s += std::string(" ") + kNames[a] + " and " + kNames[b] + " noise correlate " + sim::formatNumber("%.2f", r) +
             ": this data does not tell them apart, only their sum.";
      }
    }
  }
  return s;
}

/// The floor the verdict is judged against and where its joint part came from; with an estimated joint
/// noise kept out of it, the floor it would give.
std::string floorSentence(const calib::Diagnosis& dg) {
  const calib::NoiseFloors& nf = dg.noise;
  const auto mm = [](double m) { return sim::formatNumber("%.4f", m * 1e3) + " mm"; };
  const auto deg = [](double r) { return sim::formatNumber("%.2g", r * sim::kRadToDeg) + " deg"; };
  const std::string floor = "The verdict is judged against a held-out position RMS of " + mm(dg.lack_of_fit.noise_position_rms_m);
  if (dg.lack_of_fit.source == calib::NoiseSource::kPureError) return floor + ": the scatter of the repeated configurations (pure error).";
  if (dg.lack_of_fit.source == calib::NoiseSource::kResiduals) return floor + ": estimated from these residuals (nothing stated, no repeats).";
  if (nf.joint_source == "survives") {
    return floor + ": the stated tracker noise and the joint readings' " + deg(nf.joint_floor_rad) +
           ", estimated and resolved with the empirical corrections beside the selected model (shown not to be structure they take).";
  }
  if (nf.joint_source == "unstated") {
    return floor + ": the stated tracker noise alone; the joint readings' noise is not stated, and the " + deg(nf.joint_estimate_rad) +
           " estimated is not shown to be noise (beside a flexible model of smooth structure it is not resolved, or that model still leaves structure), so it stays out (with it: " +
           mm(nf.floor_with_estimate_rms_m) + ").";
  }
  return floor + ": the stated noise.";
}

/// A fit on a seeded random subset: "on a seeded random K of the N observations".
std::string subsetWords(int subset, std::size_t of) {
  return "on a seeded random " + std::to_string(subset) + " of the " + std::to_string(of) + " observations";
}

/// Where the noise was estimated on a subset: which one, of how many (the rows without exact repeats).
std::string sampleWords(const calib::NoiseFloors& nf, const std::vector<calib::MarkerObservation>& obs) {
  if (nf.noise_observations == 0) return "";
  return "; " + subsetWords(nf.noise_observations, obs.size() - static_cast<std::size_t>(nf.duplicates_dropped));
}

}  // namespace

std::string noiseSentence(const calib::Diagnosis& dg, const calib::DiagnoseOptions& o, const sim::MeasuredData& data,
                          const std::vector<calib::MarkerObservation>& obs) {
  const calib::NoiseFloors& nf = dg.noise;
  const calib::MarkerNoise& n = nf.whitening;
  const std::string estimated =
      nf.flexible_degree > 0
          ? " (estimated as variance components beside geometry + registration + empirical corrections of every joint, degree " +
                std::to_string(nf.flexible_degree) + ", so that smooth structure is not counted as noise" + sampleWords(nf, obs) + ")"
          : " (estimated from the residuals of geometry + registration" + sampleWords(nf, obs) + ")";
  const auto source = [&estimated](bool given) { return given ? std::string(" (given)") : estimated; };
  const std::string joints = "joint readings " + sim::formatNumber("%.3g", n.joint_noise_sigma_rad * sim::kRadToDeg) + " deg" +
                             source(nf.joint_stated || !nf.joint_estimated);
  std::string text;
  if (calib::anyOwnCovariance(obs)) {
    text = "Noise, as every fit here whitens with it: each sample's own pose covariance, and " + joints + ".";
  } else {
    const bool rotation = measuresRotation(data);
    const bool pos_given = o.sigma_position_m || data.noise_position_m, rot_given = o.sigma_rotation_rad || data.noise_rotation_rad || !rotation;
    text = "Noise, 1 sigma per axis, as every fit here whitens with it: " + noiseText(n, rotation) +
           (pos_given == rot_given ? source(pos_given) : pos_given ? " (position given, rotation" + estimated + ")"
                                                                   : " (rotation given, position" + estimated + ")") +
           ", " + joints + ".";
  }
  text += componentsSentence(dg) + " " + floorSentence(dg);
  if (!nf.with_selected) return text;
  std::string effects;
  for (const sim::Effect& e : dg.selected) effects += (effects.empty() ? "" : " ") + sim::formatEffect(e);
  return text + " With the selected effects fitted, as `orbcal calibrate --effects " + effects + "` fits them (joint readings as the "
                "description states), the noise is " + noiseText(*nf.with_selected, measuresRotation(data)) +
                (nf.with_selected_observations > 0 ? " (" + subsetWords(nf.with_selected_observations, obs.size()) + ")" : "") +
                ".";
}

}  // namespace orbcal::workflow
