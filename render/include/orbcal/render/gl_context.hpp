#pragma once
// An off-screen OpenGL context with no display and no GPU: OSMesa (Mesa's llvmpipe), core profile.
// OSMesa is opened by the first context and every gl* call goes through the pointers taken from it
// (src/gl_api.hpp); never link libGL/libOpenGL as well: with those first, gl* calls linked directly
// went to glvnd's no-op dispatch and images came out black with no error.
#include <string>
#include <vector>

struct osmesa_context;  // OSMesaContext is `struct osmesa_context*` (GL/osmesa.h)

namespace orbcal::render {

/// Owns one OSMesa context. Non-copyable, non-movable: GL objects created in it die with it.
/// The context is current on the creating thread after construction; call makeCurrent() before
/// using it again after another context was made current on this thread.
class OsMesaContext {
 public:
  /// Core profile of at least major.minor. Throws std::runtime_error when OSMesa refuses.
  explicit OsMesaContext(int major = 3, int minor = 3);
  ~OsMesaContext();
  OsMesaContext(const OsMesaContext&) = delete;
  OsMesaContext& operator=(const OsMesaContext&) = delete;
  OsMesaContext(OsMesaContext&&) = delete;
  OsMesaContext& operator=(OsMesaContext&&) = delete;

  void makeCurrent();
  /// glGetString(GL_VERSION) and GL_RENDERER, e.g. "4.5 (Core Profile) Mesa 22.3.6", "llvmpipe (...)".
  std::string version() const { return version_; }
  std::string renderer() const { return renderer_; }

 private:
  void release() noexcept;  // unbinds (if current) and destroys the context; idempotent

  osmesa_context* ctx_ = nullptr;
  std::vector<unsigned char> buffer_;  // the (unused) default framebuffer; rendering goes to FBOs
  std::string version_, renderer_;
};

}  // namespace orbcal::render
