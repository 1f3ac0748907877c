#include "orbcal/render/mesh.hpp"

#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <filesystem>

#include "orbcal/sim/config.hpp"

namespace orbcal::render {

namespace {
constexpr float kMaxSmoothingAngleDeg = 60.f;  // generated normals: faces meeting at more than this stay flat
}

TriangleMesh loadMesh(const MeshSpec& spec, const std::string& scene_source) {
  const auto fail = [&](const std::string& why) {
    throw sim::InputError(scene_source + ": " + spec.key + ": cannot load mesh '" + spec.file + "': " + why);
  };
  std::error_code ec;
  if (!std::filesystem::is_regular_file(spec.file, ec)) fail("no such file");
  Assimp::Importer importer;
  importer.SetPropertyFloat(AI_CONFIG_PP_GSN_MAX_SMOOTHING_ANGLE, kMaxSmoothingAngleDeg);  // keep box edges sharp
  const aiScene* scene = importer.ReadFile(spec.file, aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                                                          aiProcess_GenSmoothNormals | aiProcess_PreTransformVertices |
                                                          aiProcess_SortByPType);
  if (!scene || (scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE) || !scene->mRootNode) fail(importer.GetErrorString());
  TriangleMesh out;
  const float s = static_cast<float>(spec.scale);
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* mesh = scene->mMeshes[m];
    if (!(mesh->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;
    const auto base = static_cast<std::uint32_t>(out.positions.size());
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      const aiVector3D& p = mesh->mVertices[v];
      out.positions.emplace_back(s * p.x, s * p.y, s * p.z);
      Eigen::Vector3f n(0, 0, 1);
      if (mesh->HasNormals()) n = Eigen::Vector3f(mesh->mNormals[v].x, mesh->mNormals[v].y, mesh->mNormals[v].z);
      out.normals.push_back(n.norm() > 0 ? n.normalized() : Eigen::Vector3f(0, 0, 1));
    }
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3) continue;
      for (int k = 0; k < 3; ++k) out.indices.push_back(base + face.mIndices[k]);
    }
  }
  if (out.indices.empty()) fail("no triangles");
  return out;
}

}  // namespace orbcal::render
