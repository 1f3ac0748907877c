// Image files through OpenCV's codecs loaded on first use (sim/image_files.hpp): no program links them
// (they bring GDAL and ~140 libraries to every start), nor OSMesa (LLVM; render/src/gl_api.hpp), images
// still round-trip, and a plugin that cannot be loaded is named in one line with what to do; the opener
// both go through (sim/shared_library.hpp) names what it could not open or find.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "orbcal/sim/image_files.hpp"
#include "orbcal/sim/shared_library.hpp"
#include "run_orbcal.hpp"
#include "test_util.hpp"

using namespace orbcal;
using Catch::Matchers::Contains;
using Catch::Matchers::StartsWith;

TEST_CASE("image files: the orbcal program links no image codecs and no OSMesa, which load on first use", "[e2e][images]") {
  const std::string dir = test::tempDir("image-codecs");
  REQUIRE(std::system(("readelf -d '" + std::string(ORBCAL_BINARY) + "' > '" + dir + "/dynamic.txt'").c_str()) == 0);
  const std::string needed = test::slurp(dir + "/dynamic.txt");
  REQUIRE_THAT(needed, Contains("libopencv_core"));  // the listing is the program's
  CHECK_THAT(needed, !Contains("imgcodecs") && !Contains("gdal") && !Contains("OSMesa") && !Contains("LLVM"));

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
  ::setenv("ORBCAL_IMAGE_CODECS", "/nonexistent/codecs.so", 1);
  const test::OrbcalRun r = test::runOrbcal(dir, "render --scene '" + test::sourcePath("scenes/quick_scene.yaml") + "' -n 2 -o dataset");
  ::unsetenv("ORBCAL_IMAGE_CODECS");
  const std::string& out = r.err;
  CHECK(r.status == 1);
  CHECK_THAT(out, StartsWith("orbcal: cannot load OpenCV's image codecs (/nonexistent/codecs.so): ") &&
                      Contains("set ORBCAL_IMAGE_CODECS to the plugin's path"));
  CHECK(std::count(out.begin(), out.end(), '\n') == 1);
  CHECK_FALSE(std::filesystem::exists(dir + "/dataset/images/000000.png"));
}

TEST_CASE("shared library: a function is taken by name; a library or symbol that is not there is named", "[e2e][images]") {
  const sim::SharedLibrary libm("libm.so.6", "the C maths library");
  CHECK(libm.function<double (*)(double)>("cos")(0.0) == 1.0);
  CHECK_THROWS_WITH(libm.symbol("orbcal_no_such_function", "not the library asked for"),
                    "libm.so.6: no symbol orbcal_no_such_function (not the library asked for)");
  CHECK_THROWS_WITH(libm.symbol("orbcal_no_such_function"), "libm.so.6: no symbol orbcal_no_such_function");
  CHECK_THROWS_WITH(sim::SharedLibrary("/nonexistent/libx.so", "a plugin", "build it first"),
                    StartsWith("cannot load a plugin (/nonexistent/libx.so): ") && Contains("; build it first"));
  CHECK_THROWS_WITH(sim::SharedLibrary("/nonexistent/libx.so", "a plugin"), !Contains(";"));
}
