#include "orbcal/vision/intrinsics.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <opencv2/calib3d.hpp>
#include <sstream>
#include <stdexcept>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/vision/charuco.hpp"
#include "orbcal/vision/circles.hpp"
#include "orbcal/vision/measurement.hpp"

namespace orbcal::vision {

namespace {
// `text` as a YAML double-quoted scalar: backslash, quote and control characters (line breaks from
// an OpenCV message, say) escaped, so that any file name or message reads back unchanged.
std::string quoted(const std::string& text) {
  std::string out = "\"";
  for (const char ch : text) {
    switch (ch) {
      case '\\': out += "\\\\"; break;
      case '"': out += "\\\""; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(ch) < 0x20 || ch == 0x7f) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\x%02x", static_cast<unsigned>(static_cast<unsigned char>(ch)));
          out += buf;
        } else {
          out += ch;
        }
    }
  }
  return out + "\"";
}
}  // namespace

IntrinsicsResult calibrateIntrinsics(const std::vector<BoardView>& views, const cv::Size& image_size,
                                     const sim::Board& board, const IntrinsicsSettings& settings) {
  IntrinsicsResult r;
  r.camera.width_px = image_size.width;
  r.camera.height_px = image_size.height;
  for (const BoardView& v : views) {
    if (v.ids.empty() && static_cast<int>(v.corners_px.size()) != board.numCorners()) {
      throw std::invalid_argument("calibrateIntrinsics: expected " + std::to_string(board.numCorners()) +
                                  " corners per view, got " + std::to_string(v.corners_px.size()));
    }
    if (!v.ids.empty() && v.ids.size() != v.corners_px.size()) {
      throw std::invalid_argument("calibrateIntrinsics: expected one id per corner");
    }
  }
  if (static_cast<int>(views.size()) < std::max(1, settings.min_images)) {
    r.reason = "too few images with a board: " + std::to_string(views.size()) + " < " + std::to_string(settings.min_images);
    return r;
  }
  std::vector<std::vector<cv::Point3f>> object_points;
  std::vector<std::vector<cv::Point2f>> image_points;
  for (const BoardView& v : views) {
    std::vector<cv::Point2f> pts;
    std::vector<cv::Point3f> object;
    for (std::size_t n = 0; n < v.corners_px.size(); ++n) {
      pts.emplace_back(static_cast<float>(v.corners_px[n].x()), static_cast<float>(v.corners_px[n].y()));
      const Eigen::Vector3d P = sim::cornerInBoard(board, v.ids.empty() ? static_cast<int>(n) : v.ids[n]);
      object.emplace_back(P.x(), P.y(), P.z());
    }
    object_points.push_back(std::move(object));
    image_points.push_back(std::move(pts));
  }
  int flags = 0;
  if (settings.fix_aspect_ratio) flags |= cv::CALIB_FIX_ASPECT_RATIO;
  if (settings.zero_tangential) flags |= cv::CALIB_ZERO_TANGENT_DIST;
  if (settings.fix_k3) flags |= cv::CALIB_FIX_K3;
  cv::Mat K = cv::Mat::eye(3, 3, CV_64F), dist = cv::Mat::zeros(5, 1, CV_64F);
  cv::Mat std_intr, std_extr, per_view;
  std::vector<cv::Mat> rvecs, tvecs;
  try {
    r.rms_px = cv::calibrateCamera(object_points, image_points, image_size, K, dist, rvecs, tvecs, std_intr, std_extr,
                                   per_view, flags,
                                   cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-12));
  } catch (const cv::Exception& e) {
    r.reason = std::string("calibrateCamera failed: ") + e.what();
    return r;
  }
  r.camera.fx_px = K.at<double>(0, 0);
  r.camera.fy_px = K.at<double>(1, 1);
  r.camera.cx_px = K.at<double>(0, 2);
  r.camera.cy_px = K.at<double>(1, 2);
  for (int i = 0; i < 5; ++i) r.camera.distortion[i] = dist.at<double>(i);
  // std_intr: fx fy cx cy k1 k2 p1 p2 k3 k4 k5 k6 s1 s2 s3 s4 tx ty.
  for (int i = 0; i < 9 && i < std_intr.rows; ++i) r.std_dev[i] = std_intr.at<double>(i);
  r.images_used = static_cast<int>(views.size());
  r.images.resize(views.size());
  for (std::size_t i = 0; i < views.size(); ++i) {
    r.images[i].status = ImageStatus::kFound;
    r.images[i].rms_px = per_view.at<double>(static_cast<int>(i));
  }
  r.ok = true;
  return r;
}

IntrinsicsResult calibrateIntrinsicsFromFiles(const std::vector<std::string>& paths, const sim::Board& board,
                                              const IntrinsicsSettings& settings) {
  DetectorSettings det = settings.detector;
  det.require_orientation = false;
  std::vector<IntrinsicsImage> images(paths.size());
  std::vector<BoardView> views;
  std::vector<std::size_t> view_of;
  cv::Size size;  // of the first image with a board: images of other sizes come from another camera
  for (std::size_t i = 0; i < paths.size(); ++i) {
    IntrinsicsImage& im = images[i];
    im.image = paths[i];
    const cv::Mat gray = readGrayImage(paths[i], &im.reason, &im.detail);
    if (gray.empty()) {
      im.status = ImageStatus::kUnreadable;
      continue;
    }
    BoardView view;
    if (board.type == sim::BoardType::kCharuco) {
      // Corners by identity, interpolated by local homographies (no camera model yet).
      const CharucoDetection d = detectCharuco(gray, board);
      im.status = d.status;
      im.reason = d.reason;
      im.detail = d.detail;
      if (!d.found()) continue;
      view = {d.corners_px, d.ids};
    } else {
      // A circle grid's order may be half-turned: a plane all the same to the intrinsics.
      const CornerDetection d = board.type == sim::BoardType::kCircles ? detectCircles(gray, board) : detectCorners(gray, board, det);
      im.status = d.status;
      im.reason = d.reason;
      im.detail = d.detail;
      if (!d.found()) continue;
      view = {d.corners_px, {}};
    }
    if (size.area() == 0) size = gray.size();
    if (gray.size() != size) {
      im.status = ImageStatus::kRejected;
      im.reason = "image size differs from the first found image's";
      im.detail = std::to_string(gray.cols) + "x" + std::to_string(gray.rows) + " px vs " + std::to_string(size.width) +
                  "x" + std::to_string(size.height);
      continue;
    }
    views.push_back(std::move(view));
    view_of.push_back(i);
  }
  IntrinsicsResult r = calibrateIntrinsics(views, size, board, settings);
  if (r.ok) {
    for (std::size_t v = 0; v < views.size(); ++v) images[view_of[v]].rms_px = r.images[v].rms_px;
  }
  r.images = std::move(images);
  return r;
}

std::string formatIntrinsicsYaml(const IntrinsicsResult& r, const sim::Board& board) {
  const auto n = [](double v) { return sim::exactNumber(v); };
  std::ostringstream s;
  s << "# orbcal intrinsics: Zhang's method (cv::calibrateCamera). The camera section uses the scene file's keys.\n";
  s << "ok: " << (r.ok ? "true" : "false") << "\n";
  if (!r.ok) s << "reason: " << quoted(r.reason) << "\n";
  s << "board: {";
  if (board.type == sim::BoardType::kCircles) {
    s << "type: circles, grid: [" << board.corners_x << ", " << board.corners_y << "], spacing_m: " << n(board.square_m)
      << ", diameter_m: " << n(board.diameter_m) << ", asymmetric: " << (board.asymmetric ? "true" : "false") << "}\n";
  } else {
    if (board.type == sim::BoardType::kCharuco) {
      s << "type: charuco, dictionary: " << board.dictionary << ", marker_m: " << n(board.marker_m) << ", ";
    }
    s << "inner_corners_x: " << board.corners_x << ", inner_corners_y: " << board.corners_y << ", square_m: " << n(board.square_m) << "}\n";
  }
  if (r.ok) {
    const sim::Camera& c = r.camera;
    s << "camera:\n  width_px: " << c.width_px << "\n  height_px: " << c.height_px << "\n  fx_px: " << n(c.fx_px)
      << "\n  fy_px: " << n(c.fy_px) << "\n  cx_px: " << n(c.cx_px) << "\n  cy_px: " << n(c.cy_px)
      << "\n  distortion: [" << n(c.distortion[0]) << ", " << n(c.distortion[1]) << ", " << n(c.distortion[2]) << ", "
      << n(c.distortion[3]) << ", " << n(c.distortion[4]) << "]   # k1 k2 p1 p2 k3\n";
    s << "rms_px: " << n(r.rms_px) << "\n";
    s << "std_dev: {fx_px: " << n(r.std_dev[0]) << ", fy_px: " << n(r.std_dev[1]) << ", cx_px: " << n(r.std_dev[2])
      << ", cy_px: " << n(r.std_dev[3]) << ", distortion: [" << n(r.std_dev[4]) << ", " << n(r.std_dev[5]) << ", "
      << n(r.std_dev[6]) << ", " << n(r.std_dev[7]) << ", " << n(r.std_dev[8]) << "]}\n";
  }
  s << "images_used: " << r.images_used << "\nimages:\n";
  for (const IntrinsicsImage& im : r.images) {
    s << "  - {file: " << quoted(im.image) << ", status: " << toString(im.status);
    if (im.status == ImageStatus::kFound && r.ok) s << ", rms_px: " << n(im.rms_px);
    if (!im.reason.empty()) s << ", reason: " << quoted(im.reason);
    if (!im.detail.empty()) s << ", detail: " << quoted(im.detail);
    s << "}\n";
  }
  return s.str();
}

std::vector<std::string> expandImageArguments(const std::vector<std::string>& arguments) {
  static const std::vector<std::string> kExtensions{".png", ".jpg", ".jpeg", ".bmp", ".tif",
                                                     ".tiff", ".pgm", ".ppm", ".pnm", ".webp"};
  namespace fs = std::filesystem;
  std::vector<std::string> out;
  for (const std::string& a : arguments) {
    std::error_code ec;
    if (!fs::is_directory(a, ec)) {
      if (!fs::exists(a, ec)) throw sim::InputError(a + ": no such image file or folder");
      out.push_back(a);
      continue;
    }
    std::vector<std::string> found;
    for (fs::directory_iterator it(a, ec), end; !ec && it != end; it.increment(ec)) {
      std::error_code ec_file;
      if (!it->is_regular_file(ec_file)) continue;
      std::string ext = it->path().extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return std::tolower(ch); });
      if (std::find(kExtensions.begin(), kExtensions.end(), ext) != kExtensions.end()) found.push_back(it->path().string());
    }
    if (ec) throw sim::InputError(a + ": cannot list the folder: " + ec.message());
    if (found.empty()) {
      throw sim::InputError(a + ": no image files in this folder (looked for .png .jpg .jpeg .bmp .tif .tiff .pgm .ppm .pnm .webp)");
    }
    std::sort(found.begin(), found.end());
    out.insert(out.end(), found.begin(), found.end());
  }
  return out;
}

CameraFileNames cameraFileNames(const std::string& out) {
  const std::filesystem::path p(out);
  const std::filesystem::path dir = p.parent_path();
  const std::string stem = p.stem().string();
  return {(dir / (stem + "_camera_info.yaml")).string(), (dir / (stem + "_opencv.yml")).string()};
}

}  // namespace orbcal::vision
