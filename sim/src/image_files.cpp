#include "orbcal/sim/image_files.hpp"

#include <cstdlib>

#include "image_codecs.hpp"
#include "orbcal/sim/shared_library.hpp"

namespace orbcal::sim {

namespace {

/// The plugin's table, opened by the first call (a failed opening is tried again by the next).
const ImageCodecs& codecs() {
  static const ImageCodecs* const table = [] {
    const char* env = std::getenv("ORBCAL_IMAGE_CODECS");
    const SharedLibrary plugin(env && *env ? env : ORBCAL_IMAGE_CODECS_PLUGIN, "OpenCV's image codecs",
                               "build the target orbcal_image_codecs, or set ORBCAL_IMAGE_CODECS to the plugin's path");
    return plugin.function<const ImageCodecs* (*)()>("orbcal_image_codecs", "not orbcal's image codecs plugin")();
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
