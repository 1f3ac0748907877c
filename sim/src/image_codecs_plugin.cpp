// The image codecs plugin (image_files.hpp): OpenCV's imgcodecs behind image_codecs.hpp's table.
#include <opencv2/imgcodecs.hpp>

#include "image_codecs.hpp"

namespace {

cv::Mat read(const std::string& path, int flags) { return cv::imread(path, flags); }

bool write(const std::string& path, const cv::Mat& image, const std::vector<int>& params) { return cv::imwrite(path, image, params); }

bool encode(const std::string& extension, const cv::Mat& image, std::vector<unsigned char>& bytes, const std::vector<int>& params) {
  return cv::imencode(extension, image, bytes, params);
}

const orbcal::sim::ImageCodecs kCodecs{read, write, encode};

}  // namespace

extern "C" __attribute__((visibility("default"))) const orbcal::sim::ImageCodecs* orbcal_image_codecs() { return &kCodecs; }
