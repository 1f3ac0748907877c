// Image and table files for measurement.hpp (the vision library's I/O edge).
#include <cctype>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <system_error>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/image_files.hpp"
#include "orbcal/vision/measurement.hpp"

namespace orbcal::vision {

namespace {
/// True for a PNG without its end chunk or a JPEG without its end marker (a file cut short by a full
/// disk or a killed writer): such a file is refused before OpenCV decodes it, because libpng and
/// libjpeg print their own complaints on the terminal.
bool truncatedImage(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string head(8, '\0'), tail(12, '\0');
  if (!in.read(&head[0], 8)) return false;
  in.seekg(-12, std::ios::end);
  if (!in.read(&tail[0], 12)) return false;
  if (head == "\x89PNG\r\n\x1a\n") return tail != std::string("\0\0\0\0IEND\xAE\x42\x60\x82", 12);
  if (head.compare(0, 2, "\xFF\xD8") == 0) return tail.compare(10, 2, "\xFF\xD9") != 0;
  return false;
}
}  // namespace

cv::Mat readGrayImage(const std::string& path, std::string* reason, std::string* detail) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    if (reason) *reason = "file missing";
    if (detail) *detail = path + ": no such file";
    return {};
  }
  if (truncatedImage(path)) {
    if (reason) *reason = "cannot decode";
    if (detail) *detail = path + ": truncated (no end marker)";
    return {};
  }
  cv::Mat gray;
  try {
    gray = sim::readImage(path, cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception& e) {
    gray.release();
  }
  if (gray.empty() || gray.type() != CV_8UC1) {
    if (reason) *reason = "cannot decode";
    if (detail) *detail = path + ": not a readable image (truncated or not an image format OpenCV reads)";
    return {};
  }
  return gray;
}

std::vector<Measurement> measureDataset(const sim::Dataset& dataset, const MeasureSettings& settings,
                                        const std::function<void(int, int)>& progress) {
  std::vector<Measurement> rows;
  const int total = static_cast<int>(dataset.samples.size());
  for (const sim::DatasetSample& s : dataset.samples) {
    std::string reason, detail;
    const cv::Mat gray = readGrayImage(dataset.path(s.image), &reason, &detail);
    Measurement m;
    if (gray.empty()) {
      m.status = ImageStatus::kUnreadable;
      m.reason = reason;
      m.detail = detail;
    } else {
      try {
        m = measureImage(gray, dataset.scene, dataset.arm, s.q_rad, settings);
      } catch (const cv::Exception& e) {
        m = Measurement{};
        m.status = ImageStatus::kRejected;
        m.reason = "detector error";
        std::string what = e.what();
        while (!what.empty() && std::isspace(static_cast<unsigned char>(what.back()))) what.pop_back();
        m.detail = measurementCell(what);
      }
    }
    m.index = s.index;
    m.image = s.image;
    rows.push_back(std::move(m));
    if (progress) progress(static_cast<int>(rows.size()), total);
  }
  return rows;
}

std::vector<Measurement> loadMeasurements(const std::string& path) {
  return parseMeasurementsCsv(sim::readTextSource(path), path);
}

}  // namespace orbcal::vision
