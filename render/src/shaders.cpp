// The GLSL programs of the board renderer (the lighting model of renderer.hpp) and their compiling and
// linking.
#include <stdexcept>
#include <string>

#include "renderer_detail.hpp"

namespace orbcal::render::renderer_detail {

const char* const kVertexShader = R"glsl(
#version 330 core
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in float a_albedo;
layout(location = 3) in vec2 a_pattern;   // where on the designed board (the printed board may be warped)
uniform mat4 u_clip_T_board;
uniform mat4 u_light_T_board;
out vec3 v_pos;
out vec3 v_normal;
out float v_albedo;
out vec3 v_light;
out vec2 v_pattern;
void main() {
  v_pos = a_pos;
  v_pattern = a_pattern;
  v_normal = a_normal;
  v_albedo = a_albedo;
  v_light = (u_light_T_board * vec4(a_pos, 1.0)).xyz * 0.5 + 0.5;
  gl_Position = u_clip_T_board * vec4(a_pos, 1.0);
}
)glsl";

const char* const kFragmentShader = R"glsl(
#version 330 core
in vec3 v_pos;
in vec3 v_normal;
in float v_albedo;
in vec3 v_light;
in vec2 v_pattern;
uniform vec3 u_to_sun;       // board frame, unit
uniform vec3 u_camera_pos;   // board frame
uniform float u_ambient;
uniform float u_sun;
uniform float u_specular;
uniform float u_shininess;
uniform float u_exposure;
uniform float u_back_albedo; // < 0: same as the front
uniform sampler2DShadow u_shadow_map;
uniform int u_board_filter;     // 0: the vertex colour; 1: the pattern box-filtered over the pixel (analytic)
uniform vec4 u_squares;         // squared area of the board in squares: x0, y0, x1, y1
uniform float u_square;
uniform float u_black;
uniform float u_white;
#if CHARUCO
uniform sampler2D u_markers;    // ArUco marker blackness over the squared area (charucoMarkerImage)
#endif
#if CIRCLES
uniform vec4 u_circles;         // circles a row, rows, 1 for the asymmetric layout, radius (all in spacings)
#endif
out vec4 o_colour;
// Antiderivative of the square wave that is +1 on [2k, 2k+1) and -1 on [2k+1, 2k+2).
float triangleWave(float t) { return 1.0 - abs(mod(t, 2.0) - 1.0); }
// The board's albedo averaged over the pixel's footprint: the bounding box, in designed board coordinates, of
// the pixel (a point-symmetric kernel, so corners stay exactly in place). Black where
// (floor(x / s) + floor(y / s)) is even inside the squared area, i.e. 0.5 + 0.5 sx sy, which is separable.
// This is sim::isBlackSquare (square i = floor(x / s) + 1, j likewise), the contract; tests/render checks it.
#if CIRCLES
// A circle grid (sim::cornerInBoard's layout, p in spacings): the blackness of the nearest circle of the
// nearest three rows, its edge a linear ramp one pixel's footprint wide (symmetric about the circle, so
// every threshold of it is a circle of the same centre).
float circleBlackness(vec2 p) {
  vec2 w = fwidth(p);
  float fw = max(0.5 * (w.x + w.y), 1e-6);
  float step = u_circles.z > 0.5 ? 2.0 : 1.0;
  float row0 = clamp(floor(p.y + 0.5), 0.0, u_circles.y - 1.0);
  float black = 0.0;
  for (int dr = -1; dr <= 1; ++dr) {
    float row = row0 + float(dr);
    if (row < 0.0 || row > u_circles.y - 1.0) continue;
    float shift = u_circles.z > 0.5 ? mod(row, 2.0) : 0.0;
    float col = clamp(floor((p.x - shift) / step + 0.5), 0.0, u_circles.x - 1.0);
    float d = length(p - vec2(col * step + shift, row));
    black = max(black, clamp(0.5 - (d - u_circles.w) / fw, 0.0, 1.0));
  }
  return black;
}
#endif
float filteredChecker() {
  vec2 p = v_pattern / u_square;
#if CIRCLES
  return mix(u_white, u_black, circleBlackness(p));
#else
  vec2 h = 0.5 * (abs(dFdx(p)) + abs(dFdy(p))) + 1e-6;
  vec2 a = max(p - h, u_squares.xy), b = min(p + h, u_squares.zw);
  vec2 inside = max(b - a, vec2(0.0)) / (2.0 * h);
  vec2 wave = (b.x > a.x && b.y > a.y) ? vec2(triangleWave(b.x) - triangleWave(a.x), triangleWave(b.y) - triangleWave(a.y)) / (2.0 * h)
                                       : vec2(0.0);
  float black = 0.5 * inside.x * inside.y + 0.5 * wave.x * wave.y;
#if CHARUCO  // markers lie in the white squares, inset from their edges: they add to the checker's black
  black = min(1.0, black + texture(u_markers, (p - u_squares.xy) / (u_squares.zw - u_squares.xy)).r);
#endif
  return mix(u_white, u_black, black);
#endif
}
float sunVisibility() {
#if !SHADOWS  // a compile-time switch: llvmpipe runs both sides of a branch, so a uniform one would still sample 9 times
  return 1.0;
#else
  if (any(lessThan(v_light, vec3(0.0))) || any(greaterThan(v_light, vec3(1.0)))) return 1.0;
  vec2 texel = 1.0 / vec2(textureSize(u_shadow_map, 0));
  float lit = 0.0;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx)
      lit += texture(u_shadow_map, vec3(v_light.xy + vec2(dx, dy) * texel, v_light.z - 2e-4));
  return lit / 9.0;  // 3 x 3 percentage-closer filtering
#endif
}
void main() {
  vec3 n = normalize(v_normal);
  vec3 v = normalize(u_camera_pos - v_pos);
  float albedo = v_albedo;
  if (dot(n, v) < 0.0) {
    n = -n;
    if (u_back_albedo >= 0.0) albedo = u_back_albedo;
  } else if (u_board_filter != 0) {
    albedo = filteredChecker();
  }
  float ndl = dot(n, u_to_sun);
  float radiance = albedo * u_ambient;
  if (ndl > 0.0) {
    float vis = sunVisibility();
    vec3 h = normalize(u_to_sun + v);
    radiance += vis * u_sun * (albedo * ndl + u_specular * pow(max(dot(n, h), 0.0), u_shininess));
  }
  // red: the grey level; green: coverage (1 where anything is drawn; the clear colour's green is 0), read
  // back only when the camera profile's background needs it
  o_colour = vec4(clamp(radiance * u_exposure, 0.0, 1.0), 1.0, 0.0, 1.0);
}
)glsl";

const char* const kShadowVertexShader = R"glsl(
#version 330 core
layout(location = 0) in vec3 a_pos;
uniform mat4 u_light_T_board;
void main() { gl_Position = u_light_T_board * vec4(a_pos, 1.0); }
)glsl";

const char* const kShadowFragmentShader = R"glsl(
#version 330 core
void main() {}
)glsl";

namespace {

GLuint compile(GLenum type, const char* src) {
  const GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &src, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    glDeleteShader(s);
    throw std::runtime_error(std::string("render: shader does not compile: ") + log);
  }
  return s;
}

}  // namespace

GLuint link(const char* vs_src, const char* fs_src) {
  const GLuint vs = compile(GL_VERTEX_SHADER, vs_src), fs = compile(GL_FRAGMENT_SHADER, fs_src);
  const GLuint p = glCreateProgram();
  glAttachShader(p, vs);
  glAttachShader(p, fs);
  glLinkProgram(p);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetProgramInfoLog(p, sizeof log, nullptr, log);
    glDeleteProgram(p);
    throw std::runtime_error(std::string("render: shader program does not link: ") + log);
  }
  return p;
}

}  // namespace orbcal::render::renderer_detail
