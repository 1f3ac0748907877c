#include <filesystem>

#include "orbcal/render/settings.hpp"
#include "orbcal/sim/io.hpp"

namespace orbcal::render {

namespace {

double inRange(const sim::ConfigNode& n, double fallback, double lo, double hi, const char* what) {
  const double v = n.asDouble(fallback);
  if (!(v >= lo && v <= hi)) n.fail(std::string("must be ") + what);
  return v;
}

Lighting parseLighting(const sim::ConfigNode& n) {
  Lighting l;
  if (!n.defined()) return l;
  n.requireOnlyKeys({"ambient", "sun", "specular"});
  l.ambient = inRange(n.optional("ambient"), l.ambient, 0.0, 10.0, "within [0, 10]");
  const sim::ConfigNode sun = n.optional("sun");
  if (sun.defined()) {
    sun.requireOnlyKeys({"to_sun_base", "intensity"});
    if (sun.has("to_sun_base")) {
      const Eigen::Vector3d d = sun["to_sun_base"].asVector(3);
      if (d.norm() < 1e-9) sun["to_sun_base"].fail("must not be the zero vector");
      l.to_sun_base = d.normalized();
    }
    l.sun_intensity = inRange(sun.optional("intensity"), l.sun_intensity, 0.0, 100.0, "within [0, 100]");
  }
  const sim::ConfigNode spec = n.optional("specular");
  if (spec.defined()) {
    spec.requireOnlyKeys({"strength", "shininess"});
    l.specular_strength = inRange(spec.optional("strength"), l.specular_strength, 0.0, 10.0, "within [0, 10]");
    l.shininess = inRange(spec.optional("shininess"), l.shininess, 1.0, 10000.0, "within [1, 10000]");
  }
  return l;
}

Degradations parseDegradations(const sim::ConfigNode& n) {
  Degradations d;
  if (!n.defined()) return d;
  n.requireOnlyKeys({"exposure", "defocus_sigma_px", "full_well_e", "read_noise_dn"});
  d.exposure = inRange(n.optional("exposure"), d.exposure, 0.0, 100.0, "within [0, 100]");
  d.defocus_sigma_px = inRange(n.optional("defocus_sigma_px"), d.defocus_sigma_px, 0.0, 100.0, "within [0, 100]");
  d.full_well_e = inRange(n.optional("full_well_e"), d.full_well_e, 0.0, 1e9, "within [0, 1e9] (0 = no shot noise)");
  d.read_noise_dn = inRange(n.optional("read_noise_dn"), d.read_noise_dn, 0.0, 255.0, "within [0, 255]");
  return d;
}

MeshSpec parseMesh(const sim::ConfigNode& n, const std::string& base_dir) {
  n.requireOnlyKeys({"file", "frame", "pose", "scale", "albedo", "casts_shadow"});
  MeshSpec m;
  m.key = n["file"].path();
  const std::string file = n["file"].asString();
  if (file.empty()) n["file"].fail("must not be empty");
  m.file_as_written = file;
  const std::filesystem::path p(file);
  m.file = (p.is_absolute() || base_dir.empty()) ? p.string() : (std::filesystem::path(base_dir) / p).string();
  const std::string frame = n.optional("frame").asString("board");
  if (frame == "board") {
    m.frame = MeshFrame::kBoard;
  } else if (frame == "base") {
    m.frame = MeshFrame::kBase;
  } else {
    n["frame"].fail("expected 'board' or 'base', got '" + frame + "'");
  }
  if (n.has("pose")) m.frame_T_mesh = n["pose"].asTransform();
  m.scale = n.optional("scale").asDouble(m.scale);
  if (!(m.scale > 0)) n["scale"].fail("must be positive");
  m.albedo = inRange(n.optional("albedo"), m.albedo, 0.0, 1.0, "within [0, 1]");
  m.casts_shadow = n.optional("casts_shadow").asBool(m.casts_shadow);
  return m;
}

RenderOptions parseOptions(const sim::ConfigNode& n) {
  RenderOptions o;
  if (!n.defined()) return o;
  n.requireOnlyKeys({"msaa_samples", "supersample", "board_black", "board_white", "board_back", "background",
                     "board_filter", "crop_to_scene"});
  o.msaa_samples = n.optional("msaa_samples").asInt(o.msaa_samples);
  if (o.msaa_samples < 0 || o.msaa_samples > 64) n["msaa_samples"].fail("must be within 0..64");
  o.supersample = n.optional("supersample").asInt(o.supersample);
  if (o.supersample < 1 || o.supersample > 8) n["supersample"].fail("must be within 1..8");
  o.board_filter = n.optional("board_filter").asBool(o.board_filter);
  o.crop_to_scene = n.optional("crop_to_scene").asBool(o.crop_to_scene);
  o.board_black = inRange(n.optional("board_black"), o.board_black, 0.0, 1.0, "within [0, 1]");
  o.board_white = inRange(n.optional("board_white"), o.board_white, 0.0, 1.0, "within [0, 1]");
  o.board_back = inRange(n.optional("board_back"), o.board_back, 0.0, 1.0, "within [0, 1]");
  o.background = inRange(n.optional("background"), o.background, 0.0, 1.0, "within [0, 1]");
  if (!(o.board_white > o.board_black)) n["board_white"].fail("must be greater than board_black");
  return o;
}

}  // namespace

RenderSettings parseRenderSettings(const sim::ConfigNode& root, const std::string& base_dir) {
  root.requireOnlyKeys(sim::sceneTopLevelKeys());  // a misspelt section (e.g. `lightning:`) is an error, not ignored
  RenderSettings s;
  s.source = root.source();
  s.lighting = parseLighting(root.optional("lighting"));
  s.degradations = parseDegradations(root.optional("degradations"));
  const sim::ConfigNode meshes = root.optional("meshes");
  if (meshes.defined()) {
    for (std::size_t i = 0; i < meshes.size(); ++i) s.meshes.push_back(parseMesh(meshes[i], base_dir));
  }
  s.options = parseOptions(root.optional("render"));
  return s;
}

RenderSettings loadRenderSettings(const std::string& path) {
  const sim::ConfigNode root = sim::ConfigNode::load(path);
  std::string base_dir;
  if (path.rfind("builtin:", 0) != 0) base_dir = std::filesystem::path(path).parent_path().string();
  return parseRenderSettings(root, base_dir);
}

}  // namespace orbcal::render
