#pragma once
// What the board renderer's parts share (renderer.cpp draws; shaders.cpp, gl_objects.cpp and
// board_geometry.cpp make what it draws with); not part of the library's interface. The functions of
// shaders.cpp and gl_objects.cpp need the renderer's OpenGL context current.
#include "gl_api.hpp"

#include <Eigen/Geometry>
#include <array>
#include <opencv2/core.hpp>
#include <vector>

#include "orbcal/render/camera_profile.hpp"
#include "orbcal/render/settings.hpp"
#include "orbcal/sim/scene.hpp"

namespace orbcal::render::renderer_detail {

inline constexpr int kFloatsPerVertex = 9;  // position (3), normal (3), albedo (1), pattern (2)

// shaders.cpp: GLSL 330 core. The board program (kVertexShader, kFragmentShader: the lighting model of
// renderer.hpp; the fragment shader wants "#define SHADOWS 0|1" and "#define CHARUCO 0|1" and "#define CIRCLES 0|1" inserted
// after its #version line) and the shadow-map program (depth only).
extern const char* const kVertexShader;
extern const char* const kFragmentShader;
extern const char* const kShadowVertexShader;
extern const char* const kShadowFragmentShader;

/// The linked program of the two shader sources; throws std::runtime_error with the compiler's or linker's log.
GLuint link(const char* vs_src, const char* fs_src);

// gl_objects.cpp

/// Throws std::runtime_error "render: OpenGL error 0x.... in `where`" when glGetError reports one.
void checkGl(const char* where);

struct Fbo {
  GLuint fbo = 0, colour = 0, depth = 0;
};

/// A framebuffer with R8 colour (RG8 with `coverage`: the shader writes coverage into green) and 24-bit
/// depth renderbuffers; samples = 0 for single-sampled. Returns an fbo of 0 (everything deleted) when incomplete.
Fbo makeFbo(int samples, int w, int h, bool coverage = false);
/// Deletes f's objects (none when f.fbo is 0) and resets it.
void deleteFbo(Fbo& f);

/// A vertex buffer the renderer draws: triangles of kFloatsPerVertex floats a vertex.
struct Drawable {
  GLuint vao = 0, vbo = 0;
  GLsizei count = 0;
  float back_albedo = -1.f;
  bool casts_shadow = false;
  std::array<Eigen::Vector3d, 8> box;  ///< corners of the axis-aligned box (board frame) holding every vertex
};

/// Uploads the vertices `v` (position, normal, albedo; board frame) into a new vertex array.
Drawable upload(const std::vector<float>& v);

// board_geometry.cpp

/// Appends one vertex (position [m], normal, albedo, pattern) to `v`. `pattern` is where the vertex is
/// on the designed board (board frame x, y [m]): the board filter draws the checker and the markers
/// there, so a printed board that is scaled, bowed or warped (camera_profile.hpp) carries its pattern
/// along. Meshes give (0, 0): they are not drawn with the board filter.
void pushVertex(std::vector<float>& v, const Eigen::Vector3d& p, const Eigen::Vector3d& n, double albedo,
                const Eigen::Vector2d& pattern = Eigen::Vector2d::Zero());

/// The board as triangles (board frame): a grid whose x lines are [-s - m, -s, 0, s, ..., cx s, cx s + m]
/// (same for y), each cell two triangles with its own colour. Neighbouring cells share exact edge
/// coordinates (no T-junctions), so the surface has no cracks. A printed board that is not the
/// designed one (print not identity) is tessellated finer, kPrintSubdivisions cells a square side, each
/// vertex moved to printedBoardPoint of its designed place (so every inner corner is a vertex moved
/// exactly), its normal printedBoardNormal.
inline constexpr int kPrintSubdivisions = 8;
std::vector<float> boardVertices(const sim::Board& b, const RenderOptions& o, const BoardPrint& print = BoardPrint{});

/// A ChArUco board's marker blackness (CV_8UC1, 255 = black marker cell) over its squared area,
/// texels_per_square texels per square, row 0 at the lowest board y (GL's first texture row), each
/// texel the area fraction of black cells in it (4 x 4 supersampled, then averaged).
cv::Mat charucoMarkerImage(const sim::Board& b, int texels_per_square);

}  // namespace orbcal::render::renderer_detail
