#pragma once
// Extra geometry for the renderer: a mesh file loaded with Assimp (triangulated, normals generated,
// the node hierarchy flattened) into one triangle list.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "orbcal/render/settings.hpp"

namespace orbcal::render {

struct TriangleMesh {
  std::vector<Eigen::Vector3f> positions;  ///< mesh frame, already multiplied by MeshSpec::scale (m)
  std::vector<Eigen::Vector3f> normals;    ///< unit, per vertex
  std::vector<std::uint32_t> indices;      ///< three per triangle
};

/// Loads spec.file. Throws sim::InputError "<scene file>: <key>: cannot load mesh '<path>': <reason>"
/// (missing file, unreadable format, no triangles).
TriangleMesh loadMesh(const MeshSpec& spec, const std::string& scene_source);

}  // namespace orbcal::render
