#include "orbcal/sim/shared_library.hpp"

#include <dlfcn.h>

#include <stdexcept>

namespace orbcal::sim {

SharedLibrary::SharedLibrary(std::string path, const std::string& what, const std::string& hint) : path_(std::move(path)) {
  handle_ = dlopen(path_.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle_) {
    const char* why = dlerror();
    throw std::runtime_error("cannot load " + what + " (" + path_ + "): " + (why ? why : "dlopen failed") + (hint.empty() ? "" : "; " + hint));
  }
}

void* SharedLibrary::symbol(const char* name, const std::string& hint) const {
  void* address = dlsym(handle_, name);
  if (!address) throw std::runtime_error(path_ + ": no symbol " + name + (hint.empty() ? "" : " (" + hint + ")"));
  return address;
}

}  // namespace orbcal::sim
