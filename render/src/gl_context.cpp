#include "orbcal/render/gl_context.hpp"

#include "gl_api.hpp"

#include <stdexcept>

namespace orbcal::render {

namespace {
constexpr int kDefaultBufferPx = 16;
}

OsMesaContext::OsMesaContext(int major, int minor) {
  loadGl();  // OSMesa is opened by the first context (gl_api.hpp)
  const int attribs[] = {OSMESA_FORMAT,      OSMESA_RGBA, OSMESA_DEPTH_BITS,          0,     OSMESA_STENCIL_BITS, 0,
                         OSMESA_ACCUM_BITS,  0,           OSMESA_PROFILE,             OSMESA_CORE_PROFILE,
                         OSMESA_CONTEXT_MAJOR_VERSION, major, OSMESA_CONTEXT_MINOR_VERSION, minor, 0};
  ctx_ = OSMesaCreateContextAttribs(attribs, nullptr);
  if (!ctx_) {
    throw std::runtime_error("OSMesa: cannot create an OpenGL " + std::to_string(major) + "." + std::to_string(minor) +
                             " core-profile context (is GALLIUM_DRIVER set to a driver without it?)");
  }
  // The destructor does not run when the constructor throws: release the context on every failure below.
  try {
    buffer_.assign(kDefaultBufferPx * kDefaultBufferPx * 4, 0);
    makeCurrent();
    const auto str = [](GLenum name) {
      const GLubyte* s = glGetString(name);
      return s ? std::string(reinterpret_cast<const char*>(s)) : std::string();
    };
    version_ = str(GL_VERSION);
    renderer_ = str(GL_RENDERER);
    if (version_.empty()) {
      throw std::runtime_error("OSMesa: glGetString(GL_VERSION) returned nothing: gl* calls do not reach OSMesa "
                               "(is libGL or libOpenGL linked before libOSMesa?)");
    }
  } catch (...) {
    release();
    throw;
  }
}

OsMesaContext::~OsMesaContext() { release(); }

void OsMesaContext::release() noexcept {
  if (!ctx_) return;
  // Unbind before destroying, so this thread is never left with a dangling current context.
  if (OSMesaGetCurrentContext() == ctx_) OSMesaMakeCurrent(nullptr, nullptr, GL_UNSIGNED_BYTE, 0, 0);
  OSMesaDestroyContext(ctx_);
  ctx_ = nullptr;
}

void OsMesaContext::makeCurrent() {
  if (OSMesaGetCurrentContext() == ctx_) return;
  if (!OSMesaMakeCurrent(ctx_, buffer_.data(), GL_UNSIGNED_BYTE, kDefaultBufferPx, kDefaultBufferPx)) {
    throw std::runtime_error("OSMesa: cannot make the context current");
  }
}

}  // namespace orbcal::render
