#include "gl_api.hpp"

#include <mutex>

#include "orbcal/sim/shared_library.hpp"

#define ORBCAL_GL_DEFINE(name) decltype(orbcal_gl_##name) orbcal_gl_##name = nullptr;  // the type declared in gl_api.hpp
ORBCAL_GL_FUNCTIONS(ORBCAL_GL_DEFINE)
#undef ORBCAL_GL_DEFINE

namespace orbcal::render {

void loadGl() {
  static std::once_flag once;
  std::call_once(once, [] {  // a throw leaves the flag unset: the next context tries again
    const sim::SharedLibrary lib(ORBCAL_OSMESA_LIBRARY, "OSMesa");
#define ORBCAL_GL_LOAD(name) orbcal_gl_##name = lib.function<decltype(orbcal_gl_##name)>(#name);
    ORBCAL_GL_FUNCTIONS(ORBCAL_GL_LOAD)
#undef ORBCAL_GL_LOAD
  });
}

}  // namespace orbcal::render
