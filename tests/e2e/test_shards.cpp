// A shard of a rendered dataset (`orbcal render --shard`) as a dataset on its own: `orbcal calibrate`
// (which measures it first) works on it; and the two commands on the command line.
#include <sys/wait.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "orbcal/workflow/calibrate.hpp"
#include "orbcal/render/dataset_writer.hpp"
#include "orbcal/sim/dataset.hpp"
#include "test_util.hpp"

using namespace orbcal;
using Catch::Matchers::Contains;

namespace {
/// `orbcal ARGS` with stdout and stderr to files under dir; returns the exit code.
int runOrbcal(const std::string& dir, const std::string& args) {
  const std::string cmd = std::string(ORBCAL_BINARY) + " " + args + " > " + dir + "/stdout.txt 2> " + dir + "/stderr.txt";
  const int status = std::system(cmd.c_str());
  REQUIRE(WIFEXITED(status));
  return WEXITSTATUS(status);
}
}  // namespace

TEST_CASE("a shard folder alone is measured and calibrated like any dataset", "[e2e][shard]") {
  // Shard 1 of 2 of an 80-view quick-scene dataset: samples 40..79, indices and image names global.
  render::DatasetJob job;
  job.scene = test::sourcePath("scenes/quick_scene.yaml");
  job.count = 80;
  job.shard = std::make_pair(1, 2);
  job.out = test::tempDir("shard-calibrate") + "/shard";
  render::renderDataset(job);

  workflow::CalibrateOptions o;
  o.dataset = job.out;
  o.quiet = true;
  const workflow::CalibrateResult r = workflow::runCalibrate(o);
  CHECK(r.images == 40);
  CHECK(r.usable >= 38);  // clean rendered views; the planner keeps a 20 px margin
  REQUIRE(r.has_truth);
  CHECK(r.written);
  // The measurements (vision::measureDataset, as `orbcal measure`) keep the global indices 40..79.
  const std::string measurements = test::slurp(job.out + "/measurements.csv");
  CHECK_THAT(measurements, Contains("\n40,") && Contains("\n79,") && !Contains("\n0,") && !Contains("\n39,"));
  // The bar of the unsharded dataset's test (test_calibrate.cpp): 90 % of the held-out error removed.
  CHECK(calib::improvement(r.truth_before.position_avg_m, r.truth_after.position_avg_m) >= 0.90);
}

TEST_CASE("orbcal render --shard and orbcal merge-datasets on the command line", "[e2e][shard]") {
  const std::string dir = test::tempDir("shard-cli");
  const std::string scene = test::sourcePath("scenes/quick_scene.yaml");
  // A shard that does not exist: one line naming --shard, exit code 1, nothing written.
  CHECK(runOrbcal(dir, "render -n 4 --scene " + scene + " --shard 2/2 -o " + dir + "/bad") != 0);
  const std::string err = test::slurp(dir + "/stderr.txt");
  CHECK_THAT(err, Contains("--shard") && Contains("2/2"));
  CHECK(std::count(err.begin(), err.end(), '\n') == 1);
  CHECK(!std::filesystem::exists(dir + "/bad"));

  for (const char* i : {"0", "1"}) {
    REQUIRE(runOrbcal(dir, "render -n 5 --scene " + scene + " --shard " + i + "/2 -o " + dir + "/s" + i) == 0);
  }
  REQUIRE(runOrbcal(dir, "merge-datasets " + dir + "/s1 " + dir + "/s0 -o " + dir + "/merged") == 0);
  CHECK_THAT(test::slurp(dir + "/stdout.txt"), Contains("5 samples from 2 shards"));
  const sim::Dataset d = sim::loadDataset(dir + "/merged");
  CHECK(d.manifest.num_samples == 5);
  CHECK(!d.manifest.shard);
  REQUIRE(d.samples.size() == 5);
  for (int k = 0; k < 5; ++k) CHECK(d.samples[k].index == k);
  // The same shards again into the same folder: refused, the folder left as it was.
  CHECK(runOrbcal(dir, "merge-datasets " + dir + "/s0 " + dir + "/s1 -o " + dir + "/merged") != 0);
  CHECK_THAT(test::slurp(dir + "/stderr.txt"), Contains(dir + "/merged") && Contains("already exists"));
  // "OUT/" names OUT (the temporary folder goes beside it, not into it).
  REQUIRE(runOrbcal(dir, "merge-datasets " + dir + "/s0 " + dir + "/s1 -o " + dir + "/slash/") == 0);
  CHECK(sim::loadDataset(dir + "/slash").samples.size() == 5);
  CHECK(test::slurp(dir + "/slash/samples.csv") == test::slurp(dir + "/merged/samples.csv"));
  CHECK(runOrbcal(dir, "merge-datasets --help") == 0);
  CHECK_THAT(test::slurp(dir + "/stdout.txt"), Contains("--out") && Contains("shard"));
}
