#include "dataset_copies.hpp"

#include <algorithm>
#include <filesystem>
#include <map>
#include <yaml-cpp/yaml.h>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/fileio.hpp"

namespace orbcal::render::dataset_copies {

namespace {

/// True when `relative` (inside the dataset folder) is the dataset's own file or folder, or under it.
bool reservedInDataset(const std::filesystem::path& relative, const sim::DatasetManifest& m) {
  const std::string first = relative.begin()->string();
  return first == m.robot_file || first == sim::kDatasetUrdfFile || first == m.scene_file || first == m.samples_file ||
         first == "manifest.yaml" || first == kProfileFile || first == kConfigsFile || first == kImagesCameraFile ||
         first == sim::kImagesDescriptionFile ||
         first == "images" || (!m.error_set_file.empty() && first == m.error_set_file);
}

/// Text of the YAML string `s`, double-quoted.
std::string yamlQuoted(const std::string& s) {
  std::string q = "\"";
  for (char ch : s) {
    if (ch == '"' || ch == '\\') q += '\\';
    q += ch;
  }
  return q + "\"";
}

/// Where the one-line scalar `node` of `text` (parsed from it) ends: past its closing quote, or past its
/// value when plain; npos when it is not written on one line.
std::size_t scalarEnd(const std::string& text, const YAML::Node& node) {
  const std::size_t begin = static_cast<std::size_t>(node.Mark().pos);
  const std::string value = node.Scalar();
  const char open = begin < text.size() ? text[begin] : '\0';
  if (open == '"' || open == '\'') {
    for (std::size_t k = begin + 1; k < text.size() && text[k] != '\n'; ++k) {
      if (open == '"' && text[k] == '\\') {
        ++k;
      } else if (text[k] == open) {
        if (open == '\'' && k + 1 < text.size() && text[k + 1] == '\'') {
          ++k;  // '' is a quote inside a single-quoted string
        } else {
          return k + 1;
        }
      }
    }
    return std::string::npos;
  }
  return text.compare(begin, value.size(), value) == 0 ? begin + value.size() : std::string::npos;
}

}  // namespace

std::vector<MeshCopy> planMeshCopies(const RenderSettings& settings, const sim::DatasetManifest& m) {
  std::vector<MeshCopy> copies(settings.meshes.size());
  std::map<std::string, std::string> taken;  // relative path in the dataset -> the bytes it holds
  // Kept paths first, so that relocated meshes never take a kept one's place.
  for (std::size_t i = 0; i < settings.meshes.size(); ++i) {
    const MeshSpec& spec = settings.meshes[i];
    try {
      copies[i].bytes = sim::readTextSource(spec.file);
    } catch (const sim::InputError& e) {
      throw sim::InputError(settings.source + ": " + spec.key + ": cannot read mesh '" + spec.file + "' to copy it into "
                            "the dataset: " + e.what());
    }
    // ".." is checked as written: DIR/a/../x.obj does not resolve unless DIR/a exists.
    bool up = false;
    for (const auto& part : std::filesystem::path(spec.file_as_written)) up |= part == "..";
    const std::filesystem::path written = std::filesystem::path(spec.file_as_written).lexically_normal();
    if (written.is_absolute() || up || written.empty() || reservedInDataset(written, m)) {
      copies[i].rewritten = true;
      continue;
    }
    copies[i].relative = written.generic_string();
    taken.emplace(copies[i].relative, copies[i].bytes);  // the same path always resolves to the same file
  }
  for (std::size_t i = 0; i < settings.meshes.size(); ++i) {
    MeshCopy& c = copies[i];
    if (!c.rewritten) continue;
    const std::filesystem::path name = std::filesystem::path(settings.meshes[i].file).filename();
    std::string relative = "meshes/" + name.string();
    for (int n = 2;; ++n) {
      const auto it = taken.find(relative);
      if (it == taken.end() || it->second == c.bytes) break;  // free, or the same content already there
      relative = "meshes/" + name.stem().string() + "-" + std::to_string(n) + name.extension().string();
    }
    c.relative = relative;
    taken.emplace(relative, c.bytes);
  }
  return copies;
}

std::string rewriteMeshPaths(const std::string& scene_text, const RenderSettings& settings,
                             const std::vector<MeshCopy>& copies) {
  struct Edit {
    std::size_t begin, end;
    std::string text;
  };
  std::vector<Edit> edits;
  std::string note;
  const YAML::Node root = YAML::Load(scene_text);  // parsed before (loadRenderSettings): no syntax errors here
  for (std::size_t i = 0; i < copies.size(); ++i) {
    if (!copies[i].rewritten) continue;
    const MeshSpec& spec = settings.meshes[i];
    const YAML::Node node = root["meshes"][i]["file"];
    const std::size_t begin = static_cast<std::size_t>(node.Mark().pos);
    const std::string value = node.Scalar();
    const std::size_t end = scalarEnd(scene_text, node);
    if (end == std::string::npos) {
      throw sim::InputError(settings.source + ": " + spec.key + ": cannot rewrite this mesh path in the dataset's copy "
                            "of the scene (write it on one line, plain or quoted)");
    }
    edits.push_back({begin, end, yamlQuoted(copies[i].relative)});
    note += "#   " + spec.key + ": " + value + "\n";
  }
  if (edits.empty()) return scene_text;
  std::sort(edits.begin(), edits.end(), [](const Edit& a, const Edit& b) { return a.begin > b.begin; });
  std::string text = scene_text;
  for (const Edit& e : edits) text.replace(e.begin, e.end - e.begin, e.text);
  // Check the rewrite: the copied scene must name each relocated mesh by its place in the dataset.
  const RenderSettings check = parseRenderSettings(sim::ConfigNode::parse(text, settings.source), "");
  for (std::size_t i = 0; i < copies.size(); ++i) {
    if (check.meshes.size() != copies.size() || (copies[i].rewritten && check.meshes[i].file_as_written != copies[i].relative)) {
      throw sim::InputError(settings.source + ": " + settings.meshes[i].key +
                            ": cannot rewrite this mesh path in the dataset's copy of the scene");
    }
  }
  return "# orbcal render: copied into this dataset with these mesh paths rewritten to the copies in meshes/;\n"
         "# they were:\n" + note + text;
}

std::string placeCameraFile(const sim::Scene& scene, const std::string& scene_copy, std::vector<MeshCopy>& files) {
  if (scene.camera_file.empty()) return scene_copy;
  MeshCopy c;
  c.bytes = sim::readTextSource(scene.camera_file);  // read before by sim::loadScene
  c.rewritten = true;
  const std::filesystem::path original(scene.camera_file);
  const std::string ext = original.has_extension() ? original.extension().string() : ".yaml";
  c.relative = "camera" + ext;
  for (int n = 2;; ++n) {
    const auto same = [&](const MeshCopy& f) { return f.relative == c.relative; };
    const auto it = std::find_if(files.begin(), files.end(), same);
    if (it == files.end() || it->bytes == c.bytes) break;
    c.relative = "camera-" + std::to_string(n) + ext;
  }
  const YAML::Node node = YAML::Load(scene_copy)["camera"]["file"];
  const std::size_t begin = static_cast<std::size_t>(node.Mark().pos);
  const std::size_t end = scalarEnd(scene_copy, node);
  if (end == std::string::npos) {
    throw sim::InputError(scene.source + ": camera.file: cannot rewrite this path in the dataset's copy of the scene "
                          "(write it on one line, plain or quoted)");
  }
  std::string text = scene_copy;
  text.replace(begin, end - begin, yamlQuoted(c.relative));
  if (YAML::Load(text)["camera"]["file"].Scalar() != c.relative) {
    throw sim::InputError(scene.source + ": camera.file: cannot rewrite this path in the dataset's copy of the scene");
  }
  files.push_back(c);
  return "# orbcal render: camera.file rewritten to the copy " + c.relative + " in this dataset; it was: " +
         node.Scalar() + "\n" + text;
}

}  // namespace orbcal::render::dataset_copies
