// `orbcal merge-datasets`: the shards of `orbcal render --shard` joined into one dataset folder
// (sim::mergeDatasetShards, sim/dataset.hpp).
#include <unistd.h>

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "cli.hpp"
#include "orbcal/sim/dataset.hpp"
#include "progress.hpp"

namespace orbcal::tools {

namespace {
void addMergeDatasetsCommand(CLI::App& app) {
  struct Opts {
    std::vector<std::string> shards;
    std::string out;
  };
  auto opt = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand(
      "merge-datasets",
      "Join the finished shards of one dataset (orbcal render --shard i/N) into one dataset folder: the same files "
      "rendering it in one go writes (one manifest, one samples.csv in index order; images hard-linked when on the same "
      "file system, else copied). Refused, naming the shard folder: an unfinished shard, shards of different inputs, a "
      "missing or overlapping shard.");
  cmd->add_option("shards", opt->shards, "the shard folders (any order)")->required();
  cmd->add_option("-o,--out", opt->out, "the merged dataset folder (must not exist; written atomically)")->required();
  cmd->callback([opt] {
    setInterruptNote(opt->out + " is not written and the shards are unchanged (" + opt->out + ".tmp-" +
                     std::to_string(::getpid()) + " may be left: remove it); rerun the same command to merge");
    std::unique_ptr<Progress> images;
    const sim::MergeReport r = sim::mergeDatasetShards(opt->shards, opt->out, [&](int done, int total) {
      if (!images) images = std::make_unique<Progress>("merge", total);
      images->update(done);
    });
    if (images) images->finish();
    std::printf("%s: %d samples from %d shards (%d images hard-linked, %d copied)\n", opt->out.c_str(), r.samples,
                r.shards, r.linked, r.copied);
  });
}
}  // namespace

ORBCAL_COMMAND(31, addMergeDatasetsCommand);

}  // namespace orbcal::tools
