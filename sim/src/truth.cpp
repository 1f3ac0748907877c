#include "orbcal/sim/truth.hpp"

#include <cmath>
#include <set>
#include <sstream>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/gravity.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::sim {

namespace {

bool readsTorque(const KinematicModel& m) {
  for (const Effect& e : m.effects) {
    if (e.kind().needs().torque) return true;
  }
  return false;
}

TrueArm assemble(const Arm& arm, const Eigen::VectorXd& y, std::vector<Effect> effects) {
  TrueArm t;
  t.model = makeKinematicModel(arm, 1, FrameSharing::kKnown, FrameSharing::kKnown, {Eigen::Isometry3d::Identity()},
                               {Eigen::Isometry3d::Identity()}, std::move(effects));
  t.p = Eigen::VectorXd::Zero(t.model.layout.size());
  const ParamBlock& g = t.model.layout.block(t.model.layout.find(BlockKind::kGeometry));
  t.p.segment(g.offset, g.size()) = y;
  t.covariates.payload_kg = arm.masses.payload_kg;
  return t;
}

/// A positive number up to `max` (`range` says it: "more than 0 s to 1e10 s"), or `fallback` when absent.
double positive(const ConfigNode& n, double fallback, double max, const std::string& range) {
  if (!n.defined()) return fallback;
  const double v = n.asDoubleWithin(0.0, max, range);
  if (!(v > 0.0)) n.fail("must be positive");
  return v;
}

/// covariates: of an error-set file; the plant's temperatures stay within an arm's (kMinTemperatureC
/// to kMaxTemperatureC) from start_C to start_C + rise_C.
CovariateProfile readCovariates(const ConfigNode& c, double default_payload_kg) {
  CovariateProfile cov;
  if (c.defined()) c.requireOnlyKeys({"payload_kg", "temperature", "sample_period_s"});
  const ConfigNode payload = c.optional("payload_kg");
  cov.payload_kg = payload.defined() ? payload.asDoubleWithin(0.0, 1e6, "0 kg to 1e6 kg") : default_payload_kg;
  const ConfigNode temp = c.optional("temperature");
  if (temp.defined()) {
    temp.requireOnlyKeys({"start_C", "rise_C", "tau_s"});
    const std::string arm_range = formatNumber("%g", kMinTemperatureC) + " degC to " + formatNumber("%g", kMaxTemperatureC) +
                                  " degC (an arm's temperature)";
    const ConfigNode start = temp.optional("start_C"), rise = temp.optional("rise_C");
    if (start.defined()) cov.temperature_start_C = start.asDoubleWithin(kMinTemperatureC, kMaxTemperatureC, arm_range);
    if (rise.defined()) cov.temperature_rise_C = rise.asDouble();
    const double end = cov.temperature_start_C + cov.temperature_rise_C;
    if (rise.defined() && !(end >= kMinTemperatureC && end <= kMaxTemperatureC)) {
      rise.fail("start_C + rise_C = " + formatNumber("%.9g", end) + " degC is outside " + arm_range);
    }
    cov.temperature_tau_s = positive(temp.optional("tau_s"), cov.temperature_tau_s, 1e10, "more than 0 s to 1e10 s");
  }
  cov.sample_period_s = positive(c.optional("sample_period_s"), cov.sample_period_s, 1e6, "more than 0 s to 1e6 s (11 days)");
  return cov;
}

Eigen::VectorXd readGeometry(const Arm& arm, const ConfigNode& g) {
  const std::string expected = "expected table3, zero, random, {random: {angle_sigma_deg, length_sigma_mm, seed}} or one "
                               "{theta_deg, alpha_deg, a_mm, d_mm} (and beta_deg for a hayati arm) per joint";
  ErrorSetSpec spec;
  if (g.isScalar()) {
    spec.name = g.asString();
    if (!isNamedErrorSet(spec.name)) g.fail(expected + ", got " + quoteInput(spec.name));
    return makeErrorSet(arm, spec, g.source() + ": " + g.path());
  }
  if (g.isMap()) {
    g.requireOnlyKeys({"random"});
    const ConfigNode r = g["random"];
    spec.name = "random";
    if (r.defined()) {
      r.requireOnlyKeys({"angle_sigma_deg", "length_sigma_mm", "seed"});
      // Only the keys given replace ErrorSetSpec's defaults (no round trip through deg and mm).
      if (r.has("angle_sigma_deg")) {
        spec.angle_sigma_rad = r["angle_sigma_deg"].asDoubleWithin(0.0, 180.0, "0 deg to 180 deg (an angle error)") * kDegToRad;
      }
      if (r.has("length_sigma_mm")) {
        spec.length_sigma_m = r["length_sigma_mm"].asDoubleWithin(0.0, 1e4, "0 mm to 10000 mm (a length error)") * 1e-3;
      }
      if (r.has("seed")) {
        const int seed = r["seed"].asInt();
        if (seed < 0) r["seed"].fail("must not be negative");
        spec.seed = static_cast<std::uint64_t>(seed);
      }
    }
    return makeErrorSet(arm, spec, g.source() + ": " + g.path());
  }
  if (g.isSequence()) {
    if (static_cast<int>(g.size()) != arm.numJoints()) {
      g.fail("expected one row per joint: " + std::to_string(arm.numJoints()) + " (as " + arm.source + "), got " +
             std::to_string(g.size()));
    }
    Eigen::VectorXd y(arm.numParams());
    for (int j = 0; j < arm.numJoints(); ++j) readErrorRow(g[static_cast<std::size_t>(j)], arm, j, y);
    return y;
  }
  g.fail(expected);
}

}  // namespace

double CovariateProfile::temperatureAt(double t_s) const {
  return temperature_start_C + temperature_rise_C * (1.0 - std::exp(-t_s / temperature_tau_s));
}

Eigen::VectorXd TrueArm::geometryErrors() const {
  const ParamBlock& g = model.layout.block(model.layout.find(BlockKind::kGeometry));
  return p.segment(g.offset, g.size());
}

JointSample TrueArm::sample(int k, const Eigen::VectorXd& q, const Eigen::VectorXd* q_previous) const {
  JointSample s;
  s.q_rad = q;
  s.time_s = covariates.sample_period_s * k;
  s.temperature_C = covariates.temperatureAt(s.time_s);
  if (readsTorque(model)) s.tau_Nm = gravityTorques(model.arm, model.arm.masses, q);
  std::vector<MeasuredPose> moves(q_previous ? 2 : 1);
  if (q_previous) moves.front().sample.q_rad = *q_previous;
  moves.back().sample.q_rad = q;
  fillApproachDirections(moves);
  s.direction = moves.back().sample.direction;
  return s;
}

Eigen::Isometry3d TrueArm::flangePose(const JointSample& s) const {
  // The frames are known (identity), so world_T_marker is D(t) base_T_flange (the effects' inserts at
  // the base included); without effects that is forwardKinematics(withErrors(nominal, y), q) exactly.
  return model.effects.empty() ? sim::flangePose(model, p, s) : predictMarkerPose(model, p, s);
}

Camera TrueArm::camera(const Camera& scene_camera) const {
  Camera c = scene_camera;
  for (int i = 0; i < 4; ++i) c.distortion[static_cast<std::size_t>(i)] += camera_distortion_delta[i];
  return c;
}

Eigen::Isometry3d TrueArm::flangePose(int k, const Eigen::VectorXd& q, const Eigen::VectorXd* q_previous) const {
  return flangePose(sample(k, q, q_previous));
}

bool isNamedErrorSet(const std::string& name) { return name == "table3" || name == "zero" || name == "random"; }

TrueArm geometricTrueArm(const Arm& nominal, const Eigen::VectorXd& y, const std::string& name) {
  TrueArm t = assemble(nominal, y, {});
  t.name = name;
  return t;
}

TrueArm makeTrueArm(const Arm& nominal, const ErrorSetSpec& spec, const std::string& what) {
  if (isNamedErrorSet(spec.name)) return geometricTrueArm(nominal, makeErrorSet(nominal, spec, what), spec.name);
  std::string text;
  try {
    text = readTextSource(spec.name);
  } catch (const InputError& e) {
    throw InputError(what + ": '" + spec.name + "' is neither table3, zero, random nor a readable error-set file (" +
                     e.what() + ")");
  }
  TrueArm t = parseTrueArm(nominal, text, spec.name);
  t.name = spec.name;
  return t;
}

TrueArm parseTrueArm(const Arm& nominal, const std::string& text, const std::string& source) {
  const ConfigNode root = ConfigNode::parse(text, source);
  root.requireOnlyKeys({"format", "geometry", "effects", "covariates"});
  if (root["format"].asString() != kErrorSetFormat) {
    root["format"].fail("expected " + std::string(kErrorSetFormat) + ", got '" + root["format"].asString() + "'");
  }
  const Eigen::VectorXd y = readGeometry(nominal, root["geometry"]);

  // Covariates first: the effects are checked against them.
  const CovariateProfile cov = readCovariates(root.optional("covariates"), nominal.masses.payload_kg);
  const ConfigNode temp = root.optional("covariates").optional("temperature");
  Arm arm = nominal;
  arm.masses.payload_kg = cov.payload_kg;

  std::vector<Effect> effects;
  std::vector<std::size_t> effect_entries;  // the list entry of each chain effect
  std::set<std::string> seen;
  const ConfigNode list = root.optional("effects");
  const std::size_t n_effects = list.defined() ? list.size() : 0;
  Eigen::Vector4d distortion = Eigen::Vector4d::Zero();
  bool has_distortion = false;
  for (std::size_t k = 0; k < n_effects; ++k) {
    const ConfigNode e = list[k];
    e.requireOnlyKeys({"spec", "parameters"});
    const ConfigNode spec = e["spec"];
    if (isCameraEffect(spec.asString(), source + ": " + spec.path())) {
      if (has_distortion) spec.fail("a second distortion effect");
      has_distortion = true;
      const ParamBlock b = distortionBlock();
      std::vector<std::string> names;
      for (const ParamInfo& info : b.params) names.push_back(info.name);
      const ConfigNode params = e["parameters"];
      params.requireOnlyKeys(names);
      for (int i = 0; i < 4; ++i) distortion[i] = readParameterValue(params[names[static_cast<std::size_t>(i)]], b.params[static_cast<std::size_t>(i)]);
      continue;
    }
    Effect effect = parseEffect(spec.asString(), arm.numJoints(), source + ": " + spec.path());
    const std::string name = effectName(effect);
    if (!seen.insert(name).second) {
      spec.fail("a second " + name + " effect: list every joint in one spec (e.g. " + name + ":2,4)");
    }
    if (effect.kind().needs().sessions) {
      spec.fail(name + " (the marker re-mounted between sessions) has no meaning in a simulated plant: a dataset is one "
                "session");
    }
    if ((effect.kind().needs().torque || effect.kind().needs().masses) && arm.masses.empty()) {
      const bool urdf = !nominal.urdf.empty() && nominal.urdf.file == nominal.source;  // read from the URDF itself
      spec.fail(name + " reads the gravity loads of the robot file's masses, and " + nominal.source +
                (urdf ? " has no <inertial> on a link the chain moves" : " has no masses: section") +
                " and covariates.payload_kg is 0");
    }
    if (effect.kind().needs().temperature && !temp.defined()) {
      spec.fail(name + " reads the temperature: give covariates.temperature ({start_C, rise_C, tau_s}); at the "
                "reference 20 degC it would do nothing");
    }
    effects.push_back(std::move(effect));
    effect_entries.push_back(k);
  }

  TrueArm t = assemble(arm, y, effects);
  t.name = source;
  t.file_text = text;
  t.covariates = cov;
  t.camera_distortion_delta = distortion;
  t.has_camera_distortion = has_distortion;
  for (std::size_t k = 0; k < effects.size(); ++k) {
    const ConfigNode params = list[effect_entries[k]]["parameters"];
    const std::string name = effectName(effects[k]);
    std::vector<std::string> allowed;
    for (const ParamBlock& b : t.model.layout.blocks()) {
      if (b.effect != name) continue;
      for (int i = 0; i < b.size(); ++i) allowed.push_back(b.params[static_cast<std::size_t>(i)].name);
    }
    params.requireOnlyKeys(allowed);
    for (const ParamBlock& b : t.model.layout.blocks()) {
      if (b.effect != name) continue;
      for (int i = 0; i < b.size(); ++i) {
        const ParamInfo& info = b.params[static_cast<std::size_t>(i)];
        t.p[b.offset + i] = readParameterValue(params[info.name], info);
      }
    }
  }
  return t;
}

std::optional<TrueArm> datasetTrueArm(const Dataset& d) {
  const DatasetManifest& m = d.manifest;
  if (!m.true_errors) return std::nullopt;
  if (m.error_set_file.empty()) return geometricTrueArm(d.arm, *m.true_errors, m.error_set);
  const std::string path = d.path(m.error_set_file);
  TrueArm t = parseTrueArm(d.arm, readTextNamedBy(path, d.folder + "/manifest.yaml: true_errors.file"), path);
  // The manifest prints the errors in deg and mm with 12 significant digits.
  const Eigen::VectorXd y = t.geometryErrors();
  for (Eigen::Index i = 0; i < y.size(); ++i) {
    if (std::abs(y[i] - (*m.true_errors)[i]) > 1e-11 * std::max(std::abs(y[i]), std::abs((*m.true_errors)[i]))) {
      throw InputError(path + ": geometry: " + paramName(d.arm, static_cast<int>(i)) + " differs from " + d.folder +
                       "/manifest.yaml's true_errors (the dataset was rendered from another file)");
    }
  }
  return t;
}

std::string formatEffects(const TrueArm& t) {
  if (!t.hasEffects()) return "";
  std::ostringstream s;
  bool time = false, temperature = false, torque = false, direction = false;
  for (const Effect& e : t.model.effects) {
    s << "  " << formatEffect(e) << ":";
    const std::string name = effectName(e);
    bool first = true;
    for (const ParamBlock& b : t.model.layout.blocks()) {
      if (b.effect != name) continue;
      for (int i = 0; i < b.size(); ++i) {
        const ParamInfo& info = b.params[static_cast<std::size_t>(i)];
        s << (first ? " " : ", ") << info.name << " " << formatNumber("%+.6g", t.p[b.offset + i] * info.display_scale) << " "
          << info.display_unit;
        first = false;
      }
    }
    s << "\n";
    const EffectNeeds needs = e.kind().needs();
    time |= needs.time || needs.temperature;
    temperature |= needs.temperature;
    torque |= needs.torque;
    direction |= needs.direction;
  }
  const CovariateProfile& c = t.covariates;
  if (time) s << "  sample k at t = k * " << formatNumber("%.6g", c.sample_period_s) << " s\n";
  if (temperature) {
    s << "  temperature " << formatNumber("%.6g", c.temperature_start_C) << " degC + "
      << formatNumber("%.6g", c.temperature_rise_C) << " degC (1 - exp(-t / " << formatNumber("%.6g", c.temperature_tau_s)
      << " s))\n";
  }
  if (torque) {
    s << "  torques: gravity of " << (t.model.arm.masses.links.empty() ? "the payload" : "the robot file's masses")
      << " with a payload of " << formatNumber("%.6g", c.payload_kg) << " kg\n";
  }
  if (direction) s << "  approach direction: from the previous sample's joints\n";
  if (t.has_camera_distortion) {
    const ParamBlock b = distortionBlock();
    s << "  distortion (camera, added to the scene's):";
    for (int i = 0; i < 4; ++i) {
      s << (i ? ", " : " ") << b.params[static_cast<std::size_t>(i)].name << " "
        << formatNumber("%+.6g", t.camera_distortion_delta[i]);
    }
    s << "\n";
  }
  return s.str();
}

}  // namespace orbcal::sim
