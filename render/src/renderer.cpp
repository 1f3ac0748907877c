#include "orbcal/render/renderer.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <stdexcept>

#include "orbcal/render/degrade.hpp"
#include "orbcal/render/distortion.hpp"
#include "orbcal/render/gl_context.hpp"
#include "orbcal/render/mesh.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/errors.hpp"
#include "renderer_detail.hpp"

namespace orbcal::render {

using namespace renderer_detail;  // the shaders, GL objects and board geometry drawn with

namespace {

constexpr double kNearM = 0.02;
constexpr double kFarM = 2000.0;
constexpr int kShadowMapPx = 2048;
constexpr int kCropPadPx = 2;          // around the projected boxes: float rounding of GL's vertex transform, MSAA samples
constexpr double kCropMinDepthM = 2.0 * kNearM;  // box corners nearer than this: the whole frame is drawn

}  // namespace

sim::Camera scaledCamera(const sim::Camera& c, int s) {
  sim::Camera out = c;
  out.width_px = c.width_px * s;
  out.height_px = c.height_px * s;
  out.fx_px = c.fx_px * s;
  out.fy_px = c.fy_px * s;
  out.cx_px = s * (c.cx_px + 0.5) - 0.5;
  out.cy_px = s * (c.cy_px + 0.5) - 0.5;
  return out;
}

Eigen::Matrix4d glProjection(const sim::Camera& c, double near_m, double far_m) {
  const double W = c.width_px, H = c.height_px;
  Eigen::Matrix4d P = Eigen::Matrix4d::Zero();
  P(0, 0) = 2.0 * c.fx_px / W;
  P(0, 2) = 1.0 - 2.0 * (c.cx_px + 0.5) / W;
  P(1, 1) = 2.0 * c.fy_px / H;
  P(1, 2) = 2.0 * (c.cy_px + 0.5) / H - 1.0;
  P(2, 2) = -(far_m + near_m) / (far_m - near_m);
  P(2, 3) = -2.0 * far_m * near_m / (far_m - near_m);
  P(3, 2) = -1.0;
  return P;
}

namespace {
sim::Scene withProfiledCamera(sim::Scene scene, const CameraProfile& profile) {
  scene.camera = profiledCamera(scene.camera, profile);
  return scene;
}
}  // namespace

struct BoardRenderer::Impl {
  sim::Scene scene;
  RenderSettings settings;
  CameraProfile profile;
  bool coverage = false;  // the profile has a background: the framebuffer's green holds the coverage
  OsMesaContext context;
  std::vector<std::string> warnings;
  bool distorted = false;
  DistortionMap distortion;
  sim::Camera pinhole;  // what GL draws before supersampling
  sim::Camera gl_camera;  // pinhole scaled by the supersampling factor
  int samples = 0;
  unsigned char background_dn = 0;  // render.background as GL stores it (8 bits)
  Fbo msaa, single;
  GLuint program = 0, shadow_program = 0;
  GLuint shadow_fbo = 0, shadow_tex = 0;
  GLuint marker_tex = 0;  // ChArUco boards: charucoMarkerImage
  bool shadows = false;
  Eigen::Matrix4f light_T_board = Eigen::Matrix4f::Identity();
  Eigen::Vector3d to_sun_board = Eigen::Vector3d::UnitZ();
  std::vector<Drawable> drawables;  // [0] is the board

  Impl(const sim::Scene& sc, const RenderSettings& st, const CameraProfile& pr, std::future<DistortionMap>* prebuilt)
      : scene(withProfiledCamera(sc, pr)), settings(st), profile(pr), coverage(pr.background.mean_dn.has_value()), context(3, 3) {
    checkBoardPrint(profile, scene.board);
    // Meshes first: a missing file is an input error, reported before any GL work.
    const Eigen::Isometry3d board_T_base = scene.base_T_board.inverse();
    std::vector<std::vector<float>> mesh_vertices;
    std::vector<Eigen::Vector3d> caster_points;
    for (const MeshSpec& spec : settings.meshes) {
      const TriangleMesh mesh = loadMesh(spec, settings.source);
      const Eigen::Isometry3d board_T_mesh =
          spec.frame == MeshFrame::kBoard ? spec.frame_T_mesh : board_T_base * spec.frame_T_mesh;
      std::vector<float> v;
      v.reserve(mesh.indices.size() * kFloatsPerVertex);
      for (std::uint32_t idx : mesh.indices) {
        const Eigen::Vector3d p = board_T_mesh * mesh.positions[idx].cast<double>();
        pushVertex(v, p, board_T_mesh.linear() * mesh.normals[idx].cast<double>(), spec.albedo);
        if (spec.casts_shadow) caster_points.push_back(p);
      }
      mesh_vertices.push_back(std::move(v));
    }
    to_sun_board = board_T_base.linear() * settings.lighting.to_sun_base;

    if (scene.camera.hasDistortion()) {
      distorted = true;
      // a profile's lens part changes the camera a prebuilt map was made for
      distortion = prebuilt && prebuilt->valid() && pr.lens.identity() ? prebuilt->get() : makeDistortionMap(scene.camera);
      pinhole = distortion.pinhole;
    } else {
      pinhole = scene.camera;
    }
    gl_camera = scaledCamera(pinhole, settings.options.supersample);

    GLint max_rb = 0, max_samples = 0;
    glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_rb);
    glGetIntegerv(GL_MAX_SAMPLES, &max_samples);
    if (gl_camera.width_px > max_rb || gl_camera.height_px > max_rb) {
      throw sim::InputError(settings.source + ": camera.width_px/height_px and render.supersample: the rendered image (" +
                            std::to_string(gl_camera.width_px) + "x" + std::to_string(gl_camera.height_px) +
                            " px = camera size, enlarged for distortion, times render.supersample " +
                            std::to_string(settings.options.supersample) + ") exceeds GL_MAX_RENDERBUFFER_SIZE " +
                            std::to_string(max_rb) + "; lower render.supersample or the camera size");
    }
    int want = settings.options.msaa_samples > 1 ? settings.options.msaa_samples : 0;
    if (want > max_samples) {
      warnings.push_back(settings.source + ": render.msaa_samples: " + std::to_string(want) +
                         " requested, GL_MAX_SAMPLES is " + std::to_string(max_samples) + "; using " +
                         std::to_string(max_samples > 1 ? max_samples : 0));
      want = max_samples > 1 ? max_samples : 0;
    }
    single = makeFbo(0, gl_camera.width_px, gl_camera.height_px, coverage);
    if (!single.fbo) throw std::runtime_error("render: the single-sampled framebuffer is incomplete");
    if (want > 0) {
      msaa = makeFbo(want, gl_camera.width_px, gl_camera.height_px, coverage);
      if (msaa.fbo) {
        samples = want;
      } else {
        warnings.push_back(settings.source + ": render.msaa_samples: a " + std::to_string(want) +
                           "x multisampled framebuffer is incomplete on this OpenGL (" + context.renderer() +
                           "); rendering without multisampling");
      }
    }
    // The grey level GL stores for the background colour: the pixels never drawn get the same.
    glBindFramebuffer(GL_FRAMEBUFFER, single.fbo);
    const float bg = static_cast<float>(settings.options.background);
    glClearColor(bg, bg, bg, 1.f);
    glClear(GL_COLOR_BUFFER_BIT);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadPixels(0, 0, 1, 1, GL_RED, GL_UNSIGNED_BYTE, &background_dn);
    checkGl("framebuffer setup");

    shadow_program = link(kShadowVertexShader, kShadowFragmentShader);
    Drawable board = upload(boardVertices(scene.board, settings.options, profile.board));
    board.back_albedo = static_cast<float>(settings.options.board_back);
    drawables.push_back(board);
    for (std::size_t i = 0; i < mesh_vertices.size(); ++i) {
      Drawable d = upload(mesh_vertices[i]);
      d.casts_shadow = settings.meshes[i].casts_shadow;
      drawables.push_back(d);
    }
    checkGl("geometry upload");
    if (!caster_points.empty() && settings.lighting.sun_intensity > 0) buildShadowMap(caster_points);
    const bool charuco = scene.board.type == sim::BoardType::kCharuco, circles = scene.board.type == sim::BoardType::kCircles;
    if ((charuco || circles) && !settings.options.board_filter) {
      throw sim::InputError(settings.source + std::string(": render.board_filter: a ") + (charuco ? "ChArUco board" : "circle grid") +
                            " is drawn by the board filter; it must be on");
    }
    if (charuco) uploadMarkers();
    std::string fragment = kFragmentShader;  // the switches go right after the #version line
    fragment.insert(fragment.find('\n', fragment.find("#version")) + 1, std::string("#define SHADOWS ") + (shadows ? "1" : "0") +
                                                                          "\n#define CHARUCO " + (charuco ? "1" : "0") +
                                                                          "\n#define CIRCLES " + (circles ? "1" : "0") + "\n");
    program = link(kVertexShader, fragment.c_str());
  }

  ~Impl() {
    // Destructors must not throw. If the context cannot be made current, skip the deletions: the GL
    // objects die with the context (OsMesaContext's destructor, which runs next).
    try {
      context.makeCurrent();
    } catch (...) {
      return;
    }
    for (Drawable& d : drawables) {
      glDeleteBuffers(1, &d.vbo);
      glDeleteVertexArrays(1, &d.vao);
    }
    deleteFbo(msaa);
    deleteFbo(single);
    if (shadow_tex) glDeleteTextures(1, &shadow_tex);
    if (marker_tex) glDeleteTextures(1, &marker_tex);
    if (shadow_fbo) glDeleteFramebuffers(1, &shadow_fbo);
    glDeleteProgram(program);
    glDeleteProgram(shadow_program);
  }

  /// The marker texture, 128 texels per square (a square spans 45-75 px in the default scene's views),
  /// mipmapped so that distant views average the cells instead of aliasing them.
  void uploadMarkers() {
    const cv::Mat image = charucoMarkerImage(scene.board, 128);
    glGenTextures(1, &marker_tex);
    glBindTexture(GL_TEXTURE_2D, marker_tex);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_R8, image.cols, image.rows, 0, GL_RED, GL_UNSIGNED_BYTE, image.data);
    glGenerateMipmap(GL_TEXTURE_2D);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    checkGl("ChArUco marker texture");
  }

  /// Orthographic depth map from the sun covering the board (casters anywhere along the light).
  void buildShadowMap(const std::vector<Eigen::Vector3d>& casters) {
    const Eigen::Vector3d zl = to_sun_board;
    const Eigen::Vector3d xl = zl.unitOrthogonal(), yl = zl.cross(xl);
    const std::array<Eigen::Vector3d, 4> receivers = sim::boardOutline(scene.board);
    double amin = 1e300, amax = -1e300, bmin = 1e300, bmax = -1e300, dmin = 1e300, dmax = -1e300;
    for (const auto& p : receivers) {
      amin = std::min(amin, xl.dot(p)), amax = std::max(amax, xl.dot(p));
      bmin = std::min(bmin, yl.dot(p)), bmax = std::max(bmax, yl.dot(p));
      dmin = std::min(dmin, -zl.dot(p)), dmax = std::max(dmax, -zl.dot(p));
    }
    for (const auto& p : casters) dmin = std::min(dmin, -zl.dot(p)), dmax = std::max(dmax, -zl.dot(p));
    const double pa = 0.02 * (amax - amin) + 1e-3, pb = 0.02 * (bmax - bmin) + 1e-3, pd = 0.01 * (dmax - dmin) + 1e-2;
    amin -= pa, amax += pa, bmin -= pb, bmax += pb, dmin -= pd, dmax += pd;
    Eigen::Matrix4d L = Eigen::Matrix4d::Identity();
    L.row(0) << 2.0 * xl.transpose() / (amax - amin), -(amax + amin) / (amax - amin);
    L.row(1) << 2.0 * yl.transpose() / (bmax - bmin), -(bmax + bmin) / (bmax - bmin);
    L.row(2) << -2.0 * zl.transpose() / (dmax - dmin), -(dmax + dmin) / (dmax - dmin);
    L.row(3) << 0, 0, 0, 1;
    light_T_board = L.cast<float>();

    glGenTextures(1, &shadow_tex);
    glBindTexture(GL_TEXTURE_2D, shadow_tex);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT24, kShadowMapPx, kShadowMapPx, 0, GL_DEPTH_COMPONENT,
                 GL_UNSIGNED_INT, nullptr);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
    glGenFramebuffers(1, &shadow_fbo);
    glBindFramebuffer(GL_FRAMEBUFFER, shadow_fbo);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, shadow_tex, 0);
    glDrawBuffer(GL_NONE);
    glReadBuffer(GL_NONE);
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
      warnings.push_back(settings.source + ": meshes: the shadow-map framebuffer is incomplete; rendering without shadows");
      return;
    }
    glViewport(0, 0, kShadowMapPx, kShadowMapPx);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glClearDepth(1.0);
    glClear(GL_DEPTH_BUFFER_BIT);
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(1.5f, 4.0f);
    glUseProgram(shadow_program);
    glUniformMatrix4fv(glGetUniformLocation(shadow_program, "u_light_T_board"), 1, GL_FALSE, light_T_board.data());
    for (std::size_t i = 1; i < drawables.size(); ++i) {
      if (!drawables[i].casts_shadow) continue;
      glBindVertexArray(drawables[i].vao);
      glDrawArrays(GL_TRIANGLES, 0, drawables[i].count);
    }
    glBindVertexArray(0);
    glDisable(GL_POLYGON_OFFSET_FILL);
    glFinish();
    checkGl("shadow map");
    shadows = true;
  }

  /// The pixels (OpenCV convention, gl_camera's image) that anything drawn can cover, seen from
  /// camera_T_board: the bounding box of every drawable's box corners, projected, widened by kCropPadPx
  /// and aligned to the supersampling blocks. std::nullopt (the whole frame) when any box corner is not
  /// beyond the near plane, where the projection of a box no longer bounds its drawing. An empty
  /// rectangle when nothing can be seen.
  std::optional<cv::Rect> coveredRect(const Eigen::Isometry3d& camera_T_board) const {
    const int W = gl_camera.width_px, H = gl_camera.height_px, s = settings.options.supersample;
    double umin = 1e300, umax = -1e300, vmin = 1e300, vmax = -1e300;
    for (const Drawable& d : drawables) {
      for (const Eigen::Vector3d& p : d.box) {
        const Eigen::Vector3d pc = camera_T_board * p;
        if (!(pc.z() > kCropMinDepthM)) return std::nullopt;
        const Eigen::Vector2d uv = sim::project(gl_camera, pc);
        umin = std::min(umin, uv.x()), umax = std::max(umax, uv.x());
        vmin = std::min(vmin, uv.y()), vmax = std::max(vmax, uv.y());
      }
    }
    // Pixel u (centre at u) spans [u - 0.5, u + 0.5]: it can be touched when u + 0.5 > umin and u - 0.5 < umax.
    const auto lo = [&](double a, int size) {
      const double x = std::floor(a - 0.5) - kCropPadPx;
      return x <= 0 ? 0 : x >= size ? size : static_cast<int>(x) / s * s;
    };
    const auto hi = [&](double b, int size) {  // exclusive
      const double x = std::ceil(b + 0.5) + kCropPadPx + 1;
      return x <= 0 ? 0 : x >= size ? size : (static_cast<int>(x) + s - 1) / s * s;
    };
    const int x0 = lo(umin, W), x1 = std::max(x0, hi(umax, W)), y0 = lo(vmin, H), y1 = std::max(y0, hi(vmax, H));
    return cv::Rect(x0, y0, x1 - x0, y1 - y0);
  }

  /// The pinhole image (pinhole camera's size): `rect` (gl_camera pixels, image rows going down) drawn,
  /// read back and averaged down; everything else background_dn. With `coverage` (the member), `*covered`
  /// receives the framebuffer's green likewise (0 outside `rect`).
  cv::Mat renderPinhole(const Eigen::Isometry3d& camera_T_board, const cv::Rect& rect, cv::Mat* covered) {
    const int s = settings.options.supersample;
    cv::Mat img(pinhole.height_px, pinhole.width_px, CV_8UC1, cv::Scalar(background_dn));
    if (coverage) *covered = cv::Mat(pinhole.height_px, pinhole.width_px, CV_8UC1, cv::Scalar(0));
    if (rect.empty()) return img;
    context.makeCurrent();
    const int W = gl_camera.width_px, H = gl_camera.height_px;
    const int gl_y = H - rect.y - rect.height;  // GL rows go up
    glBindFramebuffer(GL_FRAMEBUFFER, samples > 0 ? msaa.fbo : single.fbo);
    glViewport(0, 0, W, H);
    const float bg = static_cast<float>(settings.options.background);
    glClearColor(bg, bg, bg, 1.f);
    glClearDepth(1.0);
    glDepthFunc(GL_LESS);
    glDisable(GL_CULL_FACE);
    if (samples > 0) glEnable(GL_MULTISAMPLE);
    // The board alone needs no depth buffer: its triangles never overlap (each pixel is drawn once).
    const bool depth = drawables.size() > 1;
    if (depth) glEnable(GL_DEPTH_TEST); else glDisable(GL_DEPTH_TEST);
    glClear(depth ? GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT : GL_COLOR_BUFFER_BIT);

    const Eigen::Matrix4d F = Eigen::Vector4d(1, -1, -1, 1).asDiagonal();  // OpenCV camera -> GL eye
    const Eigen::Matrix4f clip_T_board = (glProjection(gl_camera, kNearM, kFarM) * F * camera_T_board.matrix()).cast<float>();
    const Eigen::Vector3f camera_pos = camera_T_board.inverse().translation().cast<float>();
    const Lighting& l = settings.lighting;
    glUseProgram(program);
    const auto loc = [&](const char* name) { return glGetUniformLocation(program, name); };
    glUniformMatrix4fv(loc("u_clip_T_board"), 1, GL_FALSE, clip_T_board.data());
    glUniformMatrix4fv(loc("u_light_T_board"), 1, GL_FALSE, light_T_board.data());
    const Eigen::Vector3f to_sun = to_sun_board.cast<float>();
    glUniform3fv(loc("u_to_sun"), 1, to_sun.data());
    glUniform3fv(loc("u_camera_pos"), 1, camera_pos.data());
    glUniform1f(loc("u_ambient"), static_cast<float>(l.ambient));
    glUniform1f(loc("u_sun"), static_cast<float>(l.sun_intensity));
    glUniform1f(loc("u_specular"), static_cast<float>(l.specular_strength));
    glUniform1f(loc("u_shininess"), static_cast<float>(l.shininess));
    glUniform1f(loc("u_exposure"), static_cast<float>(settings.degradations.exposure));
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, shadow_tex);
    glUniform1i(loc("u_shadow_map"), 0);
    if (marker_tex) {
      glActiveTexture(GL_TEXTURE1);
      glBindTexture(GL_TEXTURE_2D, marker_tex);
      glUniform1i(loc("u_markers"), 1);
      glActiveTexture(GL_TEXTURE0);
    }
    const sim::Board& b = scene.board;
    glUniform4f(loc("u_squares"), -1.f, -1.f, float(b.corners_x), float(b.corners_y));
    glUniform1f(loc("u_square"), float(b.square_m));
    if (b.type == sim::BoardType::kCircles) {
      glUniform4f(loc("u_circles"), float(b.corners_x), float(b.corners_y), b.asymmetric ? 1.f : 0.f, float(0.5 * b.diameter_m / b.square_m));
    }
    glUniform1f(loc("u_black"), float(settings.options.board_black));
    glUniform1f(loc("u_white"), float(settings.options.board_white));
    for (std::size_t i = 0; i < drawables.size(); ++i) {
      const Drawable& d = drawables[i];
      glUniform1i(loc("u_board_filter"), i == 0 && settings.options.board_filter ? 1 : 0);
      glUniform1f(loc("u_back_albedo"), d.back_albedo);
      glBindVertexArray(d.vao);
      glDrawArrays(GL_TRIANGLES, 0, d.count);
    }
    glBindVertexArray(0);
    if (samples > 0) {
      glBindFramebuffer(GL_READ_FRAMEBUFFER, msaa.fbo);
      glBindFramebuffer(GL_DRAW_FRAMEBUFFER, single.fbo);
      glBlitFramebuffer(rect.x, gl_y, rect.x + rect.width, gl_y + rect.height, rect.x, gl_y, rect.x + rect.width,
                        gl_y + rect.height, GL_COLOR_BUFFER_BIT, GL_NEAREST);
    }
    glBindFramebuffer(GL_READ_FRAMEBUFFER, single.fbo);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    cv::Mat flipped(rect.height, rect.width, coverage ? CV_8UC2 : CV_8UC1);
    glReadPixels(rect.x, gl_y, rect.width, rect.height, coverage ? GL_RG : GL_RED, GL_UNSIGNED_BYTE, flipped.data);
    checkGl("render");
    cv::Mat channels[2];
    if (coverage) cv::split(flipped, channels); else channels[0] = flipped;
    for (int c = 0; c < (coverage ? 2 : 1); ++c) {
      cv::Mat& out = c == 0 ? img : *covered;
      if (s == 1) {
        cv::Mat dst = out(rect);
        cv::flip(channels[c], dst, 0);  // GL rows go up, image rows go down
      } else {
        // rect is aligned to s x s blocks, so averaging it alone gives the same pixels as the whole frame.
        cv::Mat up, dst = out(cv::Rect(rect.x / s, rect.y / s, rect.width / s, rect.height / s));
        cv::flip(channels[c], up, 0);
        cv::resize(up, dst, dst.size(), 0, 0, cv::INTER_AREA);
      }
    }
    return img;
  }

  /// The whole frame's rectangle (gl_camera pixels).
  cv::Rect fullFrame() const { return cv::Rect(0, 0, gl_camera.width_px, gl_camera.height_px); }
};

BoardRenderer::BoardRenderer(const sim::Scene& scene, const RenderSettings& settings,
                             std::future<DistortionMap>* distortion_map)
    : impl_(std::make_unique<Impl>(scene, settings, CameraProfile{}, distortion_map)) {}

BoardRenderer::BoardRenderer(const sim::Scene& scene, const RenderSettings& settings, const CameraProfile& profile,
                             std::future<DistortionMap>* distortion_map)
    : impl_(std::make_unique<Impl>(scene, settings, profile, distortion_map)) {}

BoardRenderer::~BoardRenderer() = default;

BoardRenderer::Drawn BoardRenderer::draw(const Eigen::Isometry3d& camera_T_board) {
  Impl& m = *impl_;
  std::optional<cv::Rect> rect;
  if (m.settings.options.crop_to_scene) rect = m.coveredRect(camera_T_board);
  const cv::Rect drawn = rect ? *rect : m.fullFrame();
  const int s = m.settings.options.supersample;  // drawn is aligned to s x s blocks
  Drawn out;
  out.pinhole = m.renderPinhole(camera_T_board, drawn, &out.coverage);
  out.rect = cv::Rect(drawn.x / s, drawn.y / s, drawn.width / s, drawn.height / s);
  out.cropped = rect.has_value();
  return out;
}

namespace {
/// The clean image (camera size) from a drawn one: the lens distortion applied, if any.
cv::Mat undistortedToCamera(const DistortionMap* map, const cv::Mat& pinhole, const BoardRenderer::Drawn& d,
                            unsigned char background_dn) {
  if (!map) return pinhole;
  if (!d.cropped) return applyDistortion(*map, pinhole, static_cast<double>(background_dn));
  return applyDistortion(*map, pinhole, background_dn, d.rect);
}
}  // namespace

cv::Mat BoardRenderer::finish(const Drawn& drawn, std::uint64_t seed, std::uint64_t stream) const {
  const Impl& m = *impl_;
  const DistortionMap* map = m.distorted ? &m.distortion : nullptr;
  const cv::Mat clean = undistortedToCamera(map, drawn.pinhole, drawn, m.background_dn);
  if (!m.settings.degradations.any() && m.profile.imageIdentity()) return clean;
  std::mt19937_64 rng = sim::makeRng(seed, stream);
  const cv::Mat degraded = applyDegradations(clean, m.settings.degradations, rng);
  if (m.profile.imageIdentity()) return degraded;
  const cv::Mat covered = m.coverage ? undistortedToCamera(map, drawn.coverage, drawn, 0) : cv::Mat();
  return applyCameraProfile(degraded, covered, m.profile, m.scene.camera, rng);
}

cv::Mat BoardRenderer::renderClean(const Eigen::Isometry3d& camera_T_board) {
  const Drawn d = draw(camera_T_board);
  return undistortedToCamera(impl_->distorted ? &impl_->distortion : nullptr, d.pinhole, d, impl_->background_dn);
}

cv::Mat BoardRenderer::render(const Eigen::Isometry3d& camera_T_board, std::uint64_t seed, std::uint64_t stream) {
  return finish(draw(camera_T_board), seed, stream);
}

int BoardRenderer::msaaSamples() const { return impl_->samples; }
const std::vector<std::string>& BoardRenderer::warnings() const { return impl_->warnings; }

}  // namespace orbcal::render
