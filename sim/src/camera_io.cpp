#include "orbcal/sim/camera_io.hpp"

#include <cmath>
#include <filesystem>
#include <sstream>

#include "orbcal/sim/csv.hpp"

namespace orbcal::sim {

namespace {

constexpr double kMaxDistortion = 10.0;

/// A matrix written as {rows, cols, data} (ROS) or !!opencv-matrix {rows, cols, dt, data} (OpenCV):
/// its numbers, row-major, after checking rows x cols against `sizes` (accepted shapes).
std::vector<double> readMatrix(const ConfigNode& m, bool opencv, const std::vector<std::pair<int, int>>& sizes) {
  if (!m.isMap()) m.fail("expected a matrix {rows, cols, data}");
  if (opencv) {
    m.requireOnlyKeys({"rows", "cols", "dt", "data"});
    const std::string dt = m["dt"].asString();
    if (dt != "d" && dt != "f") m["dt"].fail("expected d or f (a floating-point matrix), got '" + dt + "'");
  } else {
    m.requireOnlyKeys({"rows", "cols", "data"});
  }
  const int rows = m["rows"].asInt(), cols = m["cols"].asInt();
  bool ok = false;
  std::string expected;
  for (const auto& [r, c] : sizes) {
    ok |= rows == r && cols == c;
    expected += (expected.empty() ? "" : " or ") + std::to_string(r) + "x" + std::to_string(c);
  }
  if (!ok) m.fail("expected a " + expected + " matrix, got " + std::to_string(rows) + "x" + std::to_string(cols));
  const ConfigNode data = m["data"];
  if (!data.isSequence() || static_cast<int>(data.size()) != rows * cols) {
    data.fail("expected " + std::to_string(rows * cols) + " numbers (rows x cols)");
  }
  std::vector<double> v(static_cast<std::size_t>(rows * cols));
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = data[i].asDouble();  // asDouble rejects non-finite values
  return v;
}

/// fx fy cx cy from a row-major 3x3 K without skew; `data` names the entries in messages.
void readCameraMatrix(const std::vector<double>& K, const ConfigNode& data, Camera& c) {
  const auto must = [&](std::size_t i, double value, const char* what) {
    if (K[i] != value) data[i].fail(std::string("expected ") + what + " (orbcal's camera has no skew), got " + exactNumber(K[i]));
  };
  must(1, 0.0, "0");
  must(3, 0.0, "0");
  must(6, 0.0, "0");
  must(7, 0.0, "0");
  must(8, 1.0, "1");
  c.fx_px = K[0];
  c.cx_px = K[2];
  c.fy_px = K[4];
  c.cy_px = K[5];
}

/// k1 k2 p1 p2 k3 from a coefficient list of length 4, 5, 8, 12 or 14 (OpenCV's); coefficients past the
/// fifth must be 0 (the rational and thin-prism terms orbcal's model does not have).
void readDistortion(const std::vector<double>& d, const ConfigNode& data, Camera& c) {
  for (std::size_t i = 0; i < d.size(); ++i) {
    if (i < 5) {
      c.distortion[i] = d[i];
    } else if (d[i] != 0.0) {
      data[i].fail("orbcal's camera is OpenCV's 5-coefficient model (k1 k2 p1 p2 k3): coefficient " + std::to_string(i + 1) +
                   " must be 0, got " + exactNumber(d[i]));
    }
  }
}

/// A ROS rectification matrix R (a rotation: every entry within -1 to 1) and projection matrix
/// P = [fx' 0 cx' Tx; 0 fy' cy' Ty; 0 0 1 0] (sensor_msgs/CameraInfo): fx', fy' within K's focal range,
/// Tx, Ty = -f' B within f' times a baseline of 10 km (kMaxLengthM), every other entry a pixel
/// coordinate within 1e6 px. orbcal uses neither; they are checked so that the file says nothing absurd.
void checkRectification(const ConfigNode& R, const ConfigNode& P) {
  for (std::size_t i = 0; i < 9; ++i) R["data"][i].asDoubleWithin(-1.0, 1.0, "-1 to 1 (an entry of a rotation)");
  const ConfigNode p = P["data"];
  const double fx = p[0].asDoubleWithin(1.0, 1e6, "1 px to 1e6 px (a focal length in pixels)");
  const double fy = p[5].asDoubleWithin(1.0, 1e6, "1 px to 1e6 px (a focal length in pixels)");
  const std::string baseline = " (f' times a baseline within 10 km)";
  p[3].asDoubleWithin(-fx * kMaxLengthM, fx * kMaxLengthM, formatNumber("%.6g", -fx * kMaxLengthM) + " to " +
                                                               formatNumber("%.6g", fx * kMaxLengthM) + baseline);
  p[7].asDoubleWithin(-fy * kMaxLengthM, fy * kMaxLengthM, formatNumber("%.6g", -fy * kMaxLengthM) + " to " +
                                                               formatNumber("%.6g", fy * kMaxLengthM) + baseline);
  for (int i : {1, 2, 4, 6, 8, 9, 10, 11}) p[static_cast<std::size_t>(i)].asDoubleWithin(-1e6, 1e6, "-1e6 px to 1e6 px");
}

std::vector<std::pair<int, int>> vectorShapes(const std::vector<int>& lengths) {
  std::vector<std::pair<int, int>> s;
  for (int n : lengths) {
    s.emplace_back(1, n);
    s.emplace_back(n, 1);
  }
  return s;
}

/// checkCamera on a camera read from a file: each field blamed on the file's key (K's entry, ...).
void checkFileCamera(const Camera& c, const ConfigNode& root, const ConfigNode& K, const ConfigNode& D) {
  checkCamera(c, [&](const std::string& field) -> ConfigNode {
    if (field == "width_px") return root["image_width"];
    if (field == "height_px") return root["image_height"];
    if (field == "distortion") return D["data"];
    const int index = field == "fx_px" ? 0 : field == "cx_px" ? 2 : field == "fy_px" ? 4 : 5;
    return K["data"][static_cast<std::size_t>(index)];
  });
}

Camera parseRos(const ConfigNode& root) {
  root.requireOnlyKeys({"image_width", "image_height", "camera_name", "camera_matrix", "distortion_model",
                        "distortion_coefficients", "rectification_matrix", "projection_matrix",
                        // optional fields of sensor_msgs/CameraInfo some writers add
                        "binning_x", "binning_y", "roi"});
  Camera c;
  c.width_px = root["image_width"].asInt();
  c.height_px = root["image_height"].asInt();
  root["camera_name"].asString();
  const ConfigNode K = root["camera_matrix"];
  readCameraMatrix(readMatrix(K, false, {{3, 3}}), K["data"], c);
  const ConfigNode model = root["distortion_model"];
  const std::string name = model.asString();
  std::vector<int> lengths;
  if (name == "plumb_bob") {
    lengths = {5};
  } else if (name == "rational_polynomial") {
    lengths = {8};
  } else {
    model.fail("unknown distortion model '" + name + "' (expected plumb_bob or rational_polynomial)");
  }
  const ConfigNode D = root["distortion_coefficients"];
  readDistortion(readMatrix(D, false, vectorShapes(lengths)), D["data"], c);
  readMatrix(root["rectification_matrix"], false, {{3, 3}});
  readMatrix(root["projection_matrix"], false, {{3, 4}});
  checkRectification(root["rectification_matrix"], root["projection_matrix"]);
  checkFileCamera(c, root, K, D);
  return c;
}

Camera parseOpenCv(const ConfigNode& root) {
  Camera c;
  c.width_px = root["image_width"].asInt();
  c.height_px = root["image_height"].asInt();
  const ConfigNode K = root["camera_matrix"];
  readCameraMatrix(readMatrix(K, true, {{3, 3}}), K["data"], c);
  const ConfigNode D = root["distortion_coefficients"];
  readDistortion(readMatrix(D, true, vectorShapes({4, 5, 8, 12, 14})), D["data"], c);
  checkFileCamera(c, root, K, D);
  return c;
}

/// "[a, b, c]" with every number written exactly.
std::string list(const std::vector<double>& v) {
  std::string s = "[";
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + exactNumber(v[i]);
  return s + "]";
}

}  // namespace

void checkCamera(const Camera& c, const std::function<ConfigNode(const std::string&)>& key) {
  // Physical ranges, so that an absurd value is named at its key and not found later as "no
  // configuration sees the board". Numbers in messages as people write them (%.6g).
  const auto shown = [](double v) { return formatNumber("%.6g", v); };
  if (c.width_px < 16 || c.width_px > 16384) key("width_px").fail("must be within 16..16384");
  if (c.height_px < 16 || c.height_px > 16384) key("height_px").fail("must be within 16..16384");
  if (!(c.fx_px >= 1.0 && c.fx_px <= 1e6)) key("fx_px").fail("'" + shown(c.fx_px) + "' is outside 1 px to 1e6 px (a focal length in pixels)");
  if (!(c.fy_px >= 1.0 && c.fy_px <= 1e6)) key("fy_px").fail("'" + shown(c.fy_px) + "' is outside 1 px to 1e6 px (a focal length in pixels)");
  // Pixel centres at integers: the image spans [-0.5, size - 0.5].
  if (!(c.cx_px >= -0.5 && c.cx_px <= c.width_px - 0.5)) {
    key("cx_px").fail("'" + shown(c.cx_px) + "' is outside the image, -0.5 to width - 0.5 px");
  }
  if (!(c.cy_px >= -0.5 && c.cy_px <= c.height_px - 0.5)) {
    key("cy_px").fail("'" + shown(c.cy_px) + "' is outside the image, -0.5 to height - 0.5 px");
  }
  for (int i = 0; i < 5; ++i) {
    const bool tangential = i == 2 || i == 3;
    const double limit = tangential ? 1.0 : kMaxDistortion;
    if (!(std::abs(c.distortion[i]) <= limit)) {
      key("distortion").fail("coefficient " + std::to_string(i + 1) + " of k1 k2 p1 p2 k3, '" + shown(c.distortion[i]) + "', is outside " +
                             (tangential ? "-1 to 1 (a tangential coefficient p1, p2)" : "-10 to 10 (a radial coefficient k1, k2, k3)"));
    }
  }
}

Camera parseInlineCamera(const ConfigNode& cam) {
  cam.requireOnlyKeys({"width_px", "height_px", "fx_px", "fy_px", "cx_px", "cy_px", "distortion"});
  Camera c;
  c.width_px = cam["width_px"].asInt();
  c.height_px = cam["height_px"].asInt();
  c.fx_px = cam["fx_px"].asDouble();
  c.fy_px = cam["fy_px"].asDouble();
  c.cx_px = cam["cx_px"].asDouble();
  c.cy_px = cam["cy_px"].asDouble();
  if (cam.has("distortion")) {
    const Eigen::VectorXd k = cam["distortion"].asVector(5);
    for (int i = 0; i < 5; ++i) c.distortion[i] = k[i];
  }
  checkCamera(c, [&](const std::string& field) { return cam[field]; });
  return c;
}

Camera parseCameraFile(const std::string& text, const std::string& source, CameraFileFormat* format) {
  // cv::FileStorage starts its YAML with "%YAML:1.0" (a colon where YAML has a space), which yaml-cpp
  // rejects: drop that line; the "---" after it stays a document start.
  std::string body = text;
  const bool directive = body.rfind("%YAML", 0) == 0;
  if (directive) {
    const std::size_t eol = body.find('\n');
    body = eol == std::string::npos ? std::string() : body.substr(eol + 1);
  }
  const ConfigNode root = ConfigNode::parse(body, source);
  if (!root.isMap()) root.fail("expected a camera file (ROS camera_info or OpenCV FileStorage YAML)");
  const bool opencv = directive || text.find("!!opencv-matrix") != std::string::npos;
  const bool ros = root.has("distortion_model") || root.has("camera_name") || root.has("projection_matrix");
  if (opencv == ros) {
    root.fail(opencv ? "looks like both a ROS camera_info (distortion_model) and an OpenCV FileStorage file (%YAML:1.0)"
                     : "not a camera file: expected a ROS camera_info (camera_name, camera_matrix, distortion_model, ...) "
                       "or an OpenCV FileStorage file (%YAML:1.0, camera_matrix, distortion_coefficients)");
  }
  if (format) *format = opencv ? CameraFileFormat::kOpenCvFileStorage : CameraFileFormat::kRosCameraInfo;
  return opencv ? parseOpenCv(root) : parseRos(root);
}

Camera loadCameraFile(const std::string& path, CameraFileFormat* format) {
  return parseCameraFile(readTextSource(path), path, format);
}

Camera parseSceneCamera(const ConfigNode& cam, const std::string& scene_dir, std::string* resolved_file) {
  if (resolved_file) resolved_file->clear();
  if (!cam.has("file")) return parseInlineCamera(cam);
  cam.requireOnlyKeys({"file"});
  const ConfigNode file = cam["file"];
  const std::string written = file.asString();
  if (written.empty()) file.fail("must not be empty");
  const std::filesystem::path p(written);
  const std::string path = (p.is_absolute() || scene_dir.empty()) ? written : (std::filesystem::path(scene_dir) / p).string();
  if (resolved_file) *resolved_file = path;
  try {
    return loadCameraFile(path);
  } catch (const InputError& e) {
    throw InputError(file.source() + ": " + file.path() + ": " + e.what());
  }
}

std::string formatCameraInfoYaml(const Camera& c, const std::string& camera_name) {
  std::ostringstream s;
  const std::vector<double> K{c.fx_px, 0.0, c.cx_px, 0.0, c.fy_px, c.cy_px, 0.0, 0.0, 1.0};
  const std::vector<double> P{c.fx_px, 0.0, c.cx_px, 0.0, 0.0, c.fy_px, c.cy_px, 0.0, 0.0, 0.0, 1.0, 0.0};
  s << "image_width: " << c.width_px << "\nimage_height: " << c.height_px << "\ncamera_name: " << camera_name
    << "\ncamera_matrix:\n  rows: 3\n  cols: 3\n  data: " << list(K) << "\ndistortion_model: plumb_bob"
    << "\ndistortion_coefficients:\n  rows: 1\n  cols: 5\n  data: "
    << list({c.distortion.begin(), c.distortion.end()})
    << "\nrectification_matrix:\n  rows: 3\n  cols: 3\n  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]"
    << "\nprojection_matrix:\n  rows: 3\n  cols: 4\n  data: " << list(P) << "\n";
  return s.str();
}

std::string formatOpenCvCameraYaml(const Camera& c) {
  std::ostringstream s;
  const std::vector<double> K{c.fx_px, 0.0, c.cx_px, 0.0, c.fy_px, c.cy_px, 0.0, 0.0, 1.0};
  s << "%YAML:1.0\n---\nimage_width: " << c.width_px << "\nimage_height: " << c.height_px
    << "\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: " << list(K)
    << "\ndistortion_coefficients: !!opencv-matrix\n   rows: 5\n   cols: 1\n   dt: d\n   data: "
    << list({c.distortion.begin(), c.distortion.end()}) << "\n";
  return s.str();
}

}  // namespace orbcal::sim
