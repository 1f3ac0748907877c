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

/// The largest length a robot, scene or error file may give (m): 10 km; an arm in space is tens of metres.
inline constexpr double kMaxLengthM = 1e4;
/// The largest joint angle a robot file's limits may give, and so any joint angle orbcal reads (rad):
/// ten turns, 20 pi (a robot YAML's min_deg / max_deg within +-3600 deg, a URDF's <limit>).
inline constexpr double kMaxJointAngleRad = 62.831853071795865;
/// That bound as messages state it.
inline constexpr const char* kMaxJointAngleText = "-62.83 rad to 62.83 rad (ten turns)";
/// An arm's temperature (degC), measured or simulated: from a space arm in the shade (-150 degC) to
/// above a motor winding's insulation limit (class H, 180 degC).
inline constexpr double kMinTemperatureC = -150.0, kMaxTemperatureC = 200.0;

/// `text` as it may appear on a terminal: control bytes, C1 controls and bytes that are not valid
/// UTF-8 become \xNN (so binary junk from an input is never echoed raw, and a message stays one
/// line); valid UTF-8 text is kept. Longer than `max_chars` bytes: cut there and "..." appended.
/// Every message that quotes input goes through it (InputError applies it to its whole message).
std::string printable(const std::string& text, std::size_t max_chars = std::string::npos);
/// printable(text, 40): how a value from an input is quoted in a one-line message.
inline std::string quoteInput(const std::string& text) { return "'" + printable(text, 40) + "'"; }

/// Bad input from a file or the command line: the message names the file and the key. The message
/// is passed through printable(), so it is one line without raw control bytes.
struct InputError : std::runtime_error {
  explicit InputError(const std::string& what) : std::runtime_error(printable(what)) {}
};

/// Text of a file, or of a built-in file when `path` is "builtin:NAME" (see builtinFileNames()).
/// Throws InputError("<path>: cannot read: <reason>").
std::string readTextSource(const std::string& path);
/// readTextSource(path) for a path that another file named at a key (`named_by`: "<file>: <key>", e.g.
/// "desc.yaml: files[1]"): the "cannot read" message starts with it, so it says which file and key named
/// the one missing. An empty `named_by` adds nothing.
std::string readTextNamedBy(const std::string& path, const std::string& named_by);
/// Names of the built-in files (the YAML files under scenes/ compiled into the program).
std::string builtinFileNames();

class ConfigNode {
 public:
  /// Parses `text`; `source` names the file in messages. Throws InputError on a YAML syntax error, a
  /// key given twice in one map (yaml-cpp would keep the first silently) and an empty value (`key:`,
  /// `~`, `null`, an empty sequence item): never read as a default.
  static ConfigNode parse(const std::string& text, const std::string& source);
  /// readTextSource + parse.
  static ConfigNode load(const std::string& path);

  bool has(const std::string& key) const;
  /// Child by key; throws InputError "<file>: <path>.<key>: missing" when absent.
  ConfigNode operator[](const std::string& key) const;
  /// Child by key, or an undefined node (has() false) when absent.
  ConfigNode optional(const std::string& key) const;
  /// Present (parse() rejects empty values, so a present node is never null).
  bool defined() const { return node_.IsDefined() && !node_.IsNull(); }
  bool isScalar() const { return node_.IsDefined() && node_.IsScalar(); }
  bool isSequence() const { return node_.IsDefined() && node_.IsSequence(); }
  bool isMap() const { return node_.IsDefined() && node_.IsMap(); }
  /// Sequence element; throws unless this is a sequence with index < size().
  ConfigNode operator[](std::size_t index) const;
  std::size_t size() const;  ///< sequence length; throws unless a sequence
  /// The keys of a map in file order; throws unless this is a map.
  std::vector<std::string> keys() const;

  double asDouble() const;  ///< finite number, else InputError
  /// A finite number within [lo, hi], the physical range of the key (`range` says what it is, e.g.
  /// "0.001 m to 100 m"); else InputError "<file>: <key>: <value> is outside <range>".
  double asDoubleWithin(double lo, double hi, const std::string& range) const;
  int asInt() const;
  bool asBool() const;
  std::string asString() const;
  double asDouble(double fallback) const { return defined() ? asDouble() : fallback; }
  int asInt(int fallback) const { return defined() ? asInt() : fallback; }
  bool asBool(bool fallback) const { return defined() ? asBool() : fallback; }
  std::string asString(const std::string& fallback) const { return defined() ? asString() : fallback; }
  /// A sequence of exactly n finite numbers.
  Eigen::VectorXd asVector(int n) const;
  /// asVector(n), each entry within [lo, hi] (asDoubleWithin at its own index, e.g. "com_m[2]").
  Eigen::VectorXd asVectorWithin(int n, double lo, double hi, const std::string& range) const;
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
