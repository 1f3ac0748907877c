// sim::mergeDatasetShards: the shards of `orbcal render --shard` put back together (sim/dataset.hpp).
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <sstream>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/fileio.hpp"

namespace orbcal::sim {

namespace {

namespace fs = std::filesystem;

struct Shard {
  std::string dir;
  Dataset data;                              ///< manifest (with its shard), arm, scene, samples
  std::map<std::string, std::uintmax_t> files;  ///< input files: path inside the folder ('/'-separated) -> size
  std::string header;                        ///< the samples file's header line
  std::vector<std::string> rows;             ///< its rows as written (parsing and printing again would not
                                             ///< give the rotation vectors' last bits back)
  bool whole = false;                        ///< a dataset without the shard key: shard 0 of 1
  const DatasetShard& shard() const { return *data.manifest.shard; }
  std::string name() const {
    return dir + (whole ? " (a whole dataset)"
                        : " (shard " + std::to_string(shard().index) + "/" + std::to_string(shard().count) + ")");
  }
};

std::string sampleRange(int first, int end) {
  return end - first == 1 ? "sample " + std::to_string(first)
                          : "samples " + std::to_string(first) + ".." + std::to_string(end - 1);
}

std::string joined(const std::vector<std::string>& items) {
  std::string s;
  for (const std::string& i : items) s += (s.empty() ? "" : ", ") + i;
  return s;
}

/// A path inside the folder: relative, without "..".
bool insideFolder(const std::string& relative) {
  const fs::path p(relative);
  if (p.empty() || p.has_root_path()) return false;
  return std::none_of(p.begin(), p.end(), [](const fs::path& part) { return part == ".."; });
}

/// The shard's input files: every regular file below its folder except manifest.yaml, the samples
/// file, its images (and anything else in images/), the lock file and sim::writeFileAtomic's temporary
/// files (NAME.tmp.PID).
std::map<std::string, std::uintmax_t> inputFiles(const std::string& dir, const Dataset& d) {
  std::set<std::string> images;
  for (const DatasetSample& s : d.samples) images.insert(fs::path(s.image).lexically_normal().generic_string());
  std::map<std::string, std::uintmax_t> files;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string relative = it->path().lexically_relative(dir).generic_string();
    std::error_code ec_entry;
    if (it->is_directory(ec_entry)) {
      if (relative == "images") it.disable_recursion_pending();
      continue;
    }
    const std::string name = it->path().filename().string();
    if (relative == "manifest.yaml" || relative == d.manifest.samples_file || images.count(relative) > 0 ||
        name == kFolderLockName || name.find(".tmp.") != std::string::npos || !it->is_regular_file(ec_entry)) {
      continue;
    }
    files.emplace(relative, it->file_size(ec_entry));
    if (ec_entry) throw InputError(it->path().string() + ": cannot read: " + ec_entry.message());
  }
  if (ec) throw InputError(dir + ": cannot list the folder: " + ec.message());
  return files;
}

/// Byte for byte (sizes compared first by the caller).
bool sameBytes(const std::string& a, const std::string& b) {
  std::ifstream fa(a, std::ios::binary), fb(b, std::ios::binary);
  if (!fa || !fb) throw InputError((fa ? b : a) + ": cannot read");
  std::vector<char> ba(1 << 16), bb(1 << 16);
  for (;;) {
    fa.read(ba.data(), static_cast<std::streamsize>(ba.size()));
    fb.read(bb.data(), static_cast<std::streamsize>(bb.size()));
    if (fa.gcount() != fb.gcount() || !std::equal(ba.begin(), ba.begin() + fa.gcount(), bb.begin())) return false;
    if (fa.gcount() == 0 || !fa || !fb) return fa.eof() && fb.eof();
  }
}

/// Reads one shard folder and checks it on its own: a finished shard whose rows are its samples, in
/// order, each with its image.
Shard readShard(const std::string& dir) {
  Shard s;
  s.dir = dir;
  const std::string manifest_path = dir + "/manifest.yaml";
  DatasetManifest m = parseManifest(readTextSource(manifest_path), manifest_path);
  std::error_code ec;
  if (!fs::exists(dir + "/" + m.samples_file, ec)) {
    throw InputError(dir + ": unfinished " +
                     (m.shard ? "shard " + std::to_string(m.shard->index) + "/" + std::to_string(m.shard->count)
                              : std::string("dataset")) +
                     " (no " + m.samples_file + "): rerun its orbcal render command to finish it");
  }
  s.data = loadDataset(dir);
  if (s.data.samples.empty()) throw InputError(s.data.path(m.samples_file) + ": no samples to merge");
  if (!s.data.manifest.shard) {  // a whole dataset: shard 0 of 1 (so that one unsharded render merges too)
    s.whole = true;
    s.data.manifest.shard = datasetShard(0, 1, std::max(1, s.data.manifest.num_samples), "shard");
  }
  const DatasetShard& sh = *s.data.manifest.shard;
  const std::string samples_path = s.data.path(m.samples_file);
  // The lines as sim::CsvTable reads them (a byte order mark and CR line ends dropped, blank lines skipped).
  {
    std::string text = readTextSource(samples_path);
    if (text.compare(0, 3, "\xEF\xBB\xBF") == 0) text.erase(0, 3);
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) {
      if (!line.empty() && line.back() == '\r') line.pop_back();
      if (s.header.empty()) {
        s.header = line;
      } else if (line.find_first_not_of(" \t") != std::string::npos) {
        s.rows.push_back(line);
      }
    }
    if (s.rows.size() != s.data.samples.size()) throw InputError(samples_path + ": cannot split into its rows");
  }
  for (std::size_t k = 0; k < s.data.samples.size(); ++k) {
    const DatasetSample& sample = s.data.samples[k];
    const int expected = sh.first_sample + static_cast<int>(k);
    if (sample.index != expected) {
      throw InputError(samples_path + ": row " + std::to_string(k + 1) + ": index " + std::to_string(sample.index) +
                       ", but " + s.name() + " holds " + sampleRange(sh.first_sample, sh.end_sample) +
                       " in order (expected " + std::to_string(expected) + ")");
    }
    if (!insideFolder(sample.image)) {
      throw InputError(samples_path + ": sample " + std::to_string(sample.index) + ": image " + quoteInput(sample.image) +
                       " is not inside the folder");
    }
    if (!fs::is_regular_file(s.data.path(sample.image), ec)) {
      throw InputError(s.data.path(sample.image) + ": missing (the image of sample " + std::to_string(sample.index) +
                       " in " + samples_path + ")");
    }
  }
  s.files = inputFiles(dir, s.data);
  return s;
}

/// Throws unless `s` is a shard of the same dataset as `ref`: the same manifest but for the shard key and
/// num_samples, the same dataset size, the same input files byte for byte.
void checkSameDataset(const Shard& ref, const Shard& s) {
  DatasetManifest a = ref.data.manifest, b = s.data.manifest;
  a.shard.reset(), b.shard.reset();
  a.num_samples = b.num_samples = 0;
  std::vector<std::string> differ = manifestDifferences(a, b);
  if (ref.header != s.header) differ.emplace_back(s.data.manifest.samples_file + " header");
  if (ref.shard().dataset_samples != s.shard().dataset_samples) differ.emplace_back("shard.dataset_samples");
  if (!differ.empty()) {
    throw InputError(s.dir + "/manifest.yaml: differs from " + ref.dir + "/manifest.yaml (" + joined(differ) +
                     "): not shards of one dataset");
  }
  for (const auto& [relative, size] : ref.files) {
    const auto it = s.files.find(relative);
    if (it == s.files.end()) {
      throw InputError(s.dir + ": has no " + relative + " (" + ref.dir + " has): not shards of one dataset");
    }
    if (it->second != size || !sameBytes(ref.dir + "/" + relative, s.dir + "/" + relative)) {
      throw InputError(s.dir + "/" + relative + ": differs from " + ref.dir + "/" + relative + ": not shards of one dataset");
    }
  }
  for (const auto& [relative, size] : s.files) {
    if (ref.files.count(relative) == 0) {
      throw InputError(s.dir + "/" + relative + ": not in " + ref.dir + ": not shards of one dataset");
    }
  }
}

/// Throws unless the shards (sorted by first sample) hold every sample of the dataset exactly once.
void checkCoverage(const std::vector<const Shard*>& sorted) {
  const int total = sorted.front()->shard().dataset_samples;
  const auto missing = [&](int first, int end, const std::string& where) {
    throw InputError(where + ": " + sampleRange(first, end) + " of " + std::to_string(total) +
                     " are in none of the shards given: a shard is missing");
  };
  int next = 0;
  const Shard* previous = nullptr;
  for (const Shard* s : sorted) {
    const DatasetShard& sh = s->shard();
    if (sh.first_sample > next) {
      missing(next, sh.first_sample, previous ? "between " + previous->name() + " and " + s->name()
                                              : "before " + s->name() + ", the first given");
    }
    if (sh.first_sample < next) {
      throw InputError(s->name() + ": its " + sampleRange(sh.first_sample, sh.end_sample) + " overlap " +
                       previous->name() + "'s in " + sampleRange(sh.first_sample, std::min(next, sh.end_sample)));
    }
    next = sh.end_sample;
    previous = s;
  }
  if (next < total) missing(next, total, "after " + previous->name() + ", the last given");
}


}  // namespace

MergeReport mergeDatasetShards(const std::vector<std::string>& shard_dirs, const std::string& out_as_given,
                               const std::function<void(int, int)>& progress) {
  if (shard_dirs.empty()) throw InputError("merge-datasets: no shard folders given");
  if (out_as_given.empty()) throw InputError("--out: the merged dataset folder must be given");
  // "OUT/" names OUT: the temporary folder goes beside it, not into it.
  std::string out = out_as_given;
  while (out.size() > 1 && out.back() == '/') out.pop_back();
  if (fs::path(out).filename().empty() || out == "." || out == "..") {
    throw InputError(out_as_given + ": name a new folder for the merged dataset");
  }
  std::error_code ec;
  if (fs::exists(fs::symlink_status(out, ec))) {
    throw InputError(out + ": already exists; the merged dataset goes to a new folder (remove it or choose another -o)");
  }
  // Every shard is locked while it is read and linked from (a render --force of it waits for us).
  std::vector<std::unique_ptr<FolderLock>> locks;
  std::vector<Shard> shards;
  std::map<std::string, std::string> given;  // canonical folder -> as given
  for (const std::string& dir : shard_dirs) {
    if (!fs::is_directory(dir, ec)) throw InputError(dir + ": no such folder");
    const auto [it, fresh] = given.emplace(fs::weakly_canonical(dir, ec).string(), dir);
    if (!fresh) throw InputError(dir + ": given twice (also as " + it->second + ")");
    if (!fs::exists(dir + "/manifest.yaml", ec)) throw InputError(dir + ": no manifest.yaml: not a dataset folder");
    locks.push_back(std::make_unique<FolderLock>(dir, "orbcal merge-datasets"));
    shards.push_back(readShard(dir));
  }
  for (std::size_t k = 1; k < shards.size(); ++k) checkSameDataset(shards[0], shards[k]);
  std::vector<const Shard*> sorted;
  for (const Shard& s : shards) sorted.push_back(&s);
  std::sort(sorted.begin(), sorted.end(), [](const Shard* a, const Shard* b) {
    return a->shard().first_sample < b->shard().first_sample ||
           (a->shard().first_sample == b->shard().first_sample && a->shard().end_sample < b->shard().end_sample);
  });
  checkCoverage(sorted);

  // Built beside `out` (so that the rename is atomic), flushed, renamed into place.
  const Shard& ref = shards[0];
  const int total = ref.shard().dataset_samples;
  StagedFolder staged(out);
  const std::string& tmp = staged.path();
  MergeReport report;
  report.shards = static_cast<int>(shards.size());
  report.samples = total;
  const auto copy = [](const std::string& from, const std::string& to) {
    std::error_code e;
    if (!fs::copy_file(from, to, e) || e) throw InputError(to + ": cannot copy " + from + " here: " + e.message());
  };
  for (const auto& [relative, size] : ref.files) {
    makeDirectories(fs::path(tmp + "/" + relative).parent_path().string());
    copy(ref.dir + "/" + relative, tmp + "/" + relative);
  }
  DatasetManifest manifest = ref.data.manifest;
  manifest.shard.reset();
  manifest.num_samples = total;
  std::string samples_text = ref.header + "\n";
  std::set<std::string> folders;  // image folders made so far
  int done = 0;
  for (const Shard* s : sorted) {
    for (const std::string& row : s->rows) samples_text += row + "\n";
    for (const DatasetSample& sample : s->data.samples) {
      const std::string from = s->data.path(sample.image), to = tmp + "/" + sample.image;
      const std::string folder = fs::path(to).parent_path().string();
      if (folders.insert(folder).second) makeDirectories(folder);
      std::error_code e;
      fs::create_hard_link(from, to, e);
      if (e) {
        copy(from, to);  // another file system, or one without hard links
        ++report.copied;
      } else {
        ++report.linked;
      }
      if (progress) progress(++done, total);
    }
  }
  writeFileAtomic(tmp + "/" + manifest.samples_file, samples_text);
  writeFileAtomic(tmp + "/manifest.yaml", formatManifest(manifest));
  staged.commit();
  syncFileSystem(out);
  return report;
}

}  // namespace orbcal::sim
