// `orbcal render --shard i/N` and sim::mergeDatasetShards: the shards of a dataset, merged, are the dataset
// rendered in one go, file for file and byte for byte; bad shard sets are refused naming the folder.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <map>
#include <tuple>
#include <unistd.h>

#include "orbcal/render/dataset_writer.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "test_util.hpp"

using namespace orbcal;
using Catch::Matchers::Contains;
namespace fs = std::filesystem;

namespace {

/// The quick scene (640 x 512) with read noise on, so that each image's noise must come from its own
/// global sample index, and a plant whose poses depend on the sample index (drift and warm-up with the
/// time t_k = 15 k) and on the sample before (backlash of joint 3: the approach direction).
struct ShardInputs {
  std::string scene, errors;
};

ShardInputs writeInputs(const std::string& dir) {
  std::string scene = sim::readTextSource(test::sourcePath("scenes/quick_scene.yaml"));
  const std::string quiet = "  read_noise_dn: 0.0";
  const auto at = scene.find(quiet);
  REQUIRE(at != std::string::npos);
  scene.replace(at, quiet.size(), "  read_noise_dn: 1.5");
  ShardInputs in{dir + "/scene.yaml", dir + "/errors.yaml"};
  test::write(in.scene, scene);
  test::write(in.errors, R"(format: orbcal-errors-1
geometry: table3
effects:
  - {spec: "thermal", parameters: {alpha_thermal: 2.3e-5}}
  - {spec: "backlash:3", parameters: {b3: 1.0e-3}}
  - {spec: "drift", parameters: {drift_vx: 2.0e-5, drift_vy: 0, drift_vz: 0, drift_wx: 0, drift_wy: 1.0e-6, drift_wz: 0}}
covariates:
  temperature: {start_C: 18, rise_C: 10, tau_s: 60}
  sample_period_s: 15
)");
  return in;
}

render::DatasetJob job(const ShardInputs& in, int count, const std::string& out) {
  render::DatasetJob j;
  j.scene = in.scene;
  j.errors.name = in.errors;
  j.count = count;
  j.configuration_seed = 21, j.noise_seed = 22, j.render_seed = 23;
  j.joint_noise_sigma_rad = 0.05 * sim::kDegToRad;
  j.out = out;
  return j;
}

render::DatasetJob shardJob(const ShardInputs& in, int count, const std::string& out, int i, int n) {
  render::DatasetJob j = job(in, count, out);
  j.shard = std::make_pair(i, n);
  return j;
}

/// Every regular file below `dir`: path relative to it -> bytes.
std::map<std::string, std::string> folderFiles(const std::string& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (e.is_regular_file()) files[e.path().lexically_relative(dir).generic_string()] = test::slurp(e.path().string());
  }
  return files;
}

/// Where a merge that failed could have left files: OUT and OUT.tmp-PID.
bool leftSomething(const std::string& out) {
  const fs::path p(out);
  for (const auto& e : fs::directory_iterator(p.parent_path())) {
    if (e.path().filename().string().rfind(p.filename().string(), 0) == 0) return true;
  }
  return false;
}

}  // namespace

TEST_CASE("a dataset rendered as shards and merged is the dataset rendered in one go, byte for byte",
          "[render][dataset][shard]") {
  const std::string dir = test::tempDir("render-shards");
  const ShardInputs in = writeInputs(dir);
  // 12 samples in 3 shards of 4; 11 in 3 shards of floor(11 i / 3): [0, 3), [3, 7), [7, 11).
  for (const auto& [count, bounds] : {std::pair<int, std::vector<int>>{12, {0, 4, 8, 12}},
                                      std::pair<int, std::vector<int>>{11, {0, 3, 7, 11}}}) {
    CAPTURE(count);
    const std::string base = dir + "/n" + std::to_string(count);
    render::renderDataset(job(in, count, base + "/whole"));
    std::vector<std::string> shards;
    for (int i : {2, 0, 1}) {  // any order: each shard computes the whole dataset's sequence itself
      const std::string out = base + "/shard" + std::to_string(i);
      const render::DatasetRunReport r = render::renderDataset(shardJob(in, count, out, i, 3));
      CHECK(r.rendered == bounds[i + 1] - bounds[i]);
      CHECK(r.first_sample == bounds[i]);
      CHECK(r.end_sample == bounds[i + 1]);
      // A dataset folder of its own: it loads, its rows are its samples with their global indices and
      // image names, and its manifest records the shard.
      const sim::Dataset d = sim::loadDataset(out);
      REQUIRE(d.manifest.shard);
      CHECK(d.manifest.shard->index == i);
      CHECK(d.manifest.shard->count == 3);
      CHECK(d.manifest.shard->first_sample == bounds[i]);
      CHECK(d.manifest.shard->end_sample == bounds[i + 1]);
      CHECK(d.manifest.shard->dataset_samples == count);
      CHECK(d.manifest.num_samples == bounds[i + 1] - bounds[i]);
      REQUIRE(static_cast<int>(d.samples.size()) == bounds[i + 1] - bounds[i]);
      for (std::size_t k = 0; k < d.samples.size(); ++k) {
        const int index = bounds[i] + static_cast<int>(k);
        CHECK(d.samples[k].index == index);
        char name[32];
        std::snprintf(name, sizeof name, "images/%06d.png", index);
        CHECK(d.samples[k].image == name);
      }
      CHECK(!fs::exists(out + "/" + sim::kFolderLockName));
      shards.push_back(out);
    }
    const sim::MergeReport m = sim::mergeDatasetShards({shards[2], shards[0], shards[1]}, base + "/merged");
    CHECK(m.samples == count);
    CHECK(m.shards == 3);
    CHECK(m.linked + m.copied == count);
    CHECK(m.linked == count);  // one file system here: hard links
    CHECK(fs::hard_link_count(base + "/merged/images/000000.png") == 2);
    CHECK(!fs::exists(base + "/merged.tmp-" + std::to_string(::getpid())));

    // Every file of the one-go dataset, and no other, with the same bytes: manifest.yaml, samples.csv,
    // robot.yaml, scene.yaml, errors.yaml and every image.
    const auto whole = folderFiles(base + "/whole"), merged = folderFiles(base + "/merged");
    CHECK(whole.size() == static_cast<std::size_t>(count) + 5);
    REQUIRE(whole.size() == merged.size());
    for (const auto& [name, bytes] : whole) {
      CAPTURE(name);
      REQUIRE(merged.count(name) == 1);
      CHECK(merged.at(name) == bytes);
    }
  }
}

TEST_CASE("merging refuses a missing shard, an overlap, another seed, an unfinished shard, naming the folder",
          "[render][dataset][shard]") {
  const std::string dir = test::tempDir("render-shards-refuse");
  const ShardInputs in = writeInputs(dir);
  constexpr int kCount = 6;  // shards of 3: [0, 2), [2, 4), [4, 6); of 2: [0, 3), [3, 6)
  const auto shard = [&](int i, int n) {
    const std::string out = dir + "/s" + std::to_string(i) + "of" + std::to_string(n);
    render::renderDataset(shardJob(in, kCount, out, i, n));
    return out;
  };
  const std::string s0 = shard(0, 3), s1 = shard(1, 3), s2 = shard(2, 3), h1 = shard(1, 2);
  const std::string out = dir + "/merged";
  const auto refused = [&](const std::vector<std::string>& shards) {
    const std::string msg = test::inputError([&] { sim::mergeDatasetShards(shards, out); });
    CHECK(!leftSomething(out));  // no OUT, no OUT.tmp-PID
    return msg;
  };

  SECTION("a missing shard: the samples and the folders around them") {
    const std::string msg = refused({s0, s2});
    CHECK_THAT(msg, Contains(s0) && Contains(s2) && Contains("samples 2..3 of 6") && Contains("missing"));
    CHECK_THAT(refused({s1, s2}), Contains(s1) && Contains("samples 0..1 of 6"));
    CHECK_THAT(refused({s0, s1}), Contains(s1) && Contains("samples 4..5 of 6"));
  }
  SECTION("an overlap: both folders and the samples in both") {
    const std::string msg = refused({s0, s1, s2, h1});
    CHECK_THAT(msg, Contains(h1) && Contains(s1) && Contains("overlap") && Contains("sample 3"));
  }
  SECTION("a shard of another seed: the folder and the manifest fields") {
    render::DatasetJob other = shardJob(in, kCount, dir + "/seed99", 1, 3);
    other.configuration_seed = other.noise_seed = other.render_seed = 99;
    render::renderDataset(other);
    const std::string msg = refused({s0, other.out, s2});
    CHECK_THAT(msg, Contains(other.out + "/manifest.yaml") && Contains("seeds.configurations") &&
                        Contains("seeds.render") && Contains("not shards of one dataset"));
  }
  SECTION("a shard with another input file: the folder and the file") {
    const std::string copy = dir + "/edited";
    fs::copy(s1, copy, fs::copy_options::recursive);
    std::ofstream(copy + "/scene.yaml", std::ios::app) << "# edited\n";
    CHECK_THAT(refused({s0, copy, s2}), Contains(copy + "/scene.yaml") && Contains("differs"));
  }
  SECTION("an unfinished shard: the folder") {
    render::DatasetJob unfinished = shardJob(in, kCount, dir + "/unfinished", 1, 3);
    struct Stop {};
    REQUIRE_THROWS_AS(render::renderDataset(unfinished, [](int done, int) {
                        if (done == 1) throw Stop{};
                      }),
                      Stop);
    REQUIRE(!fs::exists(unfinished.out + "/samples.csv"));
    CHECK_THAT(refused({s0, unfinished.out, s2}), Contains(unfinished.out) && Contains("unfinished"));
  }
  SECTION("a whole dataset with a shard, an image gone, the output folder already there") {
    // A whole dataset is shard 0 of 1: alone it merges into a copy of itself; with a shard it overlaps.
    render::DatasetJob whole = job(in, kCount, dir + "/whole");
    render::renderDataset(whole);
    CHECK_THAT(refused({s1, whole.out}), Contains(whole.out + " (a whole dataset)") && Contains(s1) && Contains("overlap"));
    const sim::MergeReport alone = sim::mergeDatasetShards({whole.out}, out);
    CHECK(alone.samples == kCount);
    CHECK(folderFiles(out) == folderFiles(whole.out));
    fs::remove_all(out);
    const std::string copy = dir + "/no-image";
    fs::copy(s1, copy, fs::copy_options::recursive);
    fs::remove(copy + "/images/000003.png");
    CHECK_THAT(refused({s0, copy, s2}), Contains(copy + "/images/000003.png") && Contains("missing"));
    fs::create_directories(out);
    CHECK_THAT(test::inputError([&] { sim::mergeDatasetShards({s0, s1, s2}, out); }),
               Contains(out) && Contains("already exists"));
    fs::remove(out);
  }
  // The shards are left as they were (the lock taken while reading them is gone again).
  CHECK(!fs::exists(s1 + "/" + sim::kFolderLockName));
  CHECK(sim::loadDataset(s1).samples.size() == 2);
}

TEST_CASE("a shard i/N outside 0 <= i < N <= count is an InputError naming --shard", "[render][dataset][shard][badinput]") {
  for (const char* bad : {"3/3", "0/0", "1/0", "-1/3", "1", "a/3", "1/3x", "/3", ""}) {
    CAPTURE(bad);
    CHECK_THAT(test::inputError([&] { sim::parseShardSpec(bad, "--shard"); }), Contains("--shard"));
  }
  CHECK(sim::parseShardSpec("2/3", "--shard") == std::make_pair(2, 3));
  // The library checks the same for callers that build the job themselves, and writes nothing.
  const std::string dir = test::tempDir("render-shards-bad");
  const ShardInputs in = writeInputs(dir);
  for (const auto& spec : {std::pair<int, int>{3, 3}, {0, 0}, {-1, 2}, {0, 7}}) {  // 7 shards of 6 samples
    const int i = spec.first, n = spec.second;
    CAPTURE(i, n);
    CHECK_THAT(test::inputError([&] { render::renderDataset(shardJob(in, 6, dir + "/out", i, n)); }), Contains("--shard"));
    CHECK(!fs::exists(dir + "/out"));
  }
  // The shard bounds by hand: floor(i count / N).
  const sim::DatasetShard s = sim::datasetShard(2, 3, 11, "--shard");
  CHECK(s.first_sample == 7);
  CHECK(s.end_sample == 11);
  CHECK(sim::datasetShard(1, 3, 11, "--shard").first_sample == 3);
}

TEST_CASE("a shard folder is refused on resume with another --shard, resumed with the same", "[render][dataset][shard]") {
  const std::string dir = test::tempDir("render-shards-resume");
  const ShardInputs in = writeInputs(dir);
  const render::DatasetJob first = shardJob(in, 6, dir + "/out", 0, 3);
  render::renderDataset(first);
  const std::string manifest = test::slurp(first.out + "/manifest.yaml");
  // The manifest fields that differ, as the message lists them.
  const auto differs = [](const std::string& msg) {
    const auto at = msg.find("(differs: ");
    return at == std::string::npos ? std::string() : msg.substr(at, msg.find(')', at) - at);
  };
  // Another shard of the same dataset, shard 0 of another split, shard 0/3 of 7 samples (the same
  // samples 0..1, of another dataset).
  for (const auto& spec : {std::tuple<int, int, int>{1, 3, 6}, {0, 2, 6}, {0, 3, 7}}) {
    const int i = std::get<0>(spec), n = std::get<1>(spec), count = std::get<2>(spec);
    CAPTURE(i, n, count);
    const std::string msg = test::inputError([&] { render::renderDataset(shardJob(in, count, first.out, i, n)); });
    CHECK_THAT(msg, Contains(first.out + "/manifest.yaml") && Contains("--force"));
    CHECK_THAT(differs(msg), Contains("shard"));
  }
  // Not a shard at all: refused too.
  CHECK_THAT(differs(test::inputError([&] { render::renderDataset(job(in, 6, first.out)); })), Contains("shard"));
  CHECK(test::slurp(first.out + "/manifest.yaml") == manifest);
  const render::DatasetRunReport again = render::renderDataset(first);
  CHECK(again.resumed);
  CHECK(again.skipped == 2);
  CHECK(again.rendered == 0);
}

TEST_CASE("a manifest's shard key must agree with itself and with num_samples", "[render][dataset][shard][badinput]") {
  sim::DatasetManifest m;
  m.program_version = "1";
  m.num_samples = 4;
  m.shard = sim::datasetShard(1, 3, 11, "--shard");
  const std::string text = sim::formatManifest(m);
  CHECK(sim::parseManifest(text, "m.yaml") == m);
  const auto edited = [&](const std::string& from, const std::string& to) {
    std::string t = text;
    const auto at = t.find(from);
    REQUIRE(at != std::string::npos);
    return t.replace(at, from.size(), to);
  };
  CHECK_THAT(test::inputError([&] { sim::parseManifest(edited("first_sample: 3", "first_sample: 4"), "m.yaml"); }),
             Contains("m.yaml") && Contains("shard.first_sample") && Contains("expected 3"));
  CHECK_THAT(test::inputError([&] { sim::parseManifest(edited("num_samples: 4", "num_samples: 11"), "m.yaml"); }),
             Contains("m.yaml") && Contains("num_samples"));
  CHECK_THAT(test::inputError([&] { sim::parseManifest(edited("index: 1", "index: 3"), "m.yaml"); }),
             Contains("m.yaml") && Contains("shard.index"));
}
