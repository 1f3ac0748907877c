#pragma once
// Real images of a board as a measurement description (the `orbcal-measurements-1` file of
// sim/measured.hpp) describes them: one CSV row per image, with the image's path and, per row, either
// the flange pose the controller reported (no robot model needed: hand-eye only) or the joint readings
// of a robot (the flange pose is then the nominal arm's).
//
//   format: orbcal-measurements-1
//   files: [views.csv]                     # one row per image; relative to this file or absolute
//   images: {column: image}                # image paths, relative to the CSV; optional keys:
//                                          #   ignore: coloured   pixels of clear colour are what a capture
//                                          #                      tool drew (a printed board is grey): masked
//                                          #   mask: mask.png     non-zero pixels are ignored (every image)
//                                          #   mask_column: m     a mask per image (paths relative to the CSV)
//                                          #   rectangles: [[x0, y0, x1, y1], ...]  px, ignored in every image
//   flange_pose: {file_column: pose, length_unit: mm}   # a pose file per row: 16 numbers (a row-major
//                                          #   4x4 matrix) or a YAML map {x, y, z, qx, qy, qz, qw}; or
//                                          #   {matrix: [16 names]} or {position: [3], quaternion_wxyz: [4]}
//                                          #   columns of the CSV; base_T_flange, p_base = T p_flange
//   # robot: panda.yaml  joints: {columns: [q1, ...], unit: rad}   # instead of flange_pose
//   camera: camera.yaml                    # ROS camera_info or OpenCV FileStorage; or the scene's inline
//                                          #   keys {width_px, height_px, fx_px, fy_px, cx_px, cy_px, distortion}
//   board:
//     charuco: {squares: [7, 5], square_mm: 30, marker_mm: 22, dictionary: DICT_4X4_50}
//     # chessboard: {squares: [10, 7], square_mm: 25}
//     # circles: {grid: [4, 11], spacing_mm: 20, diameter_mm: 15, asymmetric: true}   # cv::findCirclesGrid's
//     #   patternSize (circles a row, rows); spacing s as in sim::cornerInBoard; frame: opencv only
//     frame: opencv                        # the board frame the results are written in: opencv (OpenCV
//                                          #   >= 4.6, default) or legacy (<= 4.5: (x, H - y, -z))
//     margin_mm: 10                        # the sheet's white margin around the squares or the circles'
//                                          #   area (sim::squaresOutline; optional)
//   setup: eye_in_hand                     # or eye_to_hand (a static camera, the board on the flange)
//
// `squares: [X, Y]` counts the squares along the board's x and y axes (OpenCV's CharucoBoard((X, Y))).
// Controller poses: a rotation off orthonormal by at most 1e-6 (max |R^T R - I|) is used as given, by
// less than 1e-4 (a controller printing 4 decimals: 0.7071 for 1/sqrt(2) is off by 1.9e-5) it is
// re-orthonormalised (nearest rotation) with a warning, beyond that it is refused. Errors are one-line
// InputErrors naming the file and the key (or the CSV's line and column).
#include <Eigen/Geometry>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "orbcal/sim/arm.hpp"
#include "orbcal/sim/sample.hpp"
#include "orbcal/sim/scene.hpp"

namespace orbcal::sim {

/// Where the camera is: on the flange (looking at a fixed board) or fixed (looking at a board the
/// flange carries).
enum class HandEyeSetup { kEyeInHand, kEyeToHand };
const char* handEyeSetupName(HandEyeSetup s);  ///< "eye_in_hand", "eye_to_hand"

/// The frame the board's pose is written in: OpenCV >= 4.6's CharucoBoard frame (origin at the outer
/// corner of square (0, 0), z into the board), or the legacy (<= 4.5) one, (x, H - y, -z).
enum class BoardFrameConvention { kOpenCv, kLegacy };

/// Rotations re-orthonormalised with a warning below this (max |R^T R - I|); refused above.
inline constexpr double kControllerRotationTolerance = 1e-4;

/// What to ignore in the images: pixels a capture tool drew (clear colours), a mask, rectangles.
struct ImageMask {
  bool ignore_coloured = false;
  std::string mask_file;                       ///< resolved; empty: none
  std::vector<std::array<int, 4>> rectangles;  ///< x0, y0, x1, y1 (px, inclusive, exclusive)
};

struct ImageView {
  std::string image;                ///< resolved path
  std::string mask;                 ///< this view's mask file (mask_column), resolved; empty: none
  Eigen::Isometry3d base_T_flange = Eigen::Isometry3d::Identity();  ///< m
  JointSample sample;               ///< with a robot: the joint readings (else q_rad empty)
  std::string where;                ///< "<csv>: line L"
};

struct ImageViews {
  std::string description;
  std::vector<std::string> files;   ///< the CSVs, resolved
  std::string robot_file;           ///< empty: flange poses given
  std::optional<Arm> arm;           ///< the nominal arm where joints are given
  Camera camera;
  std::string camera_file;          ///< empty: inline
  Board board;                      ///< orbcal's frame: origin at inner corner 0 (sim::cornerInBoard)
  BoardFrameConvention board_frame = BoardFrameConvention::kOpenCv;
  HandEyeSetup setup = HandEyeSetup::kEyeInHand;
  ImageMask mask;
  std::vector<ImageView> views;     ///< every row of every file, in file order
  std::vector<std::string> warnings;  ///< re-orthonormalised poses, one line each
};

/// True when the description has an `images:` key (then loadImageViews reads it, not loadMeasuredData).
bool describesImages(const std::string& description_path);

/// Reads an image description and its CSVs (the images themselves are not opened here).
ImageViews loadImageViews(const std::string& description_path);

/// printed_T_board: the board frame the user's convention names (BoardFrameConvention) from orbcal's
/// (origin at inner corner 0): multiply a pose of orbcal's board frame on the right by its inverse.
Eigen::Isometry3d printedFromBoard(const Board& board, BoardFrameConvention convention);

/// A controller's rotation within kControllerRotationTolerance made a rotation (nearest in Frobenius
/// norm); `warning` receives a line when it was changed by more than 1e-6. InputError (`where`) beyond.
Eigen::Matrix3d controllerRotation(const Eigen::Matrix3d& R, const std::string& where, std::string* warning);

}  // namespace orbcal::sim
