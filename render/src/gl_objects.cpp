// The OpenGL objects the board renderer draws with: framebuffers and vertex buffers, and the GL error check.
#include <cstdio>
#include <stdexcept>

#include "renderer_detail.hpp"

namespace orbcal::render::renderer_detail {

void checkGl(const char* where) {
  const GLenum e = glGetError();
  if (e != GL_NO_ERROR) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "render: OpenGL error 0x%04x in %s", e, where);
    throw std::runtime_error(buf);
  }
}

Fbo makeFbo(int samples, int w, int h, bool coverage) {
  Fbo f;
  glGenFramebuffers(1, &f.fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, f.fbo);
  glGenRenderbuffers(1, &f.colour);
  glBindRenderbuffer(GL_RENDERBUFFER, f.colour);
  glRenderbufferStorageMultisample(GL_RENDERBUFFER, samples, coverage ? GL_RG8 : GL_R8, w, h);  // grey: a quarter of RGBA8's memory traffic
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, f.colour);
  glGenRenderbuffers(1, &f.depth);
  glBindRenderbuffer(GL_RENDERBUFFER, f.depth);
  glRenderbufferStorageMultisample(GL_RENDERBUFFER, samples, GL_DEPTH_COMPONENT24, w, h);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, f.depth);
  const GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
  const bool error = glGetError() != GL_NO_ERROR;
  if (status != GL_FRAMEBUFFER_COMPLETE || error) {
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glDeleteRenderbuffers(1, &f.colour);
    glDeleteRenderbuffers(1, &f.depth);
    glDeleteFramebuffers(1, &f.fbo);
    return Fbo{};
  }
  return f;
}

void deleteFbo(Fbo& f) {
  if (!f.fbo) return;
  glDeleteRenderbuffers(1, &f.colour);
  glDeleteRenderbuffers(1, &f.depth);
  glDeleteFramebuffers(1, &f.fbo);
  f = Fbo{};
}

Drawable upload(const std::vector<float>& v) {
  Drawable d;
  d.count = static_cast<GLsizei>(v.size() / kFloatsPerVertex);
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = Eigen::Vector3d::Constant(-1e300);
  for (std::size_t i = 0; i + kFloatsPerVertex <= v.size(); i += kFloatsPerVertex) {
    const Eigen::Vector3d p(v[i], v[i + 1], v[i + 2]);  // the float positions GL draws
    lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  }
  for (int k = 0; k < 8; ++k) d.box[k] = Eigen::Vector3d(k & 1 ? hi.x() : lo.x(), k & 2 ? hi.y() : lo.y(), k & 4 ? hi.z() : lo.z());
  glGenVertexArrays(1, &d.vao);
  glBindVertexArray(d.vao);
  glGenBuffers(1, &d.vbo);
  glBindBuffer(GL_ARRAY_BUFFER, d.vbo);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(v.size() * sizeof(float)), v.data(), GL_STATIC_DRAW);
  const GLsizei stride = kFloatsPerVertex * sizeof(float);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, nullptr);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(3 * sizeof(float)));
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(2, 1, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(6 * sizeof(float)));
  glEnableVertexAttribArray(2);
  glVertexAttribPointer(3, 2, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(7 * sizeof(float)));
  glEnableVertexAttribArray(3);
  glBindVertexArray(0);
  return d;
}

}  // namespace orbcal::render::renderer_detail
