#pragma once
// Views given as flange poses (the controller's base_T_flange) instead of joint readings: the
// configurations CSV that `orbcal render --configs` takes, and the columns of a rendered dataset's
// samples.csv made from one. No robot model acts on them: the flange is where the pose says.

#include <string>
#include <vector>

#include <Eigen/Geometry>

namespace orbcal::sim {

struct Scene;

/// Position in metres, then the unit quaternion w, x, y, z of base_T_flange.
inline constexpr const char* kFlangePoseColumns[7] = {"flange_x_m", "flange_y_m", "flange_z_m", "flange_qw",
                                                      "flange_qx",  "flange_qy",  "flange_qz"};

/// True when the CSV's header has the flange pose columns (rather than joints). Throws InputError for
/// a malformed header.
bool holdsFlangePoses(const std::string& text, const std::string& source);

/// The flange poses of a configurations CSV: columns index (optional; whole numbers from 0, none twice)
/// and kFlangePoseColumns, one pose per row. Every value finite, positions within kMaxLengthM, the
/// quaternion's norm within kControllerRotationTolerance of 1 (then normalised; a controller printing
/// four decimals). Throws InputError naming the file, the line and the column.
std::vector<Eigen::Isometry3d> parseFlangePosesCsv(const std::string& text, const std::string& source);

/// The same CSV (index, kFlangePoseColumns), numbers exact.
std::string formatFlangePosesCsv(const std::vector<Eigen::Isometry3d>& base_T_flange);

/// The kFlangePoseColumns values of one pose, in their order (the quaternion with w >= 0).
Eigen::Matrix<double, 7, 1> flangePoseValues(const Eigen::Isometry3d& base_T_flange);
/// The pose of seven values as flangePoseValues gives them; `where` ("<file>: line L") names the row
/// in errors (a length beyond kMaxLengthM, a quaternion whose norm is not 1).
Eigen::Isometry3d flangePoseFromValues(const Eigen::Matrix<double, 7, 1>& v, const std::string& where);

/// The image description (orbcal-measurements-1, sim/image_views.hpp) of a rendered dataset whose views
/// are flange poses: its samples.csv's images and kFlangePoseColumns, the scene's camera as the file
/// `camera_file` (relative to the description) and its board, eye in hand. `orbcal calibrate` and
/// `orbcal twin` read it as they read real images with controller poses.
std::string flangePoseImagesDescription(const Scene& scene, const std::string& samples_file, const std::string& camera_file);

}  // namespace orbcal::sim
