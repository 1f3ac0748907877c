#pragma once
// Scene geometry shared by render/, vision/ and calib/: the pinhole camera (OpenCV's model and pixel
// convention: pixel centres at integer coordinates, y down), the checkerboard, and where both are.
//
// Board frame: origin at the first inner corner, x along a row of inner corners, y down the columns,
// z = x × y pointing away from the printed face (the camera sees the board from -z). Inner corner
// k = r * corners_x + c sits at (c s, r s, 0): the order cv::findChessboardCorners reports.
#include <Eigen/Geometry>
#include <array>
#include <string>
#include <vector>

namespace orbcal::sim {

struct Camera {
  int width_px = 1280;
  int height_px = 1024;
  double fx_px = 1400.0, fy_px = 1400.0;
  double cx_px = 639.5, cy_px = 511.5;
  /// OpenCV's (k1, k2, p1, p2, k3).
  std::array<double, 5> distortion{0.0, 0.0, 0.0, 0.0, 0.0};
  bool hasDistortion() const;
};

/// Pixel of a point in camera coordinates (m), OpenCV's model with distortion (cv::projectPoints).
Eigen::Vector2d project(const Camera& camera, const Eigen::Vector3d& p_cam);

/// OpenCV's lens distortion of normalised coordinates xy = (x/z, y/z), k = (k1, k2, p1, p2, k3):
///   r2 = x^2 + y^2, radial = 1 + k1 r2 + k2 r2^2 + k3 r2^3,
///   xd = x radial + 2 p1 x y + p2 (r2 + 2 x^2),  yd = y radial + p1 (r2 + 2 y^2) + 2 p2 x y.
/// The one place this polynomial is written (project() and render's inverse mapping use it).
/// J_distorted_xy (optional) receives d(xd, yd) / d(x, y).
Eigen::Vector2d distortNormalized(const std::array<double, 5>& k, const Eigen::Vector2d& xy,
                                  Eigen::Matrix2d* J_distorted_xy = nullptr);

/// The board's pattern. A ChArUco board (OpenCV's aruco module) has the chessboard's squares and
/// colouring, plus an ArUco marker centred in every white square (charucoMarkers), so that each inner
/// corner is known by its identity and a partly visible board still gives a pose. A circle grid
/// (cv::findCirclesGrid's pattern) has dark circles on white; its "corners" are the circles' centres:
/// corners_x circles a row, corners_y rows, spacing square_m. Symmetric: circle k = r * corners_x + c at
/// (c s, r s, 0); asymmetric (CALIB_CB_ASYMMETRIC_GRID): at ((2 c + r % 2) s, r s, 0), as OpenCV's
/// calibration sample (calcBoardCornerPositions) lays it out, so that neighbours in a row are 2 s apart
/// and the rows s apart. Origin at the first circle's centre, x along a row, y to the next row, z = x × y
/// away from the printed face, as for the other boards.
enum class BoardType { kChessboard, kCharuco, kCircles };

struct Board {
  BoardType type = BoardType::kChessboard;
  std::string dictionary;  ///< ChArUco only: OpenCV's predefined dictionary, e.g. "DICT_5X5_100"
  double marker_m = 0.0;   ///< ChArUco only: side of a marker (black border included), < square_m
  int corners_x = 9;       ///< inner corners along board x (squares along x = corners_x + 1)
  int corners_y = 6;       ///< inner corners along board y
  double square_m = 0.08;  ///< side of one square
  double margin_m = 0.08;  ///< white border around the squares (a circle grid: around circleArea)
  double diameter_m = 0.0;  ///< circle grid only: the circles' diameter
  bool asymmetric = false;  ///< circle grid only: OpenCV's asymmetric layout (BoardType)
  int numCorners() const { return corners_x * corners_y; }
};

/// True when the board's pattern is the same after a half turn about its normal through its centre, so
/// that an image cannot tell corner k from corner numCorners() - 1 - k: a symmetric circle grid, and an
/// asymmetric one of an even number of rows. (Chessboards of same-parity square counts are refused where
/// they are read.)
bool halfTurnSymmetric(const Board& board);
/// board_T_turned of that half turn: corner numCorners() - 1 - k of the turned frame is corner k.
Eigen::Isometry3d halfTurn(const Board& board);

/// OpenCV's predefined ArUco dictionaries DICT_NxN_M (N = 4..7, M = 50, 100, 250, 1000): the value of
/// cv::aruco::PREDEFINED_DICTIONARY_NAME for `name`, its marker count M and bits per side N; false for
/// another name. (sim does not link OpenCV; render/ and vision/ cast the id.)
struct ArucoDictionaryInfo {
  int cv_id = -1;
  int markers = 0;
  int bits = 0;
};
bool arucoDictionary(const std::string& name, ArucoDictionaryInfo* info);

/// One ArUco marker of a ChArUco board: the OpenCV id (0, 1, ... over the white squares row by row,
/// as cv::aruco::CharucoBoard numbers them), its square (i, j) as in isBlackSquare, and its corner of
/// lowest x and y in the board frame (the marker image's top-left; it spans marker_m along +x and +y).
/// A ChArUco board's inner corner k is OpenCV's ChArUco corner id k: the board frame is OpenCV's
/// CharucoBoard frame shifted by (-square_m, -square_m), the same axes.
struct CharucoMarker {
  int id = 0;
  int i = 0, j = 0;
  Eigen::Vector3d top_left;
};
std::vector<CharucoMarker> charucoMarkers(const Board& board);

/// Inner corner k in the board frame (m).
Eigen::Vector3d cornerInBoard(const Board& board, int k);
/// The board's colouring, the one contract render/ draws and vision/ reads the orientation from.
/// Square (i, j), i in [0, corners_x], j in [0, corners_y], covers x in [(i-1)s, i s], y in
/// [(j-1)s, j s] of the board frame; it is black when i + j is even. So square (0, 0), diagonally
/// outside corner 0, and square (1, 1), between inner corners 0, 1, corners_x and corners_x + 1, are
/// black; the margin around the squares is white.
bool isBlackSquare(int i, int j);
/// All inner corners, in detection order.
std::vector<Eigen::Vector3d> boardCorners(const Board& board);
/// The four outer corners of the squared area, in the board frame (m); of a circle grid, its circles'
/// area: the centres' bounding box grown by one spacing on every side (the circles' radius is less than
/// half the nearest spacing, so a white ring surrounds the outer circles).
std::array<Eigen::Vector3d, 4> squaresOutline(const Board& board);
/// The four outer corners of the whole board: the squared area grown by margin_m on every side,
/// in the board frame (m), in the same order as squaresOutline.
std::array<Eigen::Vector3d, 4> boardOutline(const Board& board);

/// What the configuration generator accepts as a usable view of the board.
struct ViewConstraints {
  double min_distance_m = 1.5;        ///< camera centre to board centre
  double max_distance_m = 2.5;
  double max_tilt_rad = 0.7854;       ///< between the optical axis and the board normal (45 deg)
  double image_margin_px = 20.0;      ///< every corner at least this far inside the image
  double min_singular_value = 0.01;   ///< of the scaled manipulator Jacobian; see configurations.hpp
  /// 0-based joint the generator's IK holds at a random value (Wang et al. 2023 locks theta_2: 1); -1 for none.
  /// In the scene file: views.locked_joint, a 1-based joint number (0 = none).
  int locked_joint = 1;
};

struct Scene {
  std::string name;
  std::string source;  ///< file the scene was loaded from (for messages)
  Camera camera;
  /// The camera file (ROS camera_info or OpenCV FileStorage) when the scene's camera is {file: PATH},
  /// resolved against the scene file's folder; empty when the camera is inline (sim/camera_io.hpp).
  std::string camera_file;
  Board board;
  Eigen::Isometry3d base_T_board = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d flange_T_camera = Eigen::Isometry3d::Identity();
  ViewConstraints views;
};

/// Centre of the board's corners (circle centres) in the board frame (m).
Eigen::Vector3d boardCentre(const Board& board);

/// Why a camera pose does not see the whole board, or kVisible.
enum class Visibility { kVisible, kBehind, kOutsideImage, kTooFar, kTooNear, kTooOblique };
Visibility boardVisibility(const Scene& scene, const Eigen::Isometry3d& camera_T_board);
const char* toString(Visibility v);

}  // namespace orbcal::sim
