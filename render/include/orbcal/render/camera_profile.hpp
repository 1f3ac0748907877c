#pragma once
// A camera profile: what a real camera and a real printed board add to a clean render, as fitted from
// real images against their rendered twins (workflow `orbcal twin`) and applied by `orbcal render
// --profile`. Every part is optional; a default-constructed profile is the identity (the render as it
// is). Models (docs/rendered-datasets-and-images.md, "Camera profile"):
//   - tone: the camera response, out = black + (white - black) * (in / 255)^(1 / gamma), in DN (8-bit);
//     gamma 1 with black 0 and white 255 is the identity (Grossberg and Nayar 2004 for the response curve);
//     white is the response at full input and may exceed 255 DN (a real exposure brighter than the
//     render's): the 8-bit output saturates;
//   - vignetting: radiance times 1 + a2 r^2 + a4 r^4 + a6 r^6 before the tone curve, r the distance to
//     the principal point over the half diagonal of the image (Goldman 2010; Kang and Weiss 2000);
//   - blur: an extra Gaussian point spread function of sigma blur_sigma_px;
//   - sharpening: an unsharp mask out = img + amount (img - G_sigma(img)) after the blur;
//   - noise: Poisson-Gaussian, variance [DN^2] = a * value [DN] + b, drawn after the tone curve
//     (Foi et al. 2008), then rounding to 8 bits;
//   - background: where the board and meshes do not cover the image, a mean level [DN] with a spatial
//     texture of standard deviation texture_dn and correlation length texture_scale_px (a wood table and
//     clutter are not modelled one by one: their level and spread are);
//   - lens: the radial distortion the stated intrinsics lack (a real lens against a camera file without
//     distortion coefficients, or with too few): k1 and k2 added to the camera's own (OpenCV's model,
//     normalised coordinates); the renderer draws through the camera so corrected (profiledCamera);
//   - board: the printed sheet as it is, not as designed: a print scale per axis (1 = exact), a bow
//     (sagitta over the board's half diagonal, along the printed face's normal), and a repeatable
//     displacement per inner-corner id in the board plane (Strobl and Hirzinger 2011).
// Units: DN for grey levels (8-bit), pixels for image lengths, metres inside the code for the board
// (millimetres in camera_profile.yaml, labelled `_mm`).
#include <Eigen/Core>
#include <map>
#include <optional>
#include <random>
#include <string>

#include <opencv2/core.hpp>

#include "orbcal/sim/scene.hpp"

namespace orbcal::render {

struct ToneCurve {
  double black_dn = 0.0;
  double white_dn = 255.0;
  double gamma = 1.0;
  bool identity() const { return black_dn == 0.0 && white_dn == 255.0 && gamma == 1.0; }
};

struct Vignetting {
  double a2 = 0.0, a4 = 0.0, a6 = 0.0;  ///< 1 + a2 r^2 + a4 r^4 + a6 r^6, r in half diagonals
  bool identity() const { return a2 == 0.0 && a4 == 0.0 && a6 == 0.0; }
};

struct SignalNoise {
  double a_dn = 0.0;    ///< variance per DN of signal [DN]
  double b_dn2 = 0.0;   ///< variance at zero signal [DN^2]
  bool identity() const { return a_dn == 0.0 && b_dn2 == 0.0; }
};

struct Sharpening {
  double amount = 0.0;     ///< unsharp-mask gain k (0 = off)
  double sigma_px = 1.0;   ///< the mask's Gaussian
  bool identity() const { return amount == 0.0; }
};

struct Background {
  std::optional<double> mean_dn;   ///< absent: the render's own background
  double texture_dn = 0.0;         ///< spatial standard deviation [DN]
  double texture_scale_px = 8.0;   ///< correlation length of the texture [px]
};

struct LensResidual {
  double k1 = 0.0, k2 = 0.0;  ///< added to the stated camera's k1, k2
  bool identity() const { return k1 == 0.0 && k2 == 0.0; }
};

struct BoardPrint {
  double scale_x = 1.0, scale_y = 1.0;   ///< printed / designed length along the board's x and y
  double bow_m = 0.0;                    ///< sagitta at the half diagonal, along the face normal [m]
  std::map<int, Eigen::Vector2d> corner_displacement_m;  ///< inner-corner id -> (dx, dy) in the board plane [m]
  bool identity() const {
    return scale_x == 1.0 && scale_y == 1.0 && bow_m == 0.0 && corner_displacement_m.empty();
  }
};

struct CameraProfile {
  std::string source;   ///< the file it was read from (messages), or "fitted by orbcal twin"
  ToneCurve tone;
  Vignetting vignetting;
  double blur_sigma_px = 0.0;
  Sharpening sharpening;
  SignalNoise noise;
  Background background;
  LensResidual lens;
  BoardPrint board;
  bool identity() const;
  /// Nothing for the renderer to draw differently: no lens part and the board as designed.
  bool geometryIdentity() const { return lens.identity() && board.identity(); }
  /// Nothing for applyCameraProfile to do (the board part may still be set).
  bool imageIdentity() const;
};

/// Reads camera_profile.yaml (format: orbcal-camera-profile-1). Misspelt keys, NaN, gamma <= 0,
/// white <= black, negative noise or blur, scales outside [0.9, 1.1] or bows beyond 5% of the board's
/// half diagonal: sim::InputError naming the file and the key.
CameraProfile loadCameraProfile(const std::string& path);
/// Writes it atomically (a temporary file renamed), millimetres and DN labelled in the keys.
void saveCameraProfile(const CameraProfile& profile, const std::string& path);

/// The camera the images are taken through: `stated` with the profile's lens part added to its k1, k2.
sim::Camera profiledCamera(const sim::Camera& stated, const CameraProfile& profile);
/// Length (px) of the shift a residual distortion `lens` gives the image corner farthest from the
/// principal point of `stated` (the lens part's size as named: distortNormalized with and without it).
double lensShiftAtImageCorner(const sim::Camera& stated, const LensResidual& lens);

/// The tone curve at one grey level: black + (white - black) * (clamp(in_dn, 0, 255) / 255)^(1 / gamma).
double toneCurve(const ToneCurve& tone, double in_dn);
/// 1 + a2 r^2 + a4 r^4 + a6 r^6 (r in half diagonals of the image).
double vignettingFactor(const Vignetting& vignetting, double r);

/// Where the printed board puts the point of the designed board at (x, y) (board frame, metres):
///   - print scale about the board frame's origin (inner corner 0): (scale_x x, scale_y y);
///   - displacement: the per-corner displacements interpolated bilinearly over the grid of inner
///     corners (corners not listed move by 0; outside the grid the nearest edge of the grid is used),
///     so inner corner k lands exactly on its designed place scaled plus its displacement;
///   - bow: z = -bow_m (r / R)^2, r the distance of the designed point from the centre of the board's
///     outline and R its half diagonal: a positive bow lifts the sheet's rim toward the printed face's
///     side (the side the camera sees it from, -z_board), so the centre is the farthest point.
/// The identity print returns (x, y, 0).
Eigen::Vector3d printedBoardPoint(const sim::Board& board, const BoardPrint& print, const Eigen::Vector2d& designed_m);
/// The printed face's normal (unit, pointing along -z_board like the flat board's) at the designed point.
Eigen::Vector3d printedBoardNormal(const sim::Board& board, const BoardPrint& print, const Eigen::Vector2d& designed_m);
/// The checks of the board part that need the board: corner ids within [0, numCorners) and |bow| at
/// most 5% of the board's half diagonal. sim::InputError naming profile.source and the key.
void checkBoardPrint(const CameraProfile& profile, const sim::Board& board);

/// The image part of the profile applied to a clean render (CV_8UC1, values = linear radiance in DN):
/// vignetting (about camera's principal point), tone curve, blur, sharpening, background (where
/// `covered` is zero; `covered` is CV_8UC1 of the image's size, or empty for "everything covered"),
/// noise, rounding. `covered` is a fraction in 1/255 (a board edge's antialiased pixels are partly
/// covered): out = c/255 img + (1 - c/255) background. The background's texture is white noise
/// smoothed by a Gaussian of sigma texture_scale_px, scaled by the kernel's exact gain to a standard
/// deviation of texture_dn (its autocorrelation is exp(-d^2 / (4 texture_scale_px^2))). The normal
/// values of texture and noise come from OpenCV's generator (cv::RNG) seeded by a draw of `rng`, ten
/// times faster than std::normal_distribution per pixel. Returns `clean` itself when imageIdentity(). Randomness only from `rng`. The board part (print, bow, displacements) is geometry:
/// the renderer draws it (BoardRenderer with a profile).
cv::Mat applyCameraProfile(const cv::Mat& clean, const cv::Mat& covered, const CameraProfile& profile,
                           const sim::Camera& camera, std::mt19937_64& rng);

}  // namespace orbcal::render
