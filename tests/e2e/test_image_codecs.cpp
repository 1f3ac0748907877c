// Image files through OpenCV's codecs loaded on first use (sim/image_files.hpp): no program links them
// (they bring GDAL and ~140 libraries to every start), nor OSMesa (LLVM; render/src/gl_api.hpp), images
// still round-trip, and a plugin that cannot be loaded is named in one line with what to do.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "orbcal/sim/image_files.hpp"
#include "test_util.hpp"

using namespace orbcal;
using Catch::Matchers::Contains;
using Catch::Matchers::StartsWith;

namespace {

/// The output of a shell command (stdout and stderr) and its exit status.
std::pair<int, std::string> run(const std::string& command) {
  std::string out;
  FILE* p = ::popen((command + " 2>&1").c_str(), "r");
  REQUIRE(p);
  char buf[4096];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, p)) > 0;) out.append(buf, n);
  const int status = ::pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

}  // namespace

TEST_CASE("image files: the orbcal program links no image codecs and no OSMesa, which load on first use", "[e2e][images]") {
  const auto [status, needed] = run("readelf -d '" + std::string(ORBCAL_BINARY) + "'");
  REQUIRE(status == 0);
  REQUIRE_THAT(needed, Contains("libopencv_core"));  // the listing is the program's
  CHECK_THAT(needed, !Contains("imgcodecs") && !Contains("gdal") && !Contains("OSMesa") && !Contains("LLVM"));

  const std::string dir = test::tempDir("image-codecs");
  cv::Mat image(48, 64, CV_8UC3);
  cv::randu(image, 0, 255);
  REQUIRE(sim::writeImage(dir + "/a.png", image));
  const cv::Mat back = sim::readImage(dir + "/a.png", cv::IMREAD_UNCHANGED);
  REQUIRE(back.size() == image.size());
  CHECK(cv::norm(back, image, cv::NORM_INF) == 0.0);  // PNG is lossless
  std::vector<unsigned char> bytes;
  REQUIRE(sim::encodeImage(".png", image, bytes));
  CHECK(cv::imdecode(bytes, cv::IMREAD_UNCHANGED).size() == image.size());
  CHECK(sim::readImage(dir + "/missing.png", cv::IMREAD_UNCHANGED).empty());
}

TEST_CASE("image files: a plugin that cannot be loaded is named, with what to do, and the command fails", "[e2e][images]") {
  const std::string dir = test::tempDir("image-codecs-missing");
  const auto [status, out] = run("ORBCAL_IMAGE_CODECS=/nonexistent/codecs.so '" + std::string(ORBCAL_BINARY) + "' render --scene '" +
                                 test::sourcePath("scenes/quick_scene.yaml") + "' -n 2 -o '" + dir + "/dataset'");
  CHECK(status == 1);
  CHECK_THAT(out, StartsWith("orbcal: cannot load OpenCV's image codecs (/nonexistent/codecs.so): ") &&
                      Contains("set ORBCAL_IMAGE_CODECS to the plugin's path"));
  CHECK(std::count(out.begin(), out.end(), '\n') == 1);
  CHECK_FALSE(std::filesystem::exists(dir + "/dataset/images/000000.png"));
}
