// `orbcal render --configs FILE --profile FILE` on the command line: the configurations `orbcal configs`
// wrote are the ones rendered, each image goes through the profile, bad input is one line naming the file.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/io.hpp"
#include "run_orbcal.hpp"

using namespace orbcal;
using Catch::Matchers::Contains;

TEST_CASE("orbcal render --configs --profile renders the given configurations through the profile", "[e2e][render]") {
  const std::string dir = test::tempDir("e2e-render-given");
  REQUIRE(test::runOrbcal(dir, "configs -n 2 --seed 4 -o c.csv").status == 0);
  std::ofstream(dir + "/p.yaml") << "format: orbcal-camera-profile-1\nbackground: {mean_dn: 99}\n";
  const test::OrbcalRun run = test::runOrbcal(dir, "render --configs c.csv --profile p.yaml -o ds");
  CAPTURE(run.out, run.err);
  REQUIRE(run.status == 0);
  const sim::Dataset ds = sim::loadDataset(dir + "/ds");
  const std::vector<Eigen::VectorXd> q = sim::parseConfigurationsCsv(sim::readTextSource(dir + "/c.csv"), "c.csv", ds.arm.numJoints());
  REQUIRE(ds.samples.size() == 2);
  for (std::size_t k = 0; k < 2; ++k) {
    CHECK((ds.samples[k].q_rad - q[k]).cwiseAbs().maxCoeff() == 0.0);  // exact: the CSV holds them bit for bit
    const cv::Mat img = cv::imread(ds.path(ds.samples[k].image), cv::IMREAD_UNCHANGED);
    CHECK(img.at<unsigned char>(0, 0) == 99);  // the profile's background (the scene's is 0)
  }
  // --count with --configs, a profile with a misspelt key, a CSV without a joint column: one line, non-zero.
  const test::OrbcalRun both = test::runOrbcal(dir, "render --configs c.csv -n 3 -o ds2");
  CHECK(both.status != 0);
  CHECK_THAT(both.err, Contains("--count"));
  std::ofstream(dir + "/bad.yaml") << "format: orbcal-camera-profile-1\ntone: {gama: 2}\n";
  const test::OrbcalRun bad = test::runOrbcal(dir, "render --profile bad.yaml -n 1 -o ds3");
  CHECK(bad.status != 0);
  CHECK_THAT(bad.err, Contains("bad.yaml") && Contains("gama"));
  std::ofstream(dir + "/short.csv") << "index,q1_rad\n0,0.1\n";
  const test::OrbcalRun short_csv = test::runOrbcal(dir, "render --configs short.csv -o ds4");
  CHECK(short_csv.status != 0);
  CHECK_THAT(short_csv.err, Contains("short.csv") && Contains("q2_rad"));
  CHECK(!std::filesystem::exists(dir + "/ds3"));
  CHECK(!std::filesystem::exists(dir + "/ds4"));
}
