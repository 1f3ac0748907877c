#include "orbcal/sim/image_files.hpp"

#include <dlfcn.h>

#include <cstdlib>
#include <stdexcept>

#include "image_codecs.hpp"

namespace orbcal::sim {

namespace {

/// The plugin's table, opened by the first call (a failed opening is tried again by the next).
const ImageCodecs& codecs() {
  static const ImageCodecs* const table = [] {
    const char* env = std::getenv("ORBCAL_IMAGE_CODECS");
    const std::string path = env && *env ? env : ORBCAL_IMAGE_CODECS_PLUGIN;
    void* plugin = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!plugin) {
      const char* why = dlerror();
      throw std::runtime_error("cannot load OpenCV's image codecs (" + path + "): " + (why ? why : "dlopen failed") +
                               "; build the target orbcal_image_codecs, or set ORBCAL_IMAGE_CODECS to the plugin's path");
    }
    const auto entry = reinterpret_cast<const ImageCodecs* (*)()>(dlsym(plugin, "orbcal_image_codecs"));
    if (!entry) throw std::runtime_error(path + ": not orbcal's image codecs plugin (no symbol orbcal_image_codecs)");
    return entry();
  }();
  return *table;
}

}  // namespace

cv::Mat readImage(const std::string& path, int flags) { return codecs().read(path, flags); }

bool writeImage(const std::string& path, const cv::Mat& image, const std::vector<int>& params) {
  return codecs().write(path, image, params);
}

bool encodeImage(const std::string& extension, const cv::Mat& image, std::vector<unsigned char>& bytes, const std::vector<int>& params) {
  return codecs().encode(extension, image, bytes, params);
}

}  // namespace orbcal::sim
