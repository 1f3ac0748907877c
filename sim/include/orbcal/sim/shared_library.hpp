#pragma once
// A shared library opened at run time (dlopen) rather than linked: what orbcal does with the libraries
// whose loading costs every start of every program (OpenCV's image codecs, OSMesa), so that only the
// commands that use them pay for it. Both openers (sim/src/image_files.cpp, render/src/gl_api.cpp) go
// through this one class, so a library that cannot be opened, or lacks a function, says so alike.
#include <string>

namespace orbcal::sim {

/// A library opened with dlopen(path, RTLD_NOW | RTLD_LOCAL) and kept open for the process's life (the
/// functions taken from it stay valid after this object is gone).
class SharedLibrary {
 public:
  /// Throws std::runtime_error "cannot load WHAT (PATH): WHY" (then "; HINT" where a hint is given)
  /// where it cannot be opened.
  SharedLibrary(std::string path, const std::string& what, const std::string& hint = "");

  /// The address of `name`; throws std::runtime_error "PATH: no symbol NAME" (then " (HINT)" where given)
  /// where the library has none.
  void* symbol(const char* name, const std::string& hint = "") const;

  /// symbol(name) as a pointer to a function of type F.
  template <class F>
  F function(const char* name, const std::string& hint = "") const {
    return reinterpret_cast<F>(symbol(name, hint));
  }

 private:
  std::string path_;
  void* handle_ = nullptr;
};

}  // namespace orbcal::sim
