#include "orbcal/vision/measurement.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/vision/charuco.hpp"
#include "orbcal/vision/circles.hpp"

namespace orbcal::vision {

namespace {
std::string fmt(double v, int decimals) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(decimals);
  s << v;
  return s.str();
}

const char* kPoseSuffix[6] = {"x_m", "y_m", "z_m", "rx_rad", "ry_rad", "rz_rad"};

std::vector<std::string> poseColumns(const std::string& prefix) {
  std::vector<std::string> c;
  for (const char* s : kPoseSuffix) c.push_back(prefix + s);
  return c;
}
std::vector<std::string> covColumns() {
  std::vector<std::string> c;
  for (int r = 0; r < 6; ++r) {
    for (int k = r; k < 6; ++k) c.push_back("cov_" + std::to_string(r) + std::to_string(k));
  }
  return c;
}

// A non-negative integer cell within int range; the error names the file, the line and the column.
int intCell(const sim::CsvTable& t, std::size_t r, int c, const char* column) {
  const double v = t.number(r, c);
  if (!(v == std::floor(v) && v >= 0.0 && v <= static_cast<double>(std::numeric_limits<int>::max()))) {
    throw sim::InputError(t.where(r) + ": " + column + ": expected a non-negative integer (at most " +
                          std::to_string(std::numeric_limits<int>::max()) + "), got '" + t.cell(r, c) + "'");
  }
  return static_cast<int>(v);
}
}  // namespace

std::string measurementCell(std::string s) {
  for (char& ch : s) {
    if (ch == ',') ch = ';';
    if (ch == '\n' || ch == '\r') ch = ' ';
  }
  return s;
}

Measurement measureImage(const cv::Mat& gray, const sim::Scene& scene, const sim::Arm& nominal, const Eigen::VectorXd& q,
                         const MeasureSettings& settings) {
  if (gray.empty() || gray.type() != CV_8UC1) {
    throw std::invalid_argument("measureImage: expected a non-empty CV_8UC1 image, got type " + std::to_string(gray.type()));
  }
  Measurement m;
  const sim::Camera& cam = scene.camera;
  if (settings.require_camera_size && (gray.cols != cam.width_px || gray.rows != cam.height_px)) {
    m.status = ImageStatus::kRejected;
    m.reason = "image size differs from the camera's";
    m.detail = "image is " + std::to_string(gray.cols) + "x" + std::to_string(gray.rows) + " px; the scene camera is " +
               std::to_string(cam.width_px) + "x" + std::to_string(cam.height_px);
    return m;
  }
  std::vector<Eigen::Vector2d> corners_px;
  std::vector<int> ids;
  if (scene.board.type == sim::BoardType::kCharuco) {
    // Corners known by identity: a partly visible board still gives a pose.
    const CharucoDetection det = detectCharuco(gray, scene.board, &cam);
    m.status = det.status;
    m.reason = det.reason;
    m.detail = det.detail;
    if (!det.found()) return m;
    corners_px = det.corners_px;
    ids = det.ids;
  } else {
    const bool circles = scene.board.type == sim::BoardType::kCircles;
    const CornerDetection det = circles ? detectCircles(gray, scene.board) : detectCorners(gray, scene.board, settings.detector);
    m.status = det.status;
    m.reason = det.reason;
    m.detail = det.detail;
    if (!det.found()) return m;
    if (!det.orientation_known && !(circles && settings.half_turn_resolved_across_views)) {
      // Possible when the detector settings make the orientation optional (intrinsics do): a pose from
      // a half-turned corner order would be wrong by a half turn about the board normal, not noisy.
      m.status = ImageStatus::kRejected;
      m.reason = "orientation undecidable";
      m.detail = det.detail.empty() ? "the board's orientation is not known" : det.detail;
      return m;
    }
    corners_px = det.corners_px;
  }
  m.num_corners = static_cast<int>(corners_px.size());

  BoardPose pose = ids.empty() ? estimateBoardPose(cam, scene.board, corners_px)
                               : estimateBoardPose(cam, scene.board, corners_px, ids);
  if (pose.ok && scene.board.type == sim::BoardType::kCircles && settings.correct_ellipse_bias) {
    // The centroids are the ellipses' centres: take off the bias the pose predicts and solve again (circles.hpp).
    for (int k = 0; k < scene.board.numCorners(); ++k) {
      corners_px[static_cast<std::size_t>(k)] -= ellipseCentreBias(cam, scene.board, pose.camera_T_board, k);
    }
    pose = estimateBoardPose(cam, scene.board, corners_px);
  }
  if (!pose.ok) {
    m.status = ImageStatus::kRejected;
    m.reason = pose.reason;
    m.detail = pose.detail;
    return m;
  }
  m.rms_px = pose.rms_px;
  if (!(pose.rms_px <= settings.max_rms_px)) {
    m.status = ImageStatus::kRejected;
    m.reason = "reprojection RMS above limit";
    m.detail = "RMS " + fmt(pose.rms_px, 3) + " px > " + fmt(settings.max_rms_px, 3) + " px";
    return m;
  }
  m.camera_T_board = pose.camera_T_board;
  m.corners_px = corners_px;
  m.corner_ids = ids;
  m.base_T_flange = measuredFlangePose(scene, pose.camera_T_board);
  m.covariance = flangeCovariance(scene.flange_T_camera, pose.covariance_camera);
  if (q.size() > 0) {
    m.pose_error = sim::poseMinus(m.base_T_flange, sim::forwardKinematics(nominal, q));
    m.has_pose_error = true;
  }
  m.status = ImageStatus::kFound;
  return m;
}

std::string formatMeasurementsCsv(const std::vector<Measurement>& rows) {
  std::ostringstream out;
  out << "index,image,status,reason,detail,num_corners,rms_px";
  for (const auto& c : poseColumns("cam_board_")) out << "," << c;
  for (const auto& c : poseColumns("base_flange_")) out << "," << c;
  for (const auto& c : covColumns()) out << "," << c;
  for (const auto& c : poseColumns("err_")) out << "," << c;
  out << "\n";
  for (const Measurement& m : rows) {
    out << m.index << "," << measurementCell(m.image) << "," << toString(m.status) << ","
        << measurementCell(m.reason) << "," << measurementCell(m.detail);
    const bool has_rms = m.found() || m.rms_px > 0.0;
    out << "," << (m.num_corners > 0 ? std::to_string(m.num_corners) : "") << ","
        << (has_rms ? sim::exactNumber(m.rms_px) : "");
    if (m.found()) {
      for (const auto* v : {&m.camera_T_board, &m.base_T_flange}) {
        const sim::Vector6d p = sim::poseToVector(*v);
        for (int i = 0; i < 6; ++i) out << "," << sim::exactNumber(p[i]);
      }
      for (int r = 0; r < 6; ++r) {
        for (int k = r; k < 6; ++k) out << "," << sim::exactNumber(m.covariance(r, k));
      }
      if (m.has_pose_error) {
        for (int i = 0; i < 6; ++i) out << "," << sim::exactNumber(m.pose_error[i]);
      } else {
        out << std::string(6, ',');
      }
    } else {
      out << std::string(6 + 6 + 21 + 6, ',');
    }
    out << "\n";
  }
  return out.str();
}

std::vector<Measurement> parseMeasurementsCsv(const std::string& text, const std::string& source) {
  const sim::CsvTable t = sim::CsvTable::parse(text, source);
  const int c_index = t.requireColumn("index"), c_image = t.requireColumn("image"), c_status = t.requireColumn("status"),
            c_reason = t.requireColumn("reason"), c_detail = t.requireColumn("detail"),
            c_n = t.requireColumn("num_corners"), c_rms = t.requireColumn("rms_px");
  const auto cols = [&](const std::vector<std::string>& names) {
    std::vector<int> c;
    for (const auto& n : names) c.push_back(t.requireColumn(n));
    return c;
  };
  const std::vector<int> c_cam = cols(poseColumns("cam_board_")), c_flange = cols(poseColumns("base_flange_")),
                         c_cov = cols(covColumns()), c_err = cols(poseColumns("err_"));
  std::vector<Measurement> rows;
  std::map<int, std::size_t> row_of_index;
  for (std::size_t r = 0; r < t.rows(); ++r) {
    Measurement m;
    m.index = intCell(t, r, c_index, "index");
    if (const auto [it, added] = row_of_index.emplace(m.index, r); !added) {
      throw sim::InputError(t.where(r) + ": index: " + std::to_string(m.index) + " repeats the row of " +
                            t.where(it->second));
    }
    m.image = t.cell(r, c_image);
    try {
      m.status = parseImageStatus(t.cell(r, c_status));
    } catch (const std::invalid_argument&) {
      throw sim::InputError(t.where(r) + ": status: expected found, not_found, rejected or unreadable, got '" +
                            t.cell(r, c_status) + "'");
    }
    m.reason = t.cell(r, c_reason);
    m.detail = t.cell(r, c_detail);
    if (!t.cell(r, c_n).empty()) m.num_corners = intCell(t, r, c_n, "num_corners");
    if (!t.cell(r, c_rms).empty()) m.rms_px = t.number(r, c_rms);
    if (m.found()) {
      // numbers() throws, naming the column, for a partly empty group.
      const auto need = [&](const std::vector<int>& c, const char* what) {
        const auto v = t.numbers(r, c);
        if (!v) throw sim::InputError(t.where(r) + ": status 'found' but the " + what + " cells are empty");
        return *v;
      };
      m.camera_T_board = sim::poseFromVector(need(c_cam, "cam_board"));
      m.base_T_flange = sim::poseFromVector(need(c_flange, "base_flange"));
      const Eigen::VectorXd cov = need(c_cov, "cov");
      int i = 0;
      for (int a = 0; a < 6; ++a) {
        for (int b = a; b < 6; ++b, ++i) m.covariance(a, b) = m.covariance(b, a) = cov[i];
      }
      if (const auto err = t.numbers(r, c_err)) {  // empty: no joint reading was available
        m.pose_error = *err;
        m.has_pose_error = true;
      }
    }
    rows.push_back(std::move(m));
  }
  return rows;
}

MeasurementSummary summarize(const std::vector<Measurement>& rows) {
  MeasurementSummary s;
  std::vector<double> rms;
  for (const Measurement& m : rows) {
    ++s.total;
    switch (m.status) {
      case ImageStatus::kFound: ++s.found; rms.push_back(m.rms_px); break;
      case ImageStatus::kNotFound: ++s.not_found; break;
      case ImageStatus::kRejected: ++s.rejected; break;
      case ImageStatus::kUnreadable: ++s.unreadable; break;
    }
    if (!m.found()) ++s.reasons[std::string(toString(m.status)) + ": " + m.reason];
  }
  if (!rms.empty()) {
    std::nth_element(rms.begin(), rms.begin() + rms.size() / 2, rms.end());
    s.median_rms_px = rms[rms.size() / 2];
  }
  return s;
}

namespace {
/// The summary's statements: the counts first, then the median RMS and each reason.
std::vector<std::string> summaryItems(const MeasurementSummary& s) {
  std::vector<std::string> items{std::to_string(s.total) + " images: " + std::to_string(s.found) + " used, " +
                                 std::to_string(s.not_found) + " not found, " + std::to_string(s.rejected) + " rejected, " +
                                 std::to_string(s.unreadable) + " unreadable"};
  if (s.found > 0) items.push_back("median reprojection RMS of the used ones: " + fmt(s.median_rms_px, 3) + " px");
  for (const auto& [why, n] : s.reasons) items.push_back(std::to_string(n) + " x " + why);
  return items;
}
}  // namespace

std::string formatSummary(const MeasurementSummary& s) {
  std::string out;
  for (const std::string& item : summaryItems(s)) out += (out.empty() ? "" : "  ") + item + "\n";
  return out;
}

std::string summaryLine(const MeasurementSummary& s) {
  std::string out;
  for (const std::string& item : summaryItems(s)) out += (out.empty() ? "" : "; ") + item;
  return out;
}

}  // namespace orbcal::vision
