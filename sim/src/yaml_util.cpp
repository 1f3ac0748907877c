#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <fstream>
#include <set>
#include <sstream>

#include "orbcal/builtin_files.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::sim {

std::string readTextSource(const std::string& path) {
  static const std::string kBuiltin = "builtin:";
  if (path.rfind(kBuiltin, 0) == 0) {
    const auto& files = builtin::files();
    const auto it = files.find(path.substr(kBuiltin.size()));
    if (it == files.end()) throw InputError(path + ": no such built-in file (built-in: " + builtinFileNames() + ")");
    return it->second;
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot read: no such file or not readable");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw InputError(path + ": cannot read: I/O error");
  return ss.str();
}

std::string readTextNamedBy(const std::string& path, const std::string& named_by) {
  try {
    return readTextSource(path);
  } catch (const InputError& e) {
    if (named_by.empty()) throw;
    throw InputError(named_by + ": " + e.what());
  }
}

std::string builtinFileNames() {
  std::string names;
  for (const auto& [name, text] : builtin::files()) names += (names.empty() ? "" : ", ") + ("builtin:" + name);
  return names;
}

std::string printable(const std::string& text, std::size_t max_chars) {
  std::string out;
  const std::size_t n = std::min(text.size(), max_chars);
  const auto byte = [&](std::size_t i) { return static_cast<unsigned char>(text[i]); };
  const auto escape = [&](unsigned char c) {
    char buf[8];
    std::snprintf(buf, sizeof buf, "\\x%02X", c);
    out += buf;
  };
  for (std::size_t i = 0; i < n;) {
    const unsigned char c = byte(i);
    if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
      ++i;
      continue;
    }
    // A valid UTF-8 sequence (no overlong forms, no surrogates, no C1 controls) is kept whole.
    std::size_t len = c >= 0xC2 && c <= 0xDF ? 2 : c >= 0xE0 && c <= 0xEF ? 3 : c >= 0xF0 && c <= 0xF4 ? 4 : 0;
    bool valid = len > 0 && i + len <= n;
    for (std::size_t k = 1; valid && k < len; ++k) valid = (byte(i + k) & 0xC0) == 0x80;
    if (valid) {
      const unsigned char c1 = byte(i + 1);
      valid = !(c == 0xC2 && c1 < 0xA0) && !(c == 0xE0 && c1 < 0xA0) && !(c == 0xED && c1 >= 0xA0) &&
              !(c == 0xF0 && c1 < 0x90) && !(c == 0xF4 && c1 >= 0x90);
    }
    if (valid) {
      out.append(text, i, len);
      i += len;
    } else {
      escape(c);
      ++i;
    }
  }
  if (text.size() > max_chars) out += "...";
  return out;
}

namespace {
std::string keyPath(const std::string& parent, const std::string& key) { return parent.empty() ? key : parent + "." + key; }

/// Every map of `node` and below: a key given twice, or an empty value, is an InputError naming the
/// file, the line and the key. yaml-cpp keeps both entries of a duplicated key and operator[] returns
/// the first, so without this check `convention: standard` followed by `convention: modified` would
/// silently read as standard.
void checkKeysAndValues(const YAML::Node& node, const std::string& source, const std::string& path) {
  const auto where = [&](const YAML::Mark& mark, const std::string& p) {
    return source + ": " + (mark.is_null() ? std::string() : "line " + std::to_string(mark.line + 1) + ": ") +
           (p.empty() ? std::string("(top level)") : p);
  };
  if (node.IsMap()) {
    std::map<std::string, int> seen;  // key -> line of its first occurrence
    for (const auto& kv : node) {
      const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : std::string("(a non-text key)");
      const std::string p = keyPath(path, printable(key, 40));
      const auto [it, fresh] = seen.emplace(key, kv.first.Mark().line + 1);
      if (!fresh) {
        throw InputError(where(kv.first.Mark(), p) + ": key given twice (first on line " + std::to_string(it->second) +
                         "); remove one");
      }
      if (kv.second.IsNull()) {
        throw InputError(where(kv.first.Mark(), p) +
                         ": empty value");
      }
      checkKeysAndValues(kv.second, source, p);
    }
  } else if (node.IsSequence()) {
    for (std::size_t i = 0; i < node.size(); ++i) {
      const std::string p = path + "[" + std::to_string(i) + "]";
      if (node[i].IsNull()) throw InputError(where(node[i].Mark(), p) + ": empty value");
      checkKeysAndValues(node[i], source, p);
    }
  }
}
}  // namespace

ConfigNode ConfigNode::parse(const std::string& text, const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(source + ": line " + std::to_string(e.mark.line + 1) + ": YAML syntax error: " + e.msg);
  }
  checkKeysAndValues(root, source, "");
  return ConfigNode(root, source, "");
}

ConfigNode ConfigNode::load(const std::string& path) { return parse(readTextSource(path), path); }

std::string ConfigNode::childPath(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

bool ConfigNode::has(const std::string& key) const { return node_.IsMap() && node_[key].IsDefined(); }

ConfigNode ConfigNode::operator[](const std::string& key) const {
  if (!node_.IsMap()) fail("expected a map with key '" + key + "'");
  const YAML::Node child = node_[key];
  if (!child.IsDefined()) throw InputError(source_ + ": " + childPath(key) + ": missing");
  return ConfigNode(child, source_, childPath(key));
}

ConfigNode ConfigNode::optional(const std::string& key) const {
  if (node_.IsDefined() && !node_.IsNull() && !node_.IsMap()) fail("expected a map with key '" + key + "'");
  // An absent node (itself optional and missing) has no type to ask for: its children are absent too.
  YAML::Node child = (node_.IsDefined() && node_.IsMap() ? node_[key] : YAML::Node(YAML::NodeType::Undefined));
  return ConfigNode(child, source_, childPath(key));
}

ConfigNode ConfigNode::operator[](std::size_t index) const {
  if (!node_.IsSequence()) fail("expected a sequence");
  if (index >= node_.size()) fail("index " + std::to_string(index) + " out of range");
  return ConfigNode(node_[index], source_, path_ + "[" + std::to_string(index) + "]");
}

std::size_t ConfigNode::size() const {
  if (!node_.IsSequence()) fail("expected a sequence");
  return node_.size();
}

std::vector<std::string> ConfigNode::keys() const {
  if (!node_.IsMap()) fail("expected a map");
  std::vector<std::string> out;
  for (const auto& kv : node_) out.push_back(kv.first.as<std::string>());
  return out;
}

void ConfigNode::fail(const std::string& what) const {
  throw InputError(source_ + ": " + (path_.empty() ? std::string("(top level)") : path_) + ": " + what);
}

namespace {
std::string scalarText(const YAML::Node& n) {
  if (n.IsScalar()) return quoteInput(n.Scalar());
  if (n.IsSequence()) return "a sequence";
  if (n.IsMap()) return "a map";
  return "nothing";
}
}  // namespace

double ConfigNode::asDouble() const {
  if (!node_.IsDefined() || node_.IsNull()) fail("missing (expected a number)");
  double v = 0.0;
  if (!node_.IsScalar() || !YAML::convert<double>::decode(node_, v)) fail("expected a number, got " + scalarText(node_));
  if (!std::isfinite(v)) fail("expected a finite number, got " + scalarText(node_));
  return v;
}

double ConfigNode::asDoubleWithin(double lo, double hi, const std::string& range) const {
  const double v = asDouble();
  if (!(v >= lo && v <= hi)) fail(scalarText(node_) + " is outside " + range);
  return v;
}

int ConfigNode::asInt() const {
  if (!node_.IsDefined() || node_.IsNull()) fail("missing (expected an integer)");
  int v = 0;
  if (!node_.IsScalar() || !YAML::convert<int>::decode(node_, v)) fail("expected an integer, got " + scalarText(node_));
  return v;
}

bool ConfigNode::asBool() const {
  if (!node_.IsDefined() || node_.IsNull()) fail("missing (expected true or false)");
  bool v = false;
  if (!node_.IsScalar() || !YAML::convert<bool>::decode(node_, v)) fail("expected true or false, got " + scalarText(node_));
  return v;
}

std::string ConfigNode::asString() const {
  if (!node_.IsDefined() || node_.IsNull()) fail("missing (expected text)");
  if (!node_.IsScalar()) fail("expected text, got " + scalarText(node_));
  return node_.Scalar();
}

Eigen::VectorXd ConfigNode::asVector(int n) const {
  if (!node_.IsSequence() || static_cast<int>(node_.size()) != n) {
    fail("expected a sequence of " + std::to_string(n) + " numbers");
  }
  Eigen::VectorXd v(n);
  for (int i = 0; i < n; ++i) v[i] = (*this)[static_cast<std::size_t>(i)].asDouble();
  return v;
}

Eigen::VectorXd ConfigNode::asVectorWithin(int n, double lo, double hi, const std::string& range) const {
  Eigen::VectorXd v = asVector(n);
  for (int i = 0; i < n; ++i) v[i] = (*this)[static_cast<std::size_t>(i)].asDoubleWithin(lo, hi, range);
  return v;
}

Eigen::Isometry3d ConfigNode::asTransform() const {
  requireOnlyKeys({"xyz_m", "rpy_deg"});
  const Eigen::Vector3d xyz = (*this)["xyz_m"].asVectorWithin(3, -kMaxLengthM, kMaxLengthM, "-10000 m to 10000 m");  // kMaxLengthM
  const Eigen::Vector3d rpy = (*this)["rpy_deg"].asVectorWithin(3, -360.0, 360.0, "-360 deg to 360 deg") * kDegToRad;
  return fromXyzRpy(xyz, rpy);
}

void ConfigNode::requireOnlyKeys(std::initializer_list<const char*> allowed) const {
  requireOnlyKeys(std::vector<std::string>(allowed.begin(), allowed.end()));
}

void ConfigNode::requireOnlyKeys(const std::vector<std::string>& allowed) const {
  if (!node_.IsMap()) fail("expected a map");
  const std::set<std::string> ok(allowed.begin(), allowed.end());
  for (const auto& kv : node_) {
    const std::string key = kv.first.as<std::string>();
    if (!ok.count(key)) {
      std::string list;
      for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
      throw InputError(source_ + ": " + childPath(printable(key, 40)) + ": unknown key (expected one of: " + list + ")");
    }
  }
}

}  // namespace orbcal::sim
