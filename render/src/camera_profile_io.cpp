// camera_profile.yaml (format orbcal-camera-profile-1): reading with every key checked, writing
// atomically. The keys and their units: docs/rendered-datasets-and-images.md, "Camera profile".
#include <cmath>
#include <sstream>

#include "orbcal/render/camera_profile.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/io.hpp"

namespace orbcal::render {

namespace {

constexpr const char* kFormat = "orbcal-camera-profile-1";

double within(const sim::ConfigNode& parent, const char* key, double fallback, double lo, double hi, const char* range) {
  const sim::ConfigNode n = parent.optional(key);
  return n.defined() ? n.asDoubleWithin(lo, hi, range) : fallback;
}

ToneCurve parseTone(const sim::ConfigNode& n) {
  ToneCurve t;
  if (!n.defined()) return t;
  n.requireOnlyKeys({"black_dn", "white_dn", "gamma"});
  t.black_dn = within(n, "black_dn", t.black_dn, 0.0, 254.0, "0 to 254 DN");
  // the response at full input: above 255 DN (an exposure brighter than the render's) the 8-bit output saturates
  t.white_dn = within(n, "white_dn", t.white_dn, 1.0, 1000.0, "1 to 1000 DN");
  t.gamma = within(n, "gamma", t.gamma, 0.1, 10.0, "0.1 to 10");
  if (!(t.white_dn > t.black_dn)) n["white_dn"].fail("must be greater than black_dn");
  return t;
}

Vignetting parseVignetting(const sim::ConfigNode& n) {
  Vignetting v;
  if (!n.defined()) return v;
  n.requireOnlyKeys({"a2", "a4", "a6"});
  v.a2 = within(n, "a2", 0.0, -10.0, 10.0, "-10 to 10");
  v.a4 = within(n, "a4", 0.0, -10.0, 10.0, "-10 to 10");
  v.a6 = within(n, "a6", 0.0, -10.0, 10.0, "-10 to 10");
  for (int i = 0; i <= 100; ++i) {  // the image's corners are at r = 1
    if (!(vignettingFactor(v, i / 100.0) > 0.0)) {
      n.fail("1 + a2 r^2 + a4 r^4 + a6 r^6 must stay positive for r in [0, 1]; it is not at r = " + std::to_string(i / 100.0));
    }
  }
  return v;
}

BoardPrint parseBoard(const sim::ConfigNode& n) {
  BoardPrint b;
  if (!n.defined()) return b;
  n.requireOnlyKeys({"scale_x", "scale_y", "bow_mm", "corner_displacements"});
  b.scale_x = within(n, "scale_x", 1.0, 0.9, 1.1, "0.9 to 1.1");
  b.scale_y = within(n, "scale_y", 1.0, 0.9, 1.1, "0.9 to 1.1");
  b.bow_m = within(n, "bow_mm", 0.0, -100.0, 100.0, "-100 to 100 mm (and 5% of the board's half diagonal)") * 1e-3;
  const sim::ConfigNode list = n.optional("corner_displacements");
  if (!list.defined()) return b;
  if (!list.isSequence()) list.fail("expected a list of {id, dx_mm, dy_mm}");
  for (std::size_t i = 0; i < list.size(); ++i) {
    const sim::ConfigNode e = list[i];
    e.requireOnlyKeys({"id", "dx_mm", "dy_mm"});
    const int id = e["id"].asInt();
    if (id < 0) e["id"].fail("must be a corner id >= 0");
    if (b.corner_displacement_m.count(id)) e["id"].fail("corner " + std::to_string(id) + " is listed twice");
    b.corner_displacement_m[id] = Eigen::Vector2d(e["dx_mm"].asDoubleWithin(-10.0, 10.0, "-10 to 10 mm"),
                                                  e["dy_mm"].asDoubleWithin(-10.0, 10.0, "-10 to 10 mm")) * 1e-3;
  }
  return b;
}

}  // namespace

CameraProfile loadCameraProfile(const std::string& path) {
  const sim::ConfigNode root = sim::ConfigNode::load(path);
  root.requireOnlyKeys({"format", "tone", "vignetting", "blur_sigma_px", "sharpening", "noise", "background", "lens", "board"});
  const std::string format = root["format"].asString();
  if (format != kFormat) root["format"].fail(std::string("expected ") + kFormat + ", got " + sim::quoteInput(format));
  CameraProfile p;
  p.source = path;
  p.tone = parseTone(root.optional("tone"));
  p.vignetting = parseVignetting(root.optional("vignetting"));
  p.blur_sigma_px = within(root, "blur_sigma_px", 0.0, 0.0, 20.0, "0 to 20 px");
  if (const sim::ConfigNode s = root.optional("sharpening"); s.defined()) {
    s.requireOnlyKeys({"amount", "sigma_px"});
    p.sharpening.amount = within(s, "amount", 0.0, 0.0, 10.0, "0 to 10");
    p.sharpening.sigma_px = within(s, "sigma_px", p.sharpening.sigma_px, 0.1, 20.0, "0.1 to 20 px");
  }
  if (const sim::ConfigNode s = root.optional("noise"); s.defined()) {
    s.requireOnlyKeys({"a_dn", "b_dn2"});
    p.noise.a_dn = within(s, "a_dn", 0.0, 0.0, 100.0, "0 to 100 DN");
    p.noise.b_dn2 = within(s, "b_dn2", 0.0, 0.0, 10000.0, "0 to 10000 DN^2");
  }
  if (const sim::ConfigNode s = root.optional("background"); s.defined()) {
    s.requireOnlyKeys({"mean_dn", "texture_dn", "texture_scale_px"});
    if (s.has("mean_dn")) p.background.mean_dn = s["mean_dn"].asDoubleWithin(0.0, 255.0, "0 to 255 DN");
    p.background.texture_dn = within(s, "texture_dn", 0.0, 0.0, 255.0, "0 to 255 DN");
    p.background.texture_scale_px = within(s, "texture_scale_px", p.background.texture_scale_px, 0.5, 200.0, "0.5 to 200 px");
    if (p.background.texture_dn > 0 && !p.background.mean_dn) s.fail("texture_dn needs mean_dn");
  }
  if (const sim::ConfigNode s = root.optional("lens"); s.defined()) {
    s.requireOnlyKeys({"k1", "k2"});
    p.lens.k1 = within(s, "k1", 0.0, -1.0, 1.0, "-1 to 1");
    p.lens.k2 = within(s, "k2", 0.0, -1.0, 1.0, "-1 to 1");
  }
  p.board = parseBoard(root.optional("board"));
  return p;
}

void saveCameraProfile(const CameraProfile& p, const std::string& path) {
  const auto num = [](double v) { return sim::exactNumber(v); };
  std::ostringstream out;
  out << "# A camera profile (docs/rendered-datasets-and-images.md, \"Camera profile\"): grey levels in DN (8-bit),\n"
      << "# image lengths in pixels, the printed board in millimetres.\n"
      << "format: " << kFormat << "\n"
      << "tone: {black_dn: " << num(p.tone.black_dn) << ", white_dn: " << num(p.tone.white_dn)
      << ", gamma: " << num(p.tone.gamma) << "}\n"
      << "vignetting: {a2: " << num(p.vignetting.a2) << ", a4: " << num(p.vignetting.a4) << ", a6: " << num(p.vignetting.a6)
      << "}\n"
      << "blur_sigma_px: " << num(p.blur_sigma_px) << "\n"
      << "sharpening: {amount: " << num(p.sharpening.amount) << ", sigma_px: " << num(p.sharpening.sigma_px) << "}\n"
      << "noise: {a_dn: " << num(p.noise.a_dn) << ", b_dn2: " << num(p.noise.b_dn2) << "}\n"
      << "background: {";
  if (p.background.mean_dn) out << "mean_dn: " << num(*p.background.mean_dn) << ", ";
  out << "texture_dn: " << num(p.background.texture_dn) << ", texture_scale_px: " << num(p.background.texture_scale_px)
      << "}\n"
      << "lens: {k1: " << num(p.lens.k1) << ", k2: " << num(p.lens.k2) << "}\n"
      << "board:\n"
      << "  scale_x: " << num(p.board.scale_x) << "\n"
      << "  scale_y: " << num(p.board.scale_y) << "\n"
      << "  bow_mm: " << num(p.board.bow_m * 1e3) << "\n";
  if (!p.board.corner_displacement_m.empty()) {
    out << "  corner_displacements:\n";
    for (const auto& [id, d] : p.board.corner_displacement_m) {
      out << "    - {id: " << id << ", dx_mm: " << num(d.x() * 1e3) << ", dy_mm: " << num(d.y() * 1e3) << "}\n";
    }
  }
  sim::writeFileAtomic(path, out.str());
}

}  // namespace orbcal::render
