#include "orbcal/render/distortion.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <opencv2/imgproc.hpp>

namespace orbcal::render {

namespace {
constexpr int kMaxNewtonIterations = 50;
// A single Newton step from a predicted ray is accepted when it moves less than this (normalised units,
// 0.014 px at f = 1400 px): the predicted ray was about that close, so the step leaves ~1e-10 (~1e-7 px).
constexpr double kPredictedStepTol = 1e-5;
constexpr double kNewtonTol = 1e-14;  // normalised units: ~1e-11 px at f = 1400 px
constexpr int kBicubicReachPx = 2;  // a lookup at x reads floor(x) - 1 .. floor(x) + 2; x is rounded to 1/32 px first
constexpr int kGatherRowPx = 4096;  // applyDistortion's gathered lookups: cv::remap's rows
constexpr int kBorderPx = 2;          // around the used area of the pinhole image: bicubic lookups read 4 x 4 pixels (-1..+2)
}  // namespace

bool undistortNormalized(const std::array<double, 5>& k, const Eigen::Vector2d& xd, Eigen::Vector2d* out,
                         const Eigen::Vector2d* start) {
  Eigen::Vector2d x = start ? *start : xd;
  for (int it = 0; it < kMaxNewtonIterations; ++it) {
    Eigen::Matrix2d J;
    const Eigen::Vector2d f = sim::distortNormalized(k, x, &J) - xd;
    const double det = J.determinant();
    if (!(det > 0.0)) return false;
    if (std::abs(f.x()) < kNewtonTol && std::abs(f.y()) < kNewtonTol) {
      *out = x;
      return true;
    }
    x -= Eigen::Vector2d(J(1, 1) * f.x() - J(0, 1) * f.y(), J(0, 0) * f.y() - J(1, 0) * f.x()) / det;
    if (!std::isfinite(x.x()) || !std::isfinite(x.y())) return false;
  }
  return false;
}

namespace {
/// One Newton step for sim::distortNormalized(k, x) = xd from `start`, accepted (true, *x set) when the
/// Jacobian there is positive and the step is under kPredictedStepTol in both coordinates: then start was
/// that close to the root and the step leaves ~(kPredictedStepTol)^2 (quadratic convergence).
bool newtonStepFrom(const std::array<double, 5>& k, const Eigen::Vector2d& xd, const Eigen::Vector2d& start, Eigen::Vector2d* x) {
  Eigen::Matrix2d J;
  const Eigen::Vector2d f = sim::distortNormalized(k, start, &J) - xd;
  const double det = J.determinant();
  if (!(det > 0.0)) return false;
  const Eigen::Vector2d step(J(1, 1) * f.x() - J(0, 1) * f.y(), J(0, 0) * f.y() - J(1, 0) * f.x());
  if (!(std::abs(step.x()) < kPredictedStepTol * det && std::abs(step.y()) < kPredictedStepTol * det)) return false;
  *x = start - step / det;
  return true;
}
}  // namespace

DistortionMap makeDistortionMap(const sim::Camera& camera, int max_side_px) {
  const int W = camera.width_px, H = camera.height_px;
  cv::Mat nx(H, W, CV_64FC1), ny(H, W, CV_64FC1);
  cv::Mat valid(H, W, CV_8UC1, cv::Scalar(0));
  // Rows in parallel (each pixel on its own: the same map whatever the split); the extent per row.
  cv::Mat extent(H, 4, CV_64FC1);  // xmin, xmax, ymin, ymax of the row's valid pixels
  cv::parallel_for_(cv::Range(0, H), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      double* e = extent.ptr<double>(v);
      e[0] = e[2] = 1e300, e[1] = e[3] = -1e300;
      // The rays of the valid pixels just left of u: after two, one Newton step from their linear
      // extrapolation (off by ~1e-7) is accepted when it moves less than kPredictedStepTol, which leaves
      // the result within ~1e-10 of the root (tests/render: float rounding of the map is all that
      // differs); otherwise Newton's method from the pixel to the left (2-3 steps instead of 5-6), and
      // from xd when that fails.
      int run = 0;
      Eigen::Vector2d x, left, left2;
      for (int u = 0; u < W; ++u) {
        const Eigen::Vector2d xd((u - camera.cx_px) / camera.fx_px, (v - camera.cy_px) / camera.fy_px);
        const bool ok = (run >= 2 && newtonStepFrom(camera.distortion, xd, 2.0 * left - left2, &x)) ||
                        (run >= 1 && undistortNormalized(camera.distortion, xd, &x, &left)) ||
                        undistortNormalized(camera.distortion, xd, &x);
        if (!ok) {
          run = 0;
          continue;
        }
        left2 = left, left = x, ++run;
        nx.at<double>(v, u) = x.x();
        ny.at<double>(v, u) = x.y();
        valid.at<unsigned char>(v, u) = 1;
        e[0] = std::min(e[0], x.x()), e[1] = std::max(e[1], x.x());
        e[2] = std::min(e[2], x.y()), e[3] = std::max(e[3], x.y());
      }
    }
  });
  double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
  for (int v = 0; v < H; ++v) {
    const double* e = extent.ptr<double>(v);
    xmin = std::min(xmin, e[0]), xmax = std::max(xmax, e[1]), ymin = std::min(ymin, e[2]), ymax = std::max(ymax, e[3]);
  }
  DistortionMap m;
  m.pinhole = camera;
  m.pinhole.distortion = {0, 0, 0, 0, 0};
  if (xmin > xmax) {  // nothing invertible: keep the camera, map everything to background
    m.map_x = cv::Mat(H, W, CV_32FC1, cv::Scalar(-1));
    m.map_y = cv::Mat(H, W, CV_32FC1, cv::Scalar(-1));
    cv::convertMaps(m.map_x, m.map_y, m.map_fixed, m.map_fraction, CV_16SC2);
    return m;
  }
  double scale = 1.0;
  const double need_w = camera.fx_px * (xmax - xmin) + 2 * kBorderPx + 1;
  const double need_h = camera.fy_px * (ymax - ymin) + 2 * kBorderPx + 1;
  scale = std::min({1.0, (max_side_px - 1.0) / need_w, (max_side_px - 1.0) / need_h});
  m.pinhole.fx_px = camera.fx_px * scale;
  m.pinhole.fy_px = camera.fy_px * scale;
  m.pinhole.cx_px = kBorderPx - m.pinhole.fx_px * xmin;
  m.pinhole.cy_px = kBorderPx - m.pinhole.fy_px * ymin;
  m.pinhole.width_px = static_cast<int>(std::ceil(m.pinhole.fx_px * xmax + m.pinhole.cx_px)) + kBorderPx + 1;
  m.pinhole.height_px = static_cast<int>(std::ceil(m.pinhole.fy_px * ymax + m.pinhole.cy_px)) + kBorderPx + 1;
  m.map_x.create(H, W, CV_32FC1);
  m.map_y.create(H, W, CV_32FC1);
  cv::parallel_for_(cv::Range(0, H), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      const unsigned char* ok = valid.ptr<unsigned char>(v);
      const double *x = nx.ptr<double>(v), *y = ny.ptr<double>(v);
      float *mx = m.map_x.ptr<float>(v), *my = m.map_y.ptr<float>(v);
      for (int u = 0; u < W; ++u) {
        mx[u] = ok[u] ? static_cast<float>(m.pinhole.fx_px * x[u] + m.pinhole.cx_px) : -1.f;
        my[u] = ok[u] ? static_cast<float>(m.pinhole.fy_px * y[u] + m.pinhole.cy_px) : -1.f;
      }
    }
  });
  cv::convertMaps(m.map_x, m.map_y, m.map_fixed, m.map_fraction, CV_16SC2);
  m.tiles_x = (W + m.tile_px - 1) / m.tile_px;
  m.tiles_y = (H + m.tile_px - 1) / m.tile_px;
  m.tile_reads.assign(static_cast<std::size_t>(m.tiles_x) * m.tiles_y, cv::Rect());
  m.tile_maps_none.assign(m.tile_reads.size(), 0);
  for (int ty = 0; ty < m.tiles_y; ++ty) {
    for (int tx = 0; tx < m.tiles_x; ++tx) {
      float x0 = 1e30f, x1 = -1e30f, y0 = 1e30f, y1 = -1e30f;
      for (int v = ty * m.tile_px; v < std::min(H, (ty + 1) * m.tile_px); ++v) {
        for (int u = tx * m.tile_px; u < std::min(W, (tx + 1) * m.tile_px); ++u) {
          const float x = m.map_x.at<float>(v, u), y = m.map_y.at<float>(v, u);
          if (x < 0 || y < 0) {  // -1: no lookup (only the border value)
            m.tile_maps_none[static_cast<std::size_t>(ty) * m.tiles_x + tx] = 1;
            continue;
          }
          x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
        }
      }
      if (x0 > x1) {
        m.tile_maps_none[static_cast<std::size_t>(ty) * m.tiles_x + tx] = 1;
        continue;
      }
      // Bicubic at x reads pixels floor(x) - 1 .. floor(x) + 2, x rounded to 1/32 px first: one more each side.
      const int a = static_cast<int>(std::floor(x0)) - kBicubicReachPx, b = static_cast<int>(std::floor(x1)) + kBicubicReachPx + 1;
      const int c = static_cast<int>(std::floor(y0)) - kBicubicReachPx, d = static_cast<int>(std::floor(y1)) + kBicubicReachPx + 1;
      m.tile_reads[static_cast<std::size_t>(ty) * m.tiles_x + tx] = cv::Rect(a, c, b - a + 1, d - c + 1);
    }
  }
  return m;
}

std::vector<cv::Rect> outputStripsReading(const DistortionMap& map, const cv::Rect& pinhole_rect) {
  std::vector<cv::Rect> strips;
  if (pinhole_rect.empty()) return strips;
  const int W = map.map_x.cols, H = map.map_x.rows;
  for (int ty = 0; ty < map.tiles_y; ++ty) {
    int tx0 = map.tiles_x, tx1 = -1;
    for (int tx = 0; tx < map.tiles_x; ++tx) {
      if ((map.tile_reads[static_cast<std::size_t>(ty) * map.tiles_x + tx] & pinhole_rect).empty()) continue;
      tx0 = std::min(tx0, tx), tx1 = tx;
    }
    if (tx1 < 0) continue;
    const int x0 = tx0 * map.tile_px, y0 = ty * map.tile_px;
    strips.emplace_back(x0, y0, std::min(W, (tx1 + 1) * map.tile_px) - x0, std::min(H, (ty + 1) * map.tile_px) - y0);
  }
  return strips;
}

namespace {
/// The grey level every lookup of output tile `t` reads, when they all read one: the tile's read rectangle
/// holds that level wherever it lies in `pinhole_rect`, and outside it (background there, also past the
/// image's edge) and for pixels mapping to -1 (the border value) only `background` is read. -1 otherwise.
int constantTileLevel(const DistortionMap& map, std::size_t t, const cv::Mat& pinhole_image, int background,
                      const cv::Rect& pinhole_rect) {
  const cv::Rect& reads = map.tile_reads[t];
  const cv::Rect r = reads & pinhole_rect;
  if (r.empty()) return background;
  const unsigned char c = pinhole_image.at<unsigned char>(r.y, r.x);
  if (c != background && (map.tile_maps_none[t] || r != reads)) return -1;
  const std::uint64_t cccc = 0x0101010101010101ull * c;
  for (int y = r.y; y < r.y + r.height; ++y) {
    const unsigned char* p = pinhole_image.ptr<unsigned char>(y) + r.x;
    std::uint64_t differ = 0, word = 0;
    if (r.width >= 8) {  // 8 bytes at a time, the last 8 overlapping
      for (int x = 0; x + 8 <= r.width; x += 8) std::memcpy(&word, p + x, 8), differ |= word ^ cccc;
      std::memcpy(&word, p + r.width - 8, 8), differ |= word ^ cccc;
    } else {
      for (int x = 0; x < r.width; ++x) differ |= static_cast<unsigned char>(p[x] ^ c);
    }
    if (differ) return -1;
  }
  return c;
}
}  // namespace

cv::Mat applyDistortion(const DistortionMap& map, const cv::Mat& pinhole_image, int background, const cv::Rect& pinhole_rect) {
  CV_Assert(pinhole_image.type() == CV_8UC1 && map.map_fixed.type() == CV_16SC2 && map.map_fraction.type() == CV_16UC1);
  cv::Mat out(map.map_x.size(), CV_8UC1, cv::Scalar(background));
  // A lookup whose 4 x 4 pixels all hold one grey level gives that level (bicubic weights sum to one in
  // OpenCV's fixed point): tiles whose lookups all do are filled; in the other tiles each pixel whose
  // lookup does is set, and the rest are gathered into rows of lookups for one cv::remap, whose results
  // are put back (each output pixel depends only on its own lookup: the same pixels).
  std::vector<cv::Rect> mixed;  // tiles whose lookups do not all read one level
  std::size_t mixed_area = 0;
  for (const cv::Rect& strip : outputStripsReading(map, pinhole_rect)) {
    const int ty = strip.y / map.tile_px;
    for (int x0 = strip.x; x0 < strip.x + strip.width; x0 += map.tile_px) {
      const cv::Rect tile(x0, strip.y, std::min(map.tile_px, strip.x + strip.width - x0), strip.height);
      const int level = constantTileLevel(map, static_cast<std::size_t>(ty) * map.tiles_x + x0 / map.tile_px, pinhole_image,
                                          background, pinhole_rect);
      if (level < 0) {
        if (!mixed.empty() && mixed.back().y == tile.y && mixed.back().br().x == tile.x) {
          mixed.back().width += tile.width;  // runs of neighbouring tiles: the maps are read along rows
        } else {
          mixed.push_back(tile);
        }
        mixed_area += static_cast<std::size_t>(tile.area());
      } else if (level != background) {
        out(tile).setTo(level);
      }
    }
  }
  // Each pixel of those: set when its 4 x 4 lookup pixels hold one level, else gathered (without branching
  // on the image: every pixel is written both ways, the gathered count grows only for the mixed ones).
  const std::size_t capacity = (mixed_area + kGatherRowPx - 1) / kGatherRowPx * kGatherRowPx;  // whole rows
  std::unique_ptr<unsigned[]> gathered(new unsigned[capacity]);  // output pixels, v * width + u
  std::unique_ptr<cv::Vec2s[]> fixed(new cv::Vec2s[capacity]);    // their lookups, as in map_fixed, map_fraction
  std::unique_ptr<unsigned short[]> fraction(new unsigned short[capacity]);
  std::size_t n = 0;
  // Lookups at (x, y) with x - 1 .. x + 2 (likewise y) inside pinhole_rect are checked for one grey level.
  const int check_x = pinhole_rect.x + 1, check_y = pinhole_rect.y + 1;
  const unsigned check_w = static_cast<unsigned>(std::max(0, pinhole_rect.width - 3));
  const unsigned check_h = static_cast<unsigned>(std::max(0, pinhole_rect.height - 3));
  const unsigned char* src = pinhole_image.data;
  const std::size_t step = pinhole_image.step[0];
  for (std::size_t first = 0, last = 0; first < mixed.size(); first = last) {  // the runs of one row of tiles
    while (last < mixed.size() && mixed[last].y == mixed[first].y) ++last;
    for (int v = mixed[first].y; v < mixed[first].y + mixed[first].height; ++v) {
      const cv::Vec2s* xy = map.map_fixed.ptr<cv::Vec2s>(v);
      const unsigned short* a = map.map_fraction.ptr<unsigned short>(v);
      unsigned char* o = out.ptr<unsigned char>(v);
      const unsigned out_row = static_cast<unsigned>(v) * static_cast<unsigned>(out.cols);
      int row_y = -1;  // the lookup row whose pointer `row` holds
      const unsigned char* row = nullptr;
      for (std::size_t k = first; k < last; ++k) {
        for (int u = mixed[k].x; u < mixed[k].x + mixed[k].width; ++u) {
          const int x = xy[u][0], y = xy[u][1];
          bool uniform = false;
          if (static_cast<unsigned>(x - check_x) < check_w && static_cast<unsigned>(y - check_y) < check_h) {
            if (y != row_y) row_y = y, row = src + (y - 1) * step;  // y changes every few pixels at most
            const unsigned char* p = row + (x - 1);
            std::uint32_t r0, r1, r2, r3;
            std::memcpy(&r0, p, 4), std::memcpy(&r1, p + step, 4), std::memcpy(&r2, p + 2 * step, 4), std::memcpy(&r3, p + 3 * step, 4);
            // One level: the rows equal and r0's bytes equal (r0 equals itself rotated by a byte).
            uniform = ((r0 ^ r1) | (r0 ^ r2) | (r0 ^ r3) | (r0 ^ ((r0 >> 8) | (r0 << 24)))) == 0;
            o[u] = static_cast<unsigned char>(r0);
          }
          gathered[n] = out_row + static_cast<unsigned>(u);
          fixed[n] = xy[u];
          fraction[n] = a[u];
          n += uniform ? 0 : 1;
        }
      }
    }
  }
  if (n == 0) return out;
  // cv::remap takes images under 32767 px a side: rows of kGatherRowPx lookups, the last one padded with
  // lookups outside the image (never put back).
  const std::size_t rows = (n + kGatherRowPx - 1) / kGatherRowPx;
  std::fill(fixed.get() + n, fixed.get() + rows * kGatherRowPx, cv::Vec2s(-8, -8));
  std::fill(fraction.get() + n, fraction.get() + rows * kGatherRowPx, 0);
  cv::Mat values;
  cv::remap(pinhole_image, values, cv::Mat(static_cast<int>(rows), kGatherRowPx, CV_16SC2, fixed.get()),
            cv::Mat(static_cast<int>(rows), kGatherRowPx, CV_16UC1, fraction.get()), cv::INTER_CUBIC, cv::BORDER_CONSTANT,
            cv::Scalar::all(background));
  const unsigned char* val = values.ptr<unsigned char>(0);  // continuous
  unsigned char* o = out.ptr<unsigned char>(0);               // continuous
  for (std::size_t i = 0; i < n; ++i) o[gathered[i]] = val[i];
  return out;
}

cv::Mat applyDistortion(const DistortionMap& map, const cv::Mat& pinhole_image, double background) {
  cv::Mat out;
  cv::remap(pinhole_image, out, map.map_fixed, map.map_fraction, cv::INTER_CUBIC, cv::BORDER_CONSTANT,
            cv::Scalar::all(background));
  return out;
}

}  // namespace orbcal::render
