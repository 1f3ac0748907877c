#include "orbcal/sim/flange_poses.hpp"

#include <cmath>
#include <map>
#include <sstream>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/image_views.hpp"
#include "orbcal/sim/scene.hpp"

namespace orbcal::sim {

namespace {

std::vector<int> poseColumns(const CsvTable& t) {
  std::vector<int> cols;
  for (const char* c : kFlangePoseColumns) cols.push_back(t.requireColumn(c));
  for (const std::string& h : t.header()) {
    if (h.size() > 1 && h[0] == 'q' && std::isdigit(static_cast<unsigned char>(h[1]))) {
      throw InputError(t.source() + ": header: column '" + h + "' beside flange poses: give either joints or flange poses");
    }
  }
  return cols;
}

}  // namespace

bool holdsFlangePoses(const std::string& text, const std::string& source) {
  const CsvTable t = CsvTable::parse(text, source);
  for (const char* c : kFlangePoseColumns) {
    if (t.column(c) >= 0) return true;
  }
  return false;
}

Eigen::Matrix<double, 7, 1> flangePoseValues(const Eigen::Isometry3d& T) {
  Eigen::Quaterniond q(T.linear());
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  Eigen::Matrix<double, 7, 1> v;
  v << T.translation(), q.w(), q.x(), q.y(), q.z();
  return v;
}

Eigen::Isometry3d flangePoseFromValues(const Eigen::Matrix<double, 7, 1>& v, const std::string& where) {
  for (int i = 0; i < 3; ++i) {
    if (std::abs(v[i]) <= kMaxLengthM) continue;
    throw InputError(where + ": " + kFlangePoseColumns[i] + ": " + formatNumber("%.9g", v[i]) +
                     " m is outside 10 km: no robot's flange reaches it (millimetres given as metres?)");
  }
  const Eigen::Quaterniond q(v[3], v[4], v[5], v[6]);
  if (!(std::abs(q.norm() - 1.0) <= kControllerRotationTolerance)) {
    throw InputError(where + ": flange_qw: the quaternion's norm is " + formatNumber("%.9g", q.norm()) +
                     ", not 1 (up to 1e-4 off is normalised; columns in w, x, y, z order?)");
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q.normalized().toRotationMatrix();
  T.translation() = v.head<3>();
  return T;
}

std::vector<Eigen::Isometry3d> parseFlangePosesCsv(const std::string& text, const std::string& source) {
  const CsvTable t = CsvTable::parse(text, source);
  const std::vector<int> cols = poseColumns(t);
  const int c_index = t.column("index");
  std::map<int, int> index_line;  // index -> line of its first row
  std::vector<Eigen::Isometry3d> poses;
  for (std::size_t r = 0; r < t.rows(); ++r) {
    checkIndexOnce(t, r, c_index, index_line, "configuration");
    const auto v = t.numbers(r, cols);
    if (!v) throw InputError(t.where(r) + ": flange_x_m: the flange pose is empty");
    poses.push_back(flangePoseFromValues(*v, t.where(r)));
  }
  return poses;
}

std::string formatFlangePosesCsv(const std::vector<Eigen::Isometry3d>& poses) {
  std::ostringstream out;
  out << "index";
  for (const char* c : kFlangePoseColumns) out << "," << c;
  out << "\n";
  for (std::size_t k = 0; k < poses.size(); ++k) {
    out << k;
    const Eigen::Matrix<double, 7, 1> v = flangePoseValues(poses[k]);
    for (int i = 0; i < 7; ++i) out << "," << exactNumber(v[i]);
    out << "\n";
  }
  return out.str();
}

std::string flangePoseImagesDescription(const Scene& scene, const std::string& samples_file, const std::string& camera_file) {
  const Board& b = scene.board;
  const auto mm = [](double m) { return exactNumber(m * 1e3); };
  std::ostringstream out;
  out << "# The rendered views as an image set with controller poses (written by orbcal render): `orbcal calibrate\n"
         "# images.yaml` estimates flange_T_camera and base_T_board from the images, `orbcal twin images.yaml` compares.\n"
         "format: orbcal-measurements-1\nfiles: ["
      << samples_file << "]\nflange_pose: {position: [" << kFlangePoseColumns[0] << ", " << kFlangePoseColumns[1] << ", "
      << kFlangePoseColumns[2] << "], quaternion_wxyz: [" << kFlangePoseColumns[3] << ", " << kFlangePoseColumns[4] << ", "
      << kFlangePoseColumns[5] << ", " << kFlangePoseColumns[6] << "], length_unit: m}\nimages: {column: image}\ncamera: "
      << camera_file << "\nboard: {";
  const std::string squares = "squares: [" + std::to_string(b.corners_x + 1) + ", " + std::to_string(b.corners_y + 1) + "]";
  if (b.type == BoardType::kCircles) {
    out << "circles: {grid: [" << b.corners_x << ", " << b.corners_y << "], spacing_mm: " << mm(b.square_m)
        << ", diameter_mm: " << mm(b.diameter_m) << ", asymmetric: " << (b.asymmetric ? "true" : "false") << "}";
  } else if (b.type == BoardType::kCharuco) {
    out << "charuco: {" << squares << ", square_mm: " << mm(b.square_m) << ", marker_mm: " << mm(b.marker_m)
        << ", dictionary: " << b.dictionary << "}";
  } else {
    out << "chessboard: {" << squares << ", square_mm: " << mm(b.square_m) << "}";
  }
  out << ", margin_mm: " << mm(b.margin_m) << "}\nsetup: eye_in_hand\n";
  return out.str();
}

}  // namespace orbcal::sim
