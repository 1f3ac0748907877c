// The camera profile's models (camera_profile.hpp): the image part applied to a clean render, and the
// printed board's geometry the renderer draws. Reading and writing the file: camera_profile_io.cpp.
#include "orbcal/render/camera_profile.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <vector>

#include "orbcal/render/degrade.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/io.hpp"

namespace orbcal::render {

bool CameraProfile::imageIdentity() const {
  return tone.identity() && vignetting.identity() && blur_sigma_px == 0.0 && sharpening.identity() &&
         noise.identity() && !background.mean_dn.has_value();
}

bool CameraProfile::identity() const { return imageIdentity() && geometryIdentity(); }

sim::Camera profiledCamera(const sim::Camera& stated, const CameraProfile& profile) {
  sim::Camera c = stated;
  c.distortion[0] += profile.lens.k1;
  c.distortion[1] += profile.lens.k2;
  return c;
}

double lensShiftAtImageCorner(const sim::Camera& stated, const LensResidual& lens) {
  CameraProfile p;
  p.lens = lens;
  const sim::Camera real = profiledCamera(stated, p);
  double farthest = -1.0, shift = 0.0;
  for (const double u : {0.0, static_cast<double>(stated.width_px)}) {
    for (const double v : {0.0, static_cast<double>(stated.height_px)}) {
      const Eigen::Vector2d xy((u - stated.cx_px) / stated.fx_px, (v - stated.cy_px) / stated.fy_px);
      if (xy.norm() <= farthest) continue;
      farthest = xy.norm();
      const Eigen::Vector2d d = sim::distortNormalized(real.distortion, xy) - sim::distortNormalized(stated.distortion, xy);
      shift = std::hypot(d.x() * stated.fx_px, d.y() * stated.fy_px);
    }
  }
  return shift;
}

double toneCurve(const ToneCurve& tone, double in_dn) {
  const double x = std::clamp(in_dn / 255.0, 0.0, 1.0);
  return tone.black_dn + (tone.white_dn - tone.black_dn) * std::pow(x, 1.0 / tone.gamma);
}

double vignettingFactor(const Vignetting& v, double r) {
  const double r2 = r * r;
  return 1.0 + r2 * (v.a2 + r2 * (v.a4 + r2 * v.a6));
}

namespace {

/// The designed board's outline centre and half diagonal (the bow's r and R).
void bowFrame(const sim::Board& board, Eigen::Vector2d* centre, double* half_diagonal) {
  const std::array<Eigen::Vector3d, 4> o = sim::boardOutline(board);  // [0] lowest x and y, [2] highest
  *centre = 0.5 * (o[0] + o[2]).head<2>();
  *half_diagonal = 0.5 * (o[2] - o[0]).head<2>().norm();
}

/// The displacement at a designed point: bilinear over the inner-corner grid, clamped to the grid.
Eigen::Vector2d displacementAt(const sim::Board& b, const BoardPrint& print, const Eigen::Vector2d& p) {
  if (print.corner_displacement_m.empty()) return Eigen::Vector2d::Zero();
  const auto at = [&](int i, int j) {
    const auto it = print.corner_displacement_m.find(j * b.corners_x + i);
    return it == print.corner_displacement_m.end() ? Eigen::Vector2d::Zero() : it->second;
  };
  const double gx = std::clamp(p.x() / b.square_m, 0.0, double(b.corners_x - 1));
  const double gy = std::clamp(p.y() / b.square_m, 0.0, double(b.corners_y - 1));
  const int i0 = std::min(static_cast<int>(std::floor(gx)), std::max(0, b.corners_x - 2));
  const int j0 = std::min(static_cast<int>(std::floor(gy)), std::max(0, b.corners_y - 2));
  const int i1 = std::min(i0 + 1, b.corners_x - 1), j1 = std::min(j0 + 1, b.corners_y - 1);
  const double fx = gx - i0, fy = gy - j0;
  return (1 - fx) * (1 - fy) * at(i0, j0) + fx * (1 - fy) * at(i1, j0) + (1 - fx) * fy * at(i0, j1) +
         fx * fy * at(i1, j1);
}

}  // namespace

Eigen::Vector3d printedBoardPoint(const sim::Board& board, const BoardPrint& print, const Eigen::Vector2d& p) {
  if (print.identity()) return Eigen::Vector3d(p.x(), p.y(), 0.0);
  const Eigen::Vector2d xy = Eigen::Vector2d(print.scale_x * p.x(), print.scale_y * p.y()) + displacementAt(board, print, p);
  Eigen::Vector2d centre;
  double R = 1.0;
  bowFrame(board, &centre, &R);
  return Eigen::Vector3d(xy.x(), xy.y(), -print.bow_m * (p - centre).squaredNorm() / (R * R));
}

Eigen::Vector3d printedBoardNormal(const sim::Board& board, const BoardPrint& print, const Eigen::Vector2d& p) {
  if (print.bow_m == 0.0) return Eigen::Vector3d(0, 0, -1);
  Eigen::Vector2d centre;
  double R = 1.0;
  bowFrame(board, &centre, &R);
  const Eigen::Vector2d grad = -2.0 * print.bow_m * (p - centre) / (R * R);  // dz/dx, dz/dy
  return Eigen::Vector3d(grad.x(), grad.y(), -1.0).normalized();  // the surface z = f(x, y), front side
}

void checkBoardPrint(const CameraProfile& profile, const sim::Board& board) {
  for (const auto& [id, d] : profile.board.corner_displacement_m) {
    if (id < 0 || id >= board.numCorners()) {
      throw sim::InputError(profile.source + ": board.corner_displacements: corner id " + std::to_string(id) +
                            " is not an inner corner of the scene's board (0.." + std::to_string(board.numCorners() - 1) + ")");
    }
  }
  Eigen::Vector2d centre;
  double R = 1.0;
  bowFrame(board, &centre, &R);
  if (std::abs(profile.board.bow_m) > 0.05 * R) {
    throw sim::InputError(profile.source + ": board.bow_mm: " + std::to_string(profile.board.bow_m * 1e3) +
                          " mm is beyond 5% of the board's half diagonal (" + std::to_string(R * 1e3) + " mm)");
  }
}

namespace {

/// Scratch images of this thread, reused from image to image: a fresh 5 MB buffer is fresh pages from the
/// kernel each time, which cost as much as the arithmetic on a loaded machine (~40 ms per buffer here).
struct Scratch {
  cv::Mat img, smooth, normal, texture;
};
Scratch& scratch() {
  thread_local Scratch s;
  return s;
}

/// `field` (CV_32FC1 of `size`) filled with standard normal values from OpenCV's generator seeded by one
/// draw of `rng`: per pixel, std::normal_distribution over std::mt19937_64 costs ~10x more.
void fillNormal(cv::Mat& field, cv::Size size, std::mt19937_64& rng) {
  field.create(size, CV_32FC1);
  cv::RNG cv_rng(rng());
  cv_rng.fill(field, cv::RNG::NORMAL, 0.0, 1.0);
}

/// Smoothed white noise of standard deviation 1 (the kernel's exact gain divided out) and sigma scale_px.
cv::Mat textureField(cv::Size size, double scale_px, std::mt19937_64& rng) {
  const int pad = static_cast<int>(std::ceil(4.0 * scale_px));
  cv::Mat& field = scratch().texture;
  fillNormal(field, cv::Size(size.width + 2 * pad, size.height + 2 * pad), rng);
  const cv::Mat k = cv::getGaussianKernel(2 * pad + 1, scale_px, CV_64F);  // what gaussianBlur uses
  const double gain = k.dot(k);  // the variance of separable smoothing of unit white noise: (sum k^2)^2
  gaussianBlur(field, scale_px);
  field *= static_cast<float>(1.0 / gain);
  return field(cv::Rect(pad, pad, size.width, size.height));
}

/// The tone curve as a table: kToneSteps entries a DN, linear between them (off the curve by < 1e-3 DN
/// above 1 DN); below 1 DN, where x^(1 / gamma) is steep, the curve itself.
class ToneTable {
 public:
  static constexpr int kToneSteps = 16;
  explicit ToneTable(const ToneCurve& t) : tone_(t), table_(255 * kToneSteps + 2) {
    for (std::size_t i = 0; i < table_.size(); ++i) table_[i] = static_cast<float>(toneCurve(t, double(i) / kToneSteps));
  }
  float operator()(double v) const {
    if (v < 1.0) return static_cast<float>(toneCurve(tone_, v));
    const double x = std::min(v, 255.0) * kToneSteps;
    const int i = static_cast<int>(x);
    const float f = static_cast<float>(x - i);
    return table_[i] + f * (table_[i + 1] - table_[i]);
  }

 private:
  ToneCurve tone_;
  std::vector<float> table_;
};

void applyVignettingAndTone(cv::Mat& img, const CameraProfile& profile, const sim::Camera& camera) {
  const bool vignette = !profile.vignetting.identity(), tone = !profile.tone.identity();
  if (!vignette && !tone) return;
  const double half_diagonal = 0.5 * std::hypot(img.cols, img.rows);
  float lut[256];  // the tone curve at integer levels, for images without vignetting
  for (int i = 0; i < 256; ++i) lut[i] = static_cast<float>(toneCurve(profile.tone, i));
  const ToneTable table(profile.tone);
  for (int r = 0; r < img.rows; ++r) {
    float* p = img.ptr<float>(r);
    const double dy = (r - camera.cy_px) / half_diagonal;
    for (int c = 0; c < img.cols; ++c) {
      if (!vignette) {
        p[c] = lut[std::clamp(static_cast<int>(p[c]), 0, 255)];  // p[c] holds an integer level here
        continue;
      }
      const double dx = (c - camera.cx_px) / half_diagonal;
      const double v = p[c] * vignettingFactor(profile.vignetting, std::sqrt(dx * dx + dy * dy));
      p[c] = tone ? table(v) : static_cast<float>(std::clamp(v, 0.0, 255.0));
    }
  }
}

void applyBackground(cv::Mat& img, const cv::Mat& covered, const Background& bg, std::mt19937_64& rng) {
  if (!bg.mean_dn) return;
  if (!covered.empty() && (covered.size() != img.size() || covered.type() != CV_8UC1)) {
    throw std::invalid_argument("applyCameraProfile: `covered` must be CV_8UC1 of the image's size");
  }
  if (covered.empty()) return;  // everything covered
  const cv::Mat texture = bg.texture_dn > 0 ? textureField(img.size(), bg.texture_scale_px, rng) : cv::Mat();
  for (int r = 0; r < img.rows; ++r) {
    float* p = img.ptr<float>(r);
    const unsigned char* c = covered.ptr<unsigned char>(r);
    const float* t = texture.empty() ? nullptr : texture.ptr<float>(r);
    for (int x = 0; x < img.cols; ++x) {
      if (c[x] == 255) continue;
      const float level = static_cast<float>(*bg.mean_dn + (t ? bg.texture_dn * t[x] : 0.0));
      const float f = c[x] / 255.f;
      p[x] = f * p[x] + (1.f - f) * level;
    }
  }
}

void applyNoise(cv::Mat& img, const SignalNoise& n, std::mt19937_64& rng) {
  if (n.identity()) return;
  cv::Mat& n01 = scratch().normal;
  fillNormal(n01, img.size(), rng);
  const float a = static_cast<float>(n.a_dn), b = static_cast<float>(n.b_dn2);
  for (int r = 0; r < img.rows; ++r) {
    float* p = img.ptr<float>(r);
    const float* z = n01.ptr<float>(r);
    for (int c = 0; c < img.cols; ++c) p[c] += std::sqrt(a * std::max(0.f, p[c]) + b) * z[c];
  }
}

}  // namespace

cv::Mat applyCameraProfile(const cv::Mat& clean, const cv::Mat& covered, const CameraProfile& profile,
                           const sim::Camera& camera, std::mt19937_64& rng) {
  if (clean.type() != CV_8UC1) throw std::invalid_argument("applyCameraProfile: expected a CV_8UC1 image");
  if (profile.imageIdentity()) return clean;
  cv::Mat& img = scratch().img;
  clean.convertTo(img, CV_32FC1);
  applyVignettingAndTone(img, profile, camera);
  gaussianBlur(img, profile.blur_sigma_px);
  if (!profile.sharpening.identity()) {
    cv::Mat& smooth = scratch().smooth;
    img.copyTo(smooth);
    gaussianBlur(smooth, profile.sharpening.sigma_px);
    const double k = profile.sharpening.amount;
    cv::addWeighted(img, 1.0 + k, smooth, -k, 0.0, img);  // img + k (img - smooth)
  }
  applyBackground(img, covered, profile.background, rng);
  applyNoise(img, profile.noise, rng);
  cv::Mat out;
  img.convertTo(out, CV_8UC1);  // rounds and saturates
  return out;
}

}  // namespace orbcal::render
