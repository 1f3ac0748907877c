#pragma once
// Image files (PNG, JPEG, ...) read, written and encoded by OpenCV's image codecs, which are loaded on
// first use: OpenCV's imgcodecs library brings GDAL and about 140 other libraries, whose loading took
// about 0.15 s of every start of a program that links it, a tracker log's diagnosis as much as an
// image command. They live in a plugin of ours (liborbcal_image_codecs.so, built beside the programs;
// ORBCAL_IMAGE_CODECS in the environment names another), opened by the first call. The flags and
// parameters are OpenCV's (cv::IMREAD_*, cv::IMWRITE_*: opencv2/imgcodecs.hpp).
#include <string>
#include <vector>

namespace cv {
class Mat;
}

namespace orbcal::sim {

/// cv::imread(path, flags): an empty matrix where the file cannot be read or decoded.
cv::Mat readImage(const std::string& path, int flags);

/// cv::imwrite(path, image, params): false where OpenCV could not write it.
bool writeImage(const std::string& path, const cv::Mat& image, const std::vector<int>& params = {});

/// cv::imencode(extension, image, bytes, params), e.g. ".png": false where OpenCV could not encode it.
bool encodeImage(const std::string& extension, const cv::Mat& image, std::vector<unsigned char>& bytes,
                 const std::vector<int>& params = {});

}  // namespace orbcal::sim
