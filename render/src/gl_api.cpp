#include "gl_api.hpp"

#include <dlfcn.h>

#include <mutex>
#include <stdexcept>
#include <string>

#define ORBCAL_GL_DEFINE(name) decltype(orbcal_gl_##name) orbcal_gl_##name = nullptr;  // the type declared in gl_api.hpp
ORBCAL_GL_FUNCTIONS(ORBCAL_GL_DEFINE)
#undef ORBCAL_GL_DEFINE

namespace orbcal::render {

void loadGl() {
  static std::once_flag once;
  std::call_once(once, [] {  // a throw leaves the flag unset: the next context tries again
    void* lib = dlopen(ORBCAL_OSMESA_LIBRARY, RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
      const char* why = dlerror();
      throw std::runtime_error(std::string("cannot load OSMesa (") + ORBCAL_OSMESA_LIBRARY + "): " + (why ? why : "dlopen failed"));
    }
#define ORBCAL_GL_LOAD(name)                                                                               \
  orbcal_gl_##name = reinterpret_cast<decltype(orbcal_gl_##name)>(dlsym(lib, #name));                     \
  if (!orbcal_gl_##name) throw std::runtime_error(std::string(ORBCAL_OSMESA_LIBRARY) + ": no symbol " #name);
    ORBCAL_GL_FUNCTIONS(ORBCAL_GL_LOAD)
#undef ORBCAL_GL_LOAD
  });
}

}  // namespace orbcal::render
