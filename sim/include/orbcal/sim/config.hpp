#pragma once
// Reading human-written YAML with errors that name the file and the key, e.g.
//   "scenes/ssrms.yaml: joints[2].d_m: expected a number, got 'abc'".
// Every loader in orbcal (robot, scene, render settings) reads through ConfigNode.
#include <yaml-cpp/yaml.h>

#include <Eigen/Geometry>
#include <stdexcept>
#include <string>
#include <vector>

namespace orbcal::sim {

/// Bad input from a file or the command line: the message names the file and the key.
struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Text of a file, or of a built-in file when `path` is "builtin:NAME" (see builtinFileNames()).
/// Throws InputError("<path>: cannot read: <reason>").
std::string readTextSource(const std::string& path);
/// Names of the built-in files (the YAML files under scenes/ compiled into the program).
std::string builtinFileNames();

class ConfigNode {
 public:
  /// Parses `text`; `source` names the file in messages. Throws InputError on a YAML syntax error.
  static ConfigNode parse(const std::string& text, const std::string& source);
  /// readTextSource + parse.
  static ConfigNode load(const std::string& path);

  bool has(const std::string& key) const;
  /// Child by key; throws InputError "<file>: <path>.<key>: missing" when absent.
  ConfigNode operator[](const std::string& key) const;
  /// Child by key, or an undefined node (has() false) when absent.
  ConfigNode optional(const std::string& key) const;
  bool defined() const { return node_.IsDefined() && !node_.IsNull(); }
  bool isScalar() const { return node_.IsDefined() && node_.IsScalar(); }
  bool isSequence() const { return node_.IsDefined() && node_.IsSequence(); }
  bool isMap() const { return node_.IsDefined() && node_.IsMap(); }
  /// Sequence element; throws unless this is a sequence with index < size().
  ConfigNode operator[](std::size_t index) const;
  std::size_t size() const;  ///< sequence length; throws unless a sequence

  double asDouble() const;  ///< finite number, else InputError
  int asInt() const;
  bool asBool() const;
  std::string asString() const;
  double asDouble(double fallback) const { return defined() ? asDouble() : fallback; }
  int asInt(int fallback) const { return defined() ? asInt() : fallback; }
  bool asBool(bool fallback) const { return defined() ? asBool() : fallback; }
  std::string asString(const std::string& fallback) const { return defined() ? asString() : fallback; }
  /// A sequence of exactly n finite numbers.
  Eigen::VectorXd asVector(int n) const;
  /// A rigid transform written as {xyz_m: [x, y, z], rpy_deg: [roll, pitch, yaw]}, R = Rz Ry Rx.
  Eigen::Isometry3d asTransform() const;

  /// Throws InputError "<file>: <path>: <what>" for a value that parsed but is out of range.
  [[noreturn]] void fail(const std::string& what) const;
  /// Throws unless every key of this map is in `allowed` (catches misspelt keys).
  void requireOnlyKeys(std::initializer_list<const char*> allowed) const;
  void requireOnlyKeys(const std::vector<std::string>& allowed) const;

  const std::string& source() const { return source_; }
  const std::string& path() const { return path_; }

 private:
  ConfigNode(YAML::Node node, std::string source, std::string path)
      : node_(std::move(node)), source_(std::move(source)), path_(std::move(path)) {}
  std::string childPath(const std::string& key) const;
  YAML::Node node_;
  std::string source_;
  std::string path_;
};

}  // namespace orbcal::sim
