#include <algorithm>
#include "orbcal/sim/dataset.hpp"

#include "orbcal/sim/joint_limits.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <sstream>
#include <stdexcept>

#include "orbcal/sim/arm.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/flange_poses.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/measured.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::sim {

namespace {
/// Human units (deg, mm) with 12 significant digits: 0.3 deg prints as 0.3.
std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.12g", v);
  return buf;
}
}  // namespace

namespace {
/// A seed: a whole number from 0 that fits 64 bits, written as digits (a double would round seeds
/// above 2^53, and a cast of a negative or huge one is undefined).
std::uint64_t readSeed(const ConfigNode& n) {
  const std::string text = n.asString();
  const bool digits = !text.empty() && text.size() <= 20 && text.find_first_not_of("0123456789") == std::string::npos;
  if (!digits || (text.size() == 20 && text > "18446744073709551615")) {
    n.fail("expected a whole number from 0 to 18446744073709551615, got " + quoteInput(text));
  }
  return std::stoull(text);
}

/// The manifest keeps angles in degrees and lengths in mm for people (12 significant digits), so a
/// value read back differs from the one written by up to 1e-12 relative: compare within that.
bool sameValue(double a, double b) { return std::abs(a - b) <= 1e-11 * std::max(std::abs(a), std::abs(b)); }
}  // namespace

bool DatasetShard::operator==(const DatasetShard& o) const {
  return index == o.index && count == o.count && first_sample == o.first_sample && end_sample == o.end_sample &&
         dataset_samples == o.dataset_samples;
}

DatasetShard datasetShard(int index, int count, int dataset_samples, const std::string& what) {
  const std::string spec = std::to_string(index) + "/" + std::to_string(count);
  if (count < 1) throw InputError(what + ": " + spec + ": the number of shards must be at least 1");
  if (index < 0 || index >= count) {
    throw InputError(what + ": " + spec + ": shard " + std::to_string(index) + " of " + std::to_string(count) +
                     " does not exist (shards are numbered 0 to " + std::to_string(count - 1) + ")");
  }
  if (count > dataset_samples) {
    throw InputError(what + ": " + spec + ": " + std::to_string(count) + " shards of " + std::to_string(dataset_samples) +
                     " samples would leave some empty (at most one shard per sample)");
  }
  DatasetShard s;
  s.index = index;
  s.count = count;
  s.dataset_samples = dataset_samples;
  const auto bound = [&](int i) {
    return static_cast<int>(static_cast<std::int64_t>(i) * dataset_samples / count);  // floor: both non-negative
  };
  s.first_sample = bound(index);
  s.end_sample = bound(index + 1);
  return s;
}

std::pair<int, int> parseShardSpec(const std::string& text, const std::string& what) {
  const auto slash = text.find('/');
  const auto whole = [](const std::string& t) {
    return !t.empty() && t.size() <= 9 && t.find_first_not_of("0123456789") == std::string::npos;
  };
  if (slash == std::string::npos || !whole(text.substr(0, slash)) || !whole(text.substr(slash + 1))) {
    throw InputError(what + ": expected i/N (shard i of N, numbered from 0), got " + quoteInput(text));
  }
  const int index = std::stoi(text.substr(0, slash)), count = std::stoi(text.substr(slash + 1));
  if (count < 1) throw InputError(what + ": " + quoteInput(text) + ": the number of shards must be at least 1");
  if (index >= count) {
    throw InputError(what + ": " + quoteInput(text) + ": shard " + std::to_string(index) + " of " + std::to_string(count) +
                     " does not exist (shards are numbered 0 to " + std::to_string(count - 1) + ")");
  }
  return {index, count};
}

bool DatasetManifest::operator==(const DatasetManifest& o) const {
  bool errors_equal = true_errors.has_value() == o.true_errors.has_value();
  if (errors_equal && true_errors) {
    errors_equal = true_errors->size() == o.true_errors->size() && true_errors_per_joint == o.true_errors_per_joint;
    for (Eigen::Index i = 0; errors_equal && i < true_errors->size(); ++i) {
      errors_equal = sameValue((*true_errors)[i], (*o.true_errors)[i]);
    }
  }
  return format == o.format && program_version == o.program_version && robot_file == o.robot_file &&
         scene_file == o.scene_file && samples_file == o.samples_file && num_samples == o.num_samples &&
         errors_equal && error_set == o.error_set && error_set_file == o.error_set_file &&
         sameValue(joint_noise_sigma_rad, o.joint_noise_sigma_rad) &&
         configuration_seed == o.configuration_seed && noise_seed == o.noise_seed && render_seed == o.render_seed &&
         shard == o.shard;
}

std::vector<std::string> manifestDifferences(const DatasetManifest& a, const DatasetManifest& b) {
  std::vector<std::string> d;
  const auto check = [&](bool same, const char* field) {
    if (!same) d.emplace_back(field);
  };
  check(a.format == b.format, "format");
  check(a.program_version == b.program_version, "program_version");
  check(a.robot_file == b.robot_file, "robot");
  check(a.scene_file == b.scene_file, "scene");
  check(a.samples_file == b.samples_file, "samples");
  check(a.num_samples == b.num_samples, "num_samples");
  check(sameValue(a.joint_noise_sigma_rad, b.joint_noise_sigma_rad), "joint_noise_deg");
  check(a.configuration_seed == b.configuration_seed, "seeds.configurations");
  check(a.noise_seed == b.noise_seed, "seeds.joint_noise");
  check(a.render_seed == b.render_seed, "seeds.render");
  check(a.error_set == b.error_set, "true_errors.name");
  check(a.error_set_file == b.error_set_file, "true_errors.file");
  DatasetManifest errors_only_a, errors_only_b;  // operator== on the true errors alone
  errors_only_a.true_errors = a.true_errors, errors_only_a.true_errors_per_joint = a.true_errors_per_joint;
  errors_only_b.true_errors = b.true_errors, errors_only_b.true_errors_per_joint = b.true_errors_per_joint;
  check(errors_only_a == errors_only_b, "true_errors.joints");
  check(a.shard == b.shard, "shard");
  if (d.empty() && !(a == b)) d.emplace_back("manifest.yaml");  // a field this list does not know yet
  return d;
}

std::string formatManifest(const DatasetManifest& m) {
  std::ostringstream s;
  s << "# orbcal calibration dataset (layout: docs/file-formats.md, 'Dataset layout')\n";
  s << "format: " << m.format << "\n";
  if (!m.program_version.empty()) s << "program_version: " << m.program_version << "\n";  // an empty value is an error
  s << "robot: " << m.robot_file << "\n";
  s << "scene: " << m.scene_file << "\n";
  s << "samples: " << m.samples_file << "\n";
  s << "num_samples: " << m.num_samples << "\n";
  if (m.shard) {
    s << "shard: {index: " << m.shard->index << ", count: " << m.shard->count << ", first_sample: " << m.shard->first_sample
      << ", end_sample: " << m.shard->end_sample << ", dataset_samples: " << m.shard->dataset_samples
      << "}   # samples first_sample..end_sample-1 of dataset_samples (orbcal render --shard)\n";
  }
  s << "joint_noise_deg: " << num(m.joint_noise_sigma_rad * kRadToDeg) << "\n";
  s << "seeds: {configurations: " << m.configuration_seed << ", joint_noise: " << m.noise_seed
    << ", render: " << m.render_seed << "}\n";
  if (m.true_errors) {
    s << "true_errors:   # injected into the plant, per joint (y order); angles in deg, lengths in mm\n";
    s << "  name: " << (m.error_set.empty() ? "custom" : m.error_set) << "\n";
    if (!m.error_set_file.empty()) s << "  file: " << m.error_set_file << "   # the error-set file: these + its effects\n";
    s << "  joints:\n";
    const Eigen::VectorXd& y = *m.true_errors;
    const int per_joint = m.true_errors_per_joint;
    const Arm table = errorTableArm(per_joint);
    for (int j = 0; j < static_cast<int>(y.size()) / per_joint; ++j) s << "    - " << errorRowYaml(table, y, j, num) << "\n";
  }
  return s.str();
}

DatasetManifest parseManifest(const std::string& text, const std::string& source) {
  const ConfigNode root = ConfigNode::parse(text, source);
  root.requireOnlyKeys({"format", "program_version", "robot", "scene", "samples", "num_samples", "joint_noise_deg",
                        "seeds", "true_errors", "shard"});
  DatasetManifest m;
  m.format = root["format"].asString();
  if (m.format != kDatasetFormat) root["format"].fail("expected '" + std::string(kDatasetFormat) + "', got " + quoteInput(m.format));
  m.program_version = root.optional("program_version").asString("");
  m.robot_file = root["robot"].asString();
  m.scene_file = root["scene"].asString();
  m.samples_file = root["samples"].asString();
  m.num_samples = root["num_samples"].asInt();
  if (m.num_samples < 0) root["num_samples"].fail("must not be negative");
  if (const ConfigNode shard = root.optional("shard"); shard.defined()) {
    shard.requireOnlyKeys({"index", "count", "first_sample", "end_sample", "dataset_samples"});
    const int samples = shard["dataset_samples"].asInt();
    if (samples < 1) shard["dataset_samples"].fail("must be at least 1");
    DatasetShard expected;
    try {
      expected = datasetShard(shard["index"].asInt(), shard["count"].asInt(), samples, "shard");
    } catch (const InputError& e) {
      shard["index"].fail(e.what());
    }
    for (const auto& [key, value] : {std::pair<const char*, int>{"first_sample", expected.first_sample},
                                     std::pair<const char*, int>{"end_sample", expected.end_sample}}) {
      if (shard[key].asInt() != value) {
        shard[key].fail("expected " + std::to_string(value) + " for shard " + std::to_string(expected.index) + " of " +
                        std::to_string(expected.count) + " of " + std::to_string(samples) + " samples");
      }
    }
    if (m.num_samples != expected.size()) {
      root["num_samples"].fail("expected " + std::to_string(expected.size()) + ", the samples of its shard");
    }
    m.shard = expected;
  }
  if (const ConfigNode noise = root.optional("joint_noise_deg"); noise.defined()) {
    m.joint_noise_sigma_rad = noise.asDoubleWithin(0.0, kMaxNoiseJointDeg, "0 to 10 deg (1 sigma; 0: readings exact)") * kDegToRad;
  }
  const ConfigNode seeds = root.optional("seeds");
  if (seeds.defined()) {
    seeds.requireOnlyKeys({"configurations", "joint_noise", "render"});
    for (const auto& [key, seed] : {std::pair<const char*, std::uint64_t*>{"configurations", &m.configuration_seed},
                                    {"joint_noise", &m.noise_seed}, {"render", &m.render_seed}}) {
      if (seeds.has(key)) *seed = readSeed(seeds[key]);
    }
  }
  const ConfigNode te = root.optional("true_errors");
  if (te.defined()) {
    te.requireOnlyKeys({"name", "file", "joints"});
    m.error_set = te.optional("name").asString("custom");
    m.error_set_file = te.optional("file").asString("");
    const ConfigNode joints = te["joints"];
    // Rows with beta_deg (a Hayati arm's) carry 5 errors, rows with x_mm (a URDF arm's) 7; then every
    // row must have the same keys.
    m.true_errors_per_joint = joints.size() > 0 ? errorTablePerJoint(joints[0]) : 4;
    const Arm table = errorTableArm(m.true_errors_per_joint);
    Eigen::VectorXd y(static_cast<Eigen::Index>(joints.size()) * m.true_errors_per_joint);
    for (std::size_t j = 0; j < joints.size(); ++j) readErrorRow(joints[j], table, static_cast<int>(j), y);
    m.true_errors = y;
  }
  return m;
}

namespace {
const char* kPoseColumns[6] = {"cam_board_x_m", "cam_board_y_m", "cam_board_z_m",
                               "cam_board_rx_rad", "cam_board_ry_rad", "cam_board_rz_rad"};

/// How far a true joint (simulation: the reading plus the joint noise) may lie outside the limits:
/// 6 sigma of the largest joint noise a manifest states (a draw beyond it: once in 5e8).
constexpr double kTrueJointMarginRad = 6.0 * kMaxNoiseJointDeg * kDegToRad;

/// Throws unless the image path stays inside the dataset folder: relative, and no `..` that leaves it.
void checkImagePath(const CsvTable& t, std::size_t r, const std::string& image) {
  const std::filesystem::path p = std::filesystem::path(image).lexically_normal();
  if (p.is_absolute() || p.has_root_name() || p.has_root_directory() || (!p.empty() && *p.begin() == "..")) {
    throw InputError(t.where(r) + ": image: " + quoteInput(image) +
                     " leaves the dataset folder (image paths are relative to it and stay inside)");
  }
}

/// The simulation-truth columns of row r: true joints within the limits widened by
/// kTrueJointMarginRad, the camera-board pose within 10 km and a rotation vector of at most one turn.
void checkTruthColumns(const CsvTable& t, std::size_t r, const std::vector<int>& c_qt, const std::vector<int>& c_pose,
                       const Arm* limits) {
  for (std::size_t j = 0; limits && j < c_qt.size(); ++j) {
    const Eigen::Index i = static_cast<Eigen::Index>(j);
    const double lo = limits->lower_rad[i] - kTrueJointMarginRad, hi = limits->upper_rad[i] + kTrueJointMarginRad;
    if (t.cell(r, c_qt[j]).empty() || (t.number(r, c_qt[j]) >= lo && t.number(r, c_qt[j]) <= hi)) continue;
    throw InputError(t.where(r) + ": " + t.header()[static_cast<std::size_t>(c_qt[j])] + ": " +
                     formatNumber("%.9g", t.number(r, c_qt[j])) + " rad is outside the joint limits of " + limits->source +
                     " widened by 60 deg (6 sigma of the largest joint noise), " + formatNumber("%.9g", lo) + " to " +
                     formatNumber("%.9g", hi) + " rad");
  }
  const auto pose = t.numbers(r, c_pose);
  if (!pose) return;
  for (int i = 0; i < 3; ++i) {
    if (std::abs((*pose)[i]) > kMaxLengthM) {
      throw InputError(t.where(r) + ": " + kPoseColumns[i] + ": " + formatNumber("%.9g", (*pose)[i]) +
                       " m is outside -10000 m to 10000 m");
    }
  }
  if (pose->tail<3>().norm() > 2.0 * kPi) {
    throw InputError(t.where(r) + ": " + kPoseColumns[3] + ".." + kPoseColumns[5] + ": a rotation vector of " +
                     formatNumber("%.9g", pose->tail<3>().norm()) + " rad, more than one turn (2 pi rad)");
  }
}
}  // namespace

std::string formatSamplesCsv(const std::vector<DatasetSample>& samples, int n) {
  bool has_true = false, has_pose = false;
  for (const auto& s : samples) {
    has_true |= s.q_true_rad.has_value();
    has_pose |= s.camera_T_board_true.has_value();
  }
  const bool by_pose = !samples.empty() && samples.front().base_T_flange.has_value();
  if (by_pose) n = 0;
  std::ostringstream out;
  out << "index,image";
  if (by_pose) {
    for (const char* c : kFlangePoseColumns) out << "," << c;
  }
  for (int j = 1; j <= n; ++j) out << ",q" << j << "_rad";
  if (has_true) {
    for (int j = 1; j <= n; ++j) out << ",q" << j << "_true_rad";
  }
  if (has_pose) {
    for (const char* c : kPoseColumns) out << "," << c;
  }
  out << "\n";
  for (const auto& s : samples) {
    out << s.index << "," << s.image;
    if (by_pose) {
      if (!s.base_T_flange) throw std::logic_error("formatSamplesCsv: flange poses given for some samples only");
      const Eigen::Matrix<double, 7, 1> v = flangePoseValues(*s.base_T_flange);
      for (int i = 0; i < 7; ++i) out << "," << exactNumber(v[i]);
    }
    for (int j = 0; j < n; ++j) out << "," << exactNumber(s.q_rad[j]);
    if (has_true) {
      for (int j = 0; j < n; ++j) out << "," << (s.q_true_rad ? exactNumber((*s.q_true_rad)[j]) : "");
    }
    if (has_pose) {
      if (s.camera_T_board_true) {
        const Vector6d v = poseToVector(*s.camera_T_board_true);
        for (int i = 0; i < 6; ++i) out << "," << exactNumber(v[i]);
      } else {
        out << ",,,,,,";
      }
    }
    out << "\n";
  }
  return out.str();
}

std::vector<DatasetSample> parseSamplesCsv(const std::string& text, const std::string& source, int n, const Arm* limits) {
  const CsvTable t = CsvTable::parse(text, source);
  const int c_index = t.requireColumn("index"), c_image = t.requireColumn("image");
  std::vector<int> c_q, c_qt, c_pose, c_flange;
  if (t.column(kFlangePoseColumns[0]) >= 0) {  // views given by flange poses: no joints
    for (const char* c : kFlangePoseColumns) c_flange.push_back(t.requireColumn(c));
    if (t.column("q1_rad") >= 0) throw InputError(source + ": header: both joint readings (q1_rad) and flange poses (flange_x_m)");
    n = 0;
  }
  for (int j = 1; j <= n; ++j) c_q.push_back(t.requireColumn("q" + std::to_string(j) + "_rad"));
  if (t.column("q" + std::to_string(n + 1) + "_rad") >= 0) {
    throw InputError(source + ": header: column 'q" + std::to_string(n + 1) + "_rad' but the robot has " +
                     std::to_string(n) + " joints");
  }
  if (t.column("q1_true_rad") >= 0) {
    for (int j = 1; j <= n; ++j) c_qt.push_back(t.requireColumn("q" + std::to_string(j) + "_true_rad"));
  }
  if (t.column(kPoseColumns[0]) >= 0) {
    for (const char* c : kPoseColumns) c_pose.push_back(t.requireColumn(c));
  }
  std::vector<DatasetSample> samples;
  std::map<int, int> index_line;           // sample index -> line of its first row
  std::map<std::string, int> image_line;   // image -> line of its first row
  for (std::size_t r = 0; r < t.rows(); ++r) {
    DatasetSample s;
    s.index = t.wholeNumber(r, c_index);
    const int line = t.line(r);
    checkIndexOnce(t, r, c_index, index_line, "sample");
    s.image = t.cell(r, c_image);
    if (s.image.empty()) throw InputError(t.where(r) + ": image: empty");
    checkImagePath(t, r, s.image);
    if (const auto [it, fresh] = image_line.emplace(s.image, line); !fresh) {
      throw InputError(t.where(r) + ": image: " + quoteInput(s.image) + " given twice (first on line " +
                       std::to_string(it->second) + ")");
    }
    if (!c_flange.empty()) {
      const auto v = t.numbers(r, c_flange);
      if (!v) throw InputError(t.where(r) + ": flange_x_m: the flange pose is empty");
      s.base_T_flange = flangePoseFromValues(*v, t.where(r));
    }
    const auto q = c_flange.empty() ? t.numbers(r, c_q) : std::optional<Eigen::VectorXd>(Eigen::VectorXd());
    if (!q) throw InputError(t.where(r) + ": q1_rad: joint readings are empty");
    s.q_rad = *q;
    for (int j = 0; limits && j < n; ++j) {
      const double v = (*q)[j];
      if (!clearlyOutsideLimits(*limits, j, v)) continue;  // within the limits, or past one by a reading's slack (nearLimitWarnings)
      throw InputError(t.where(r) + ": q" + std::to_string(j + 1) + "_rad: " + formatNumber("%.9g", v) + " " + jointSiUnit(*limits, j) +
                       " (" + formatJointValue(*limits, j, v) + ") " + outsideLimitsText(*limits, j));
    }
    checkTruthColumns(t, r, c_qt, c_pose, limits);
    s.q_true_rad = t.numbers(r, c_qt);
    if (const auto pose = t.numbers(r, c_pose)) s.camera_T_board_true = poseFromVector(*pose);
    samples.push_back(std::move(s));
  }
  return samples;
}

Dataset loadDataset(const std::string& folder) {
  Dataset d;
  d.folder = folder;
  const std::string manifest_path = folder + "/manifest.yaml";
  d.manifest = parseManifest(readTextSource(manifest_path), manifest_path);
  d.arm = loadArm(RobotSource{d.path(d.manifest.robot_file), "", ""}, manifest_path + ": robot");
  (void)readTextNamedBy(d.path(d.manifest.scene_file), manifest_path + ": scene");  // a missing scene names the key (read twice: a few kB)
  d.scene = loadScene(d.path(d.manifest.scene_file));
  const std::string samples_path = d.path(d.manifest.samples_file);
  d.samples = parseSamplesCsv(readTextNamedBy(samples_path, manifest_path + ": samples"), samples_path, d.arm.numJoints(), &d.arm);
  if (static_cast<int>(d.samples.size()) != d.manifest.num_samples) {
    throw InputError(manifest_path + ": num_samples: " + std::to_string(d.manifest.num_samples) + ", but " +
                     d.manifest.samples_file + " has " + std::to_string(d.samples.size()) + " rows");
  }
  if (d.manifest.true_errors && d.manifest.true_errors_per_joint != d.arm.paramsPerJoint()) {
    throw InputError(manifest_path + ": true_errors.joints: rows of " + std::to_string(d.manifest.true_errors_per_joint) +
                     " errors, but " + d.manifest.robot_file + " is " + conventionName(d.arm.convention) + " with " +
                     std::to_string(d.arm.paramsPerJoint()) + " a joint");
  }
  if (d.manifest.true_errors && d.manifest.true_errors->size() != d.arm.numParams()) {
    throw InputError(manifest_path + ": true_errors.joints: expected " + std::to_string(d.arm.numJoints()) +
                     " joints (as " + d.manifest.robot_file + "), got " +
                     std::to_string(d.manifest.true_errors->size() / d.manifest.true_errors_per_joint));
  }
  return d;
}

bool viewsByFlangePose(const Dataset& d) { return !d.samples.empty() && d.samples.front().base_T_flange.has_value(); }

void requireJointReadings(const Dataset& d, const std::string& what) {
  if (!viewsByFlangePose(d)) return;
  throw InputError(d.path(d.manifest.samples_file) + ": its views are flange poses, without joint readings, which " + what +
                   " needs: `orbcal calibrate " + d.path(kImagesDescriptionFile) + "` estimates the hand-eye and board frames");
}

void writeDatasetTables(const Dataset& d, int num_joints) {
  writeFileAtomic(d.path(d.manifest.samples_file), formatSamplesCsv(d.samples, num_joints));
  writeFileAtomic(d.folder + "/manifest.yaml", formatManifest(d.manifest));
}

}  // namespace orbcal::sim
