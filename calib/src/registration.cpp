#include "orbcal/calib/registration.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <stdexcept>
#include <string>

#include "orbcal/sim/se3.hpp"

// Frames (a_T_b maps b coordinates to a):
//   world  - the measuring system (laser tracker, motion capture)
//   base   - the arm's base frame of the nominal model
//   flange - the arm's flange frame of the nominal model, base_T_flange_k at sample k
//   marker - the measured target on the flange
//   world_T_marker_k = world_T_base * base_T_flange_k * flange_T_marker.
// Rotations R_ab and translations p_ab are those of a_T_b; m = p_fm, the marker origin in the flange.

namespace orbcal::calib {

namespace {

constexpr int kMinFullPoseSamples = 3;
constexpr int kMinPositionSamples = 4;
constexpr int kMaxAlternations = 100;
constexpr double kAlternationTolM = 1e-9;  // stop when the marker offset moves less than this
// Orientations whose rotation vectors (relative to the first sample) have an RMS spread off their
// principal axis below this carry no information about the rotation about that axis (and the marker
// offset along it): 1e-3 rad = 0.06 deg, several times the angular noise of a tracker's pose.
constexpr double kMinOffAxisSpreadRad = 1e-3;
// Positions whose RMS distance from their best plane is below this fraction of their largest RMS
// extent are coplanar to measurement precision (1 um over 1 m).
constexpr double kMinFlatness = 1e-6;

std::string fmt(const char* format, double a, double b) {
  char buf[160];
  std::snprintf(buf, sizeof buf, format, a, b);
  return buf;
}

/// Ascending eigenvalues of the scatter (1/n) sum v v^T of the columns of V (3 x n).
Eigen::Vector3d scatterEigenvalues(const Eigen::Matrix3Xd& V) {
  const Eigen::Matrix3d S = V * V.transpose() / static_cast<double>(V.cols());
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(S, Eigen::EigenvaluesOnly).eigenvalues();
}

/// Equal counts and finite entries (the measured rotations only where they are used).
void checkSamples(const std::vector<Eigen::Isometry3d>& world_T_marker,
                  const std::vector<Eigen::Isometry3d>& base_T_flange, bool use_rotation, const char* context) {
  if (world_T_marker.size() != base_T_flange.size()) {
    throw std::invalid_argument(std::string(context) + ": " + std::to_string(world_T_marker.size()) +
                                " measured poses but " + std::to_string(base_T_flange.size()) + " flange poses");
  }
  for (std::size_t k = 0; k < world_T_marker.size(); ++k) {
    const bool measured_ok = use_rotation ? world_T_marker[k].matrix().allFinite()
                                          : world_T_marker[k].translation().allFinite();
    if (!measured_ok || !base_T_flange[k].matrix().allFinite()) {
      throw std::invalid_argument(std::string(context) + ": sample " + std::to_string(k) + " has a NaN or inf entry");
    }
  }
}

/// Throws unless the flange orientations turn about at least two independent axes. With rotations
/// about one axis only (or none), the rotation of world_T_base about that axis is confounded with
/// that of flange_T_marker (full poses), and the marker offset along it with the base translation.
void checkOrientationSpread(const std::vector<Eigen::Isometry3d>& base_T_flange, const char* context) {
  // Rotations about a common axis a (fixed in the base or in the flange) have collinear rotation
  // vectors log(R_bf_k R_bf_0^T) = theta_k a, so the scatter's second eigenvalue measures the spread off a.
  const Eigen::Matrix3d R_fb_0 = base_T_flange.front().linear().transpose();
  Eigen::Matrix3Xd w(3, static_cast<Eigen::Index>(base_T_flange.size()));
  for (std::size_t k = 0; k < base_T_flange.size(); ++k) {
    w.col(static_cast<Eigen::Index>(k)) = sim::logSO3(base_T_flange[k].linear() * R_fb_0);
  }
  const double off_axis_rad = std::sqrt(std::max(0.0, scatterEigenvalues(w)[1]));
  if (off_axis_rad < kMinOffAxisSpreadRad) {
    throw std::invalid_argument(std::string(context) +
                                fmt(": the flange orientations all turn about one axis or none (spread off it "
                                    "%.3g deg < %.3g deg); the frames cannot be separated",
                                    off_axis_rad * sim::kRadToDeg, kMinOffAxisSpreadRad * sim::kRadToDeg));
  }
}

/// Throws when the measured positions lie in one plane (or on a line, or at one point), as the header
/// promises. Only a line (or a point) is truly degenerate: with flange orientations about two axes,
/// coplanar positions still fix R_wb (Umeyama resolves the reflection) and (m, t_wb).
void checkNotCoplanar(const std::vector<Eigen::Isometry3d>& world_T_marker, const char* context) {
  Eigen::Matrix3Xd p(3, static_cast<Eigen::Index>(world_T_marker.size()));
  for (std::size_t k = 0; k < world_T_marker.size(); ++k) {
    p.col(static_cast<Eigen::Index>(k)) = world_T_marker[k].translation();
  }
  p.colwise() -= p.rowwise().mean();
  const Eigen::Vector3d lambda = scatterEigenvalues(p).cwiseMax(0.0);
  const double out_of_plane_m = std::sqrt(lambda[0]), extent_m = std::sqrt(lambda[2]);
  if (out_of_plane_m <= kMinFlatness * extent_m) {
    throw std::invalid_argument(std::string(context) +
                                fmt(": the measured positions are coplanar (RMS %.3g m off their plane, extent %.3g m); "
                                    "position-only registration needs 4 positions not in one plane",
                                    out_of_plane_m, extent_m));
  }
}

/// The marker offset m (flange frame) and p_wb minimising sum_k |R_wb (R_bf_k m + p_bf_k) + p_wb - p_wm_k|^2
/// for a given R_wb: linear least squares, rows [R_wb R_bf_k, I] [m; p_wb] = p_wm_k - R_wb p_bf_k.
void solveTranslations(const std::vector<Eigen::Isometry3d>& world_T_marker,
                       const std::vector<Eigen::Isometry3d>& base_T_flange, const Eigen::Matrix3d& R_wb,
                       Eigen::Vector3d& m, Eigen::Vector3d& p_wb) {
  const auto n = static_cast<Eigen::Index>(world_T_marker.size());
  Eigen::MatrixXd A(3 * n, 6);
  Eigen::VectorXd b(3 * n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const Eigen::Isometry3d& base_T_flange_k = base_T_flange[static_cast<std::size_t>(k)];
    A.block<3, 3>(3 * k, 0) = R_wb * base_T_flange_k.linear();
    A.block<3, 3>(3 * k, 3).setIdentity();
    b.segment<3>(3 * k) = world_T_marker[static_cast<std::size_t>(k)].translation() - R_wb * base_T_flange_k.translation();
  }
  const Eigen::VectorXd x = A.colPivHouseholderQr().solve(b);
  m = x.head<3>();
  p_wb = x.tail<3>();
}

double rmsPosition(const std::vector<Eigen::Isometry3d>& world_T_marker, const std::vector<Eigen::Isometry3d>& base_T_flange,
                   const Eigen::Isometry3d& world_T_base, const Eigen::Isometry3d& flange_T_marker) {
  double sse = 0.0;
  for (std::size_t k = 0; k < world_T_marker.size(); ++k) {
    const Eigen::Vector3d p_wm = (world_T_base * base_T_flange[k] * flange_T_marker).translation();
    sse += (p_wm - world_T_marker[k].translation()).squaredNorm();
  }
  return std::sqrt(sse / static_cast<double>(world_T_marker.size()));
}

cv::Mat toCv(const Eigen::Matrix3d& R) {
  cv::Mat out;
  cv::eigen2cv(R, out);
  return out;
}
cv::Mat toCv(const Eigen::Vector3d& t) {
  cv::Mat out;
  cv::eigen2cv(t, out);
  return out;
}

/// Shah's solve (cv::calibrateRobotWorldHandEye) on at most this many poses, evenly spread through the
/// samples: its dense system grows with them (4 % of a diagnosis of 10^5 samples, one solve per model's
/// start), and what it gives is a starting guess the fit refines; the input checks see every sample.
constexpr std::size_t kRotationGuessPoses = 2000;

/// R_wb and R_fm from OpenCV's robot-world / hand-eye solver (Shah 2013: the rotations are the
/// leading singular vectors of sum_k kron(R_B_k, R_A_k), projected to SO(3)).
///
/// OpenCV solves A_k X = Z B_k with A_k = cam_T_world_k, X = world_T_base, Z = cam_T_gripper,
/// B_k = gripper_T_base_k. Our chain, inverted and multiplied by world_T_base on the right,
///     marker_T_world_k * world_T_base = marker_T_flange * flange_T_base_k,
/// is that equation with cam = marker, gripper = flange (world and base keep their names), so
///     A_k = world_T_marker_k^-1  (R_world2cam, t_world2cam),
///     B_k = base_T_flange_k^-1   (R_base2gripper, t_base2gripper),
///     X = world_T_base           (R_base2world, t_base2world),
///     Z = flange_T_marker^-1     (R_gripper2cam, t_gripper2cam).
/// Its translations are not used: solveTranslations fits them to the marker positions instead.
void robotWorldHandEyeRotations(const std::vector<Eigen::Isometry3d>& world_T_marker,
                                const std::vector<Eigen::Isometry3d>& base_T_flange, Eigen::Matrix3d& R_wb,
                                Eigen::Matrix3d& R_fm) {
  std::vector<cv::Mat> R_world2cam, t_world2cam, R_base2gripper, t_base2gripper;
  const std::size_t step = (world_T_marker.size() + kRotationGuessPoses - 1) / kRotationGuessPoses;
  for (std::size_t k = 0; k < world_T_marker.size(); k += std::max<std::size_t>(1, step)) {
    const Eigen::Isometry3d marker_T_world = world_T_marker[k].inverse();
    const Eigen::Isometry3d flange_T_base = base_T_flange[k].inverse();
    R_world2cam.push_back(toCv(Eigen::Matrix3d(marker_T_world.linear())));
    t_world2cam.push_back(toCv(Eigen::Vector3d(marker_T_world.translation())));
    R_base2gripper.push_back(toCv(Eigen::Matrix3d(flange_T_base.linear())));
    t_base2gripper.push_back(toCv(Eigen::Vector3d(flange_T_base.translation())));
  }
  cv::Mat R_base2world, t_base2world, R_gripper2cam, t_gripper2cam;
  try {
    cv::calibrateRobotWorldHandEye(R_world2cam, t_world2cam, R_base2gripper, t_base2gripper, R_base2world,
                                   t_base2world, R_gripper2cam, t_gripper2cam, cv::CALIB_ROBOT_WORLD_HAND_EYE_SHAH);
  } catch (const cv::Exception& e) {
    throw std::invalid_argument("initialRegistration: the robot-world/hand-eye solve failed (" + e.msg + ")");
  }
  Eigen::Matrix3d R_mf;
  cv::cv2eigen(R_base2world, R_wb);
  cv::cv2eigen(R_gripper2cam, R_mf);
  R_wb = sim::projectToSO3(R_wb);
  R_fm = sim::projectToSO3(R_mf.transpose());
}

}  // namespace

RegistrationGuess initialRegistration(const std::vector<Eigen::Isometry3d>& world_T_marker,
                                      const std::vector<Eigen::Isometry3d>& base_T_flange, bool use_rotation) {
  const char* context = "initialRegistration";
  checkSamples(world_T_marker, base_T_flange, use_rotation, context);
  const int needed = use_rotation ? kMinFullPoseSamples : kMinPositionSamples;
  if (static_cast<int>(world_T_marker.size()) < needed) {
    throw std::invalid_argument(std::string(context) + ": needs at least " + std::to_string(needed) + " samples with " +
                                (use_rotation ? "full poses" : "positions only") + ", got " +
                                std::to_string(world_T_marker.size()));
  }
  checkOrientationSpread(base_T_flange, context);
  if (!use_rotation) checkNotCoplanar(world_T_marker, context);

  Eigen::Matrix3d R_wb, R_fm = Eigen::Matrix3d::Identity();
  Eigen::Vector3d m = Eigen::Vector3d::Zero(), p_wb = Eigen::Vector3d::Zero();
  if (use_rotation) {
    robotWorldHandEyeRotations(world_T_marker, base_T_flange, R_wb, R_fm);
    solveTranslations(world_T_marker, base_T_flange, R_wb, m, p_wb);
  } else {
    // Alternation from m = 0: the marker points in the base frame, p_bm_k = R_bf_k m + p_bf_k, are
    // registered to the measured p_wm_k (Umeyama without scale: R_wb, p_wb); then m and p_wb are
    // re-fitted by linear least squares for that R_wb. Each step lowers the same sum of squares.
    const auto n = static_cast<Eigen::Index>(world_T_marker.size());
    Eigen::Matrix3Xd p_wm(3, n), p_bm(3, n);
    for (Eigen::Index k = 0; k < n; ++k) p_wm.col(k) = world_T_marker[static_cast<std::size_t>(k)].translation();
    for (int it = 0; it < kMaxAlternations; ++it) {
      for (Eigen::Index k = 0; k < n; ++k) {
        const Eigen::Isometry3d& base_T_flange_k = base_T_flange[static_cast<std::size_t>(k)];
        p_bm.col(k) = base_T_flange_k.linear() * m + base_T_flange_k.translation();
      }
      const Eigen::Matrix4d world_T_base_h = Eigen::umeyama(p_bm, p_wm, false);
      R_wb = sim::projectToSO3(world_T_base_h.topLeftCorner<3, 3>());
      const Eigen::Vector3d m_prev = m;
      solveTranslations(world_T_marker, base_T_flange, R_wb, m, p_wb);
      if ((m - m_prev).norm() < kAlternationTolM) break;
    }
  }

  RegistrationGuess g;
  g.world_T_base.linear() = R_wb;
  g.world_T_base.translation() = p_wb;
  g.flange_T_marker.linear() = R_fm;
  g.flange_T_marker.translation() = m;
  g.rms_position_m = rmsPosition(world_T_marker, base_T_flange, g.world_T_base, g.flange_T_marker);
  return g;
}

Eigen::Isometry3d initialMarker(const std::vector<Eigen::Isometry3d>& world_T_marker,
                                const std::vector<Eigen::Isometry3d>& base_T_flange,
                                const Eigen::Isometry3d& world_T_base, bool use_rotation) {
  const char* context = "initialMarker";
  checkSamples(world_T_marker, base_T_flange, use_rotation, context);
  if (world_T_marker.empty()) throw std::invalid_argument(std::string(context) + ": no samples");
  const Eigen::Isometry3d base_T_world = world_T_base.inverse();
  // Per sample, flange_T_marker_k = base_T_flange_k^-1 * base_T_world * world_T_marker_k. The position
  // least squares sum_k |R_wb R_bf_k m + ... - p_wm_k|^2 has orthonormal blocks, so its solution is the
  // mean of the per-sample offsets; the rotation is their chordal mean (the sum projected to SO(3)).
  Eigen::Matrix3d R_sum = Eigen::Matrix3d::Zero();
  Eigen::Vector3d m = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < world_T_marker.size(); ++k) {
    const Eigen::Isometry3d flange_T_marker_k = base_T_flange[k].inverse() * base_T_world * world_T_marker[k];
    R_sum += flange_T_marker_k.linear();
    m += flange_T_marker_k.translation();
  }
  Eigen::Isometry3d flange_T_marker = Eigen::Isometry3d::Identity();
  if (use_rotation) flange_T_marker.linear() = sim::projectToSO3(R_sum);
  flange_T_marker.translation() = m / static_cast<double>(world_T_marker.size());
  return flange_T_marker;
}

}  // namespace orbcal::calib
