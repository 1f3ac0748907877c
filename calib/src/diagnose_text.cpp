// What diagnose says in words: people's names for effects, the advice that separates a confounded
// set, and the verdict paragraph.
#include <algorithm>
#include <sstream>

#include "diagnose_text.hpp"
#include "diagnose_noise.hpp"
#include "orbcal/sim/csv.hpp"

namespace orbcal::calib {

using sim::Effect;

std::string describeEffect(const sim::Effect& e) { return e.kind().words(e); }

std::string separationAdvice(const std::vector<Effect>& set) {
  const auto has = [&](const char* k) { return std::any_of(set.begin(), set.end(), [&](const Effect& e) { return e.name() == k; }); };
  if (has("thermal") && has("drift") && !has("compliance")) {
    return "measure while the temperature also falls (a cool-down), so that temperature and time part";
  }
  for (const sim::EffectKind* k : sim::catalog()) {
    if (std::any_of(set.begin(), set.end(), [&](const Effect& e) { return &e.kind() == k; })) return k->separateBy();
  }
  return "add configurations that move the joints involved independently";
}

std::string verdictText(const Diagnosis& out) {
  const std::vector<Effect>& selected = out.selected;
  std::ostringstream v;
  if (out.clean && out.lack_of_fit.tested) {
    v << "No unmodelled effect: the geometry + registration model leaves no significant structure in its held-out residuals "
      << "(held-out position RMS " << sim::formatNumber("%.3f", out.heldout.base.position_rms_m * 1e3) << " mm, the noise gives "
      << sim::formatNumber("%.3f", out.heldout.noise_position_rms_m * 1e3) << " mm); calibrate it as it is.";
  } else if (out.clean) {
    v << "No unmodelled effect found, but only relative to noise estimated from these residuals, "
      << sim::formatNumber("%.3f", out.heldout.noise_position_rms_m * 1e3) << " mm (held-out position RMS "
      << sim::formatNumber("%.3f", out.heldout.base.position_rms_m * 1e3) << " mm): no structure found against any variable "
      << "tested, but a misfit spread evenly over the samples cannot be told from noise without a stated noise or repeated "
      << "configurations; calibrate it as it is, or state the noise to test it.";
  } else if (selected.empty()) {
    v << unexplainedSentence(out);
  } else {
    // Physical causes are named as causes; empirical corrections as what they are.
    std::vector<Effect> causes, empirical;
    for (const Effect& e : selected) (e.kind().empirical() ? empirical : causes).push_back(e);
    const auto list = [&](const std::vector<Effect>& es) {
      std::string t;
      for (std::size_t i = 0; i < es.size(); ++i) t += (i ? (i + 1 == es.size() ? " and " : ", ") : "") + describeEffect(es[i]);
      return t;
    };
    if (!causes.empty()) v << "The model misses " << list(causes);
    if (!empirical.empty()) {
      v << (causes.empty() ? "No cause of the catalog explains the structure in the residuals; " : "; what they leave is taken up by ")
        << list(empirical) << (causes.empty() ? " takes it up (empirical, not a physical cause)" : " (empirical, not a physical cause)");
    }
    // In micrometres where millimetres to 3 decimals would read the same ("from 0.091 to 0.091 mm").
    std::string before = sim::formatNumber("%.3f", out.heldout.base.position_rms_m * 1e3) + " mm";
    std::string after = sim::formatNumber("%.3f", out.heldout.selected.position_rms_m * 1e3) + " mm";
    if (before == after) {
      before = sim::formatNumber("%.2f", out.heldout.base.position_rms_m * 1e6) + " um";
      after = sim::formatNumber("%.2f", out.heldout.selected.position_rms_m * 1e6) + " um";
    }
    // Selection weighs the held-out errors by their noise; the plain position RMS can stay level.
    const bool cut = out.heldout.selected.position_rms_m < out.heldout.base.position_rms_m;
    v << ": adding " << (selected.size() > 1 ? "them" : "it")
      << (cut ? " cuts the held-out position RMS from " : " lowers the held-out error weighed by the noise (the position RMS goes from ")
      << before << " to " << after << (cut ? "" : ")") << "; calibrate with --effects";
    for (const Effect& e : selected) v << " " << sim::formatEffect(e);
    v << (out.confounded.empty() ? "." : " (some causes are confounded in this data: see below).");
    if (out.unexplained) v << " " << unexplainedSentence(out);
  }
  const std::string noise = noiseDependenceText(out);
  if (!noise.empty()) v << " " << noise;
  return v.str();
}

}  // namespace orbcal::calib
