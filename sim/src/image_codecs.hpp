#pragma once
// The interface between image_files.cpp and the plugin it opens (image_codecs_plugin.cpp), both built
// from this tree by the same compiler: C++ types pass through a table of plain function pointers.
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

namespace orbcal::sim {

struct ImageCodecs {
  cv::Mat (*read)(const std::string& path, int flags);
  bool (*write)(const std::string& path, const cv::Mat& image, const std::vector<int>& params);
  bool (*encode)(const std::string& extension, const cv::Mat& image, std::vector<unsigned char>& bytes, const std::vector<int>& params);
};

}  // namespace orbcal::sim

/// The plugin's one exported symbol: its table (static storage).
extern "C" const orbcal::sim::ImageCodecs* orbcal_image_codecs();
