// Edge spread profiles and the tone curve (image_stats.hpp).
#include <algorithm>
#include <array>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "orbcal/vision/image_stats.hpp"

namespace orbcal::vision {

namespace {

constexpr double kBinPx = 0.25;       // edge spread profile bins (a quarter pixel: the slanted-edge method's)
constexpr double kMaxHalfBandPx = 6;  // profiles reach this far from the edge at most
constexpr double kMinHalfBandPx = 3;  // and at least this far (else the edge is not used)
constexpr double kPlateauPx = 1.5;    // the outermost 1.5 px of each side give its level

double median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

struct Profile {
  double width = 0.0, overshoot = 0.0, undershoot = 0.0;
  bool ok = false;
};

/// Width, overshoot and undershoot of a binned profile normalised to 0 (black plateau) .. 1 (white),
/// bins from -h to h (index 0 at -h).
Profile readProfile(const std::vector<double>& e) {
  Profile p;
  const int n = static_cast<int>(e.size());
  // the 50 % crossing nearest the middle
  int mid = -1;
  for (int k = 0; k + 1 < n; ++k) {
    if ((e[k] - 0.5) * (e[k + 1] - 0.5) <= 0.0 && (mid < 0 || std::abs(k - n / 2) < std::abs(mid - n / 2))) mid = k;
  }
  if (mid < 0) return p;
  const auto crossing = [&](double level, int from, int dir) {
    for (int k = from; k + dir >= 0 && k + dir < n; k += dir) {
      const double a = e[k], b = e[k + dir];
      if ((a - level) * (b - level) <= 0.0 && a != b) return (k + dir * (level - a) / (b - a)) * kBinPx;
    }
    return std::numeric_limits<double>::quiet_NaN();
  };
  const double lo = crossing(0.1, mid, -1), hi = crossing(0.9, mid + 1, 1);
  if (!std::isfinite(lo) || !std::isfinite(hi)) return p;
  p.width = hi - lo;
  double top = -1e9, bottom = 1e9;
  for (int k = 1; k + 1 < n; ++k) {  // three-bin means: one noisy bin does not make an overshoot
    const double s = (e[k - 1] + e[k] + e[k + 1]) / 3.0;
    if (k > mid) top = std::max(top, s);
    if (k <= mid) bottom = std::min(bottom, s);
  }
  p.overshoot = std::max(0.0, top - 1.0);
  p.undershoot = std::max(0.0, -bottom);
  p.ok = true;
  return p;
}

/// The profile across the edge from board point a to b (a segment between two inner corners), white on
/// the side of `to_white` (a unit board vector).
Profile edgeProfile(const sim::Camera& camera, const sim::Board& board, const BoardImage& view, const Eigen::Vector3d& a,
                    const Eigen::Vector3d& b, const Eigen::Vector3d& to_white) {
  const Eigen::Isometry3d& T = view.camera_T_board;
  if ((T * a).z() <= 0.0 || (T * b).z() <= 0.0) return {};
  const Eigen::Vector2d A = projectBoardPoint(camera, T, a + 0.25 * (b - a)), B = projectBoardPoint(camera, T, a + 0.75 * (b - a));
  const Eigen::Vector3d mid = 0.5 * (a + b);
  const double margin_m = board.type == sim::BoardType::kCharuco ? 0.5 * (board.square_m - board.marker_m) : 0.5 * board.square_m;
  const Eigen::Vector2d M = projectBoardPoint(camera, T, mid), W = projectBoardPoint(camera, T, mid + margin_m * to_white);
  const double margin_px = (W - M).norm();
  const double h = std::min(kMaxHalfBandPx, margin_px - 2.0);
  const double length = (B - A).norm();
  if (h < kMinHalfBandPx || length < 4.0) return {};
  const Eigen::Vector2d t = (B - A) / length;
  Eigen::Vector2d nrm(-t.y(), t.x());
  if (nrm.dot(W - M) < 0.0) nrm = -nrm;
  const int bins = static_cast<int>(std::floor(2.0 * h / kBinPx));
  std::vector<double> sum(bins, 0.0);
  std::vector<int> count(bins, 0);
  const int u0 = static_cast<int>(std::floor(std::min(A.x(), B.x()) - h)), u1 = static_cast<int>(std::ceil(std::max(A.x(), B.x()) + h));
  const int v0 = static_cast<int>(std::floor(std::min(A.y(), B.y()) - h)), v1 = static_cast<int>(std::ceil(std::max(A.y(), B.y()) + h));
  if (u0 < 0 || v0 < 0 || u1 >= view.gray.cols || v1 >= view.gray.rows) return {};
  for (int v = v0; v <= v1; ++v) {
    for (int u = u0; u <= u1; ++u) {
      const Eigen::Vector2d p = Eigen::Vector2d(u, v) - A;
      const double along = p.dot(t), d = p.dot(nrm);
      if (along < 0.0 || along > length || d <= -h || d >= h) continue;
      if (!view.ignored.empty() && view.ignored.at<uchar>(v, u)) return {};  // drawn over: not this edge
      const int k = std::min(bins - 1, static_cast<int>((d + h) / kBinPx));
      sum[k] += view.gray.at<uchar>(v, u);
      ++count[k];
    }
  }
  // fill empty bins linearly; at least half of them must hold pixels
  std::vector<double> esf(bins, std::numeric_limits<double>::quiet_NaN());
  int filled = 0;
  for (int k = 0; k < bins; ++k) {
    if (count[k] > 0) {
      esf[k] = sum[k] / count[k];
      ++filled;
    }
  }
  if (2 * filled < bins || count[0] == 0 || count[bins - 1] == 0) return {};
  for (int k = 1; k < bins; ++k) {
    if (std::isfinite(esf[k])) continue;
    int next = k + 1;
    while (!std::isfinite(esf[next])) ++next;
    esf[k] = esf[k - 1] + (esf[next] - esf[k - 1]) / (next - k + 1);
  }
  const int plateau = std::max(1, static_cast<int>(kPlateauPx / kBinPx));
  const double black = median(std::vector<double>(esf.begin(), esf.begin() + plateau));
  const double white = median(std::vector<double>(esf.end() - plateau, esf.end()));
  constexpr double kMinStepDn = 20.0;  // a step this small is not a black-white edge
  if (white - black < kMinStepDn) return {};
  for (double& x : esf) x = (x - black) / (white - black);
  return readProfile(esf);
}

}  // namespace

EdgeStats edgeStats(const sim::Camera& camera, const sim::Board& board, const BoardImage& view) {
  if (view.gray.empty() || view.gray.type() != CV_8UC1) throw std::invalid_argument("edgeStats: expected a CV_8UC1 image");
  std::vector<double> widths, overs, unders;
  const double s = board.square_m;
  for (int iy = 0; iy < board.corners_y; ++iy) {
    for (int ix = 0; ix < board.corners_x; ++ix) {
      const Eigen::Vector3d a = sim::cornerInBoard(board, iy * board.corners_x + ix);
      // along x to the next corner: squares (ix + 1, iy) below in y and (ix + 1, iy + 1) above
      if (ix + 1 < board.corners_x) {
        const double dir = sim::isBlackSquare(ix + 1, iy + 1) ? -1.0 : 1.0;
        const Profile p = edgeProfile(camera, board, view, a, a + Eigen::Vector3d(s, 0, 0), Eigen::Vector3d(0, dir, 0));
        if (p.ok) {
          widths.push_back(p.width);
          overs.push_back(p.overshoot);
          unders.push_back(p.undershoot);
        }
      }
      if (iy + 1 < board.corners_y) {
        const double dir = sim::isBlackSquare(ix + 1, iy + 1) ? -1.0 : 1.0;
        const Profile p = edgeProfile(camera, board, view, a, a + Eigen::Vector3d(0, s, 0), Eigen::Vector3d(dir, 0, 0));
        if (p.ok) {
          widths.push_back(p.width);
          overs.push_back(p.overshoot);
          unders.push_back(p.undershoot);
        }
      }
    }
  }
  EdgeStats out;
  out.edges = static_cast<int>(widths.size());
  if (widths.empty()) return out;
  out.width_px = median(widths);
  out.overshoot = median(overs);
  out.undershoot = median(unders);
  return out;
}

ToneFit fitToneCurve(const std::vector<Eigen::Vector2d>& in_out, double max_white) {
  ToneFit best;
  if (in_out.size() < 3) return best;
  // the inputs are 8-bit levels: per level its count and the sums of out and out^2 give every sum below
  std::array<double, 256> n{}, sy{}, syy{};
  for (const auto& p : in_out) {
    const int level = static_cast<int>(std::lround(std::clamp(p.x(), 0.0, 255.0)));
    n[level] += 1.0;
    sy[level] += p.y();
    syy[level] += p.y() * p.y();
  }
  const auto linear = [&](double gamma, ToneFit* fit) {
    double N = 0, Sx = 0, Sy = 0, Sxx = 0, Sxy = 0, Syy = 0;
    for (int level = 0; level < 256; ++level) {
      if (n[level] == 0.0) continue;
      const double x = std::pow(level / 255.0, 1.0 / gamma);
      N += n[level];
      Sx += n[level] * x;
      Sxx += n[level] * x * x;
      Sy += sy[level];
      Sxy += x * sy[level];
      Syy += syy[level];
    }
    const double det = N * Sxx - Sx * Sx;
    if (det <= 1e-12 * N * N) return std::numeric_limits<double>::infinity();
    double slope = (N * Sxy - Sx * Sy) / det, icpt = (Sy - slope * Sx) / N;
    if (icpt + slope > max_white) {  // white held at its bound: y = b (1 - x) + max_white x, b by least squares
      const double S1 = N - 2 * Sx + Sxx, Sy1 = Sy - Sxy, Sx1 = Sx - Sxx;  // sums of (1-x)^2, y (1-x), x (1-x)
      icpt = S1 > 0 ? (Sy1 - max_white * Sx1) / S1 : 0.0;
      slope = max_white - icpt;
    }
    const double sse = Syy - 2 * icpt * Sy - 2 * slope * Sxy + N * icpt * icpt + 2 * icpt * slope * Sx + slope * slope * Sxx;
    if (fit) *fit = {icpt, icpt + slope, gamma, std::sqrt(std::max(0.0, sse) / N)};
    return sse;
  };
  // a log grid over [0.25, 5], then golden-section search around its best point
  constexpr int kGrid = 40;
  double best_lg = 0.0, best_sse = std::numeric_limits<double>::infinity();
  const double lg0 = std::log(0.25), lg1 = std::log(5.0);
  for (int k = 0; k <= kGrid; ++k) {
    const double lg = lg0 + (lg1 - lg0) * k / kGrid, sse = linear(std::exp(lg), nullptr);
    if (sse < best_sse) {
      best_sse = sse;
      best_lg = lg;
    }
  }
  double lo = best_lg - (lg1 - lg0) / kGrid, hi = best_lg + (lg1 - lg0) / kGrid;
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  for (int it = 0; it < 40; ++it) {
    const double x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo);
    if (linear(std::exp(x1), nullptr) < linear(std::exp(x2), nullptr)) {
      hi = x2;
    } else {
      lo = x1;
    }
  }
  linear(std::exp(0.5 * (lo + hi)), &best);
  return best;
}

std::vector<Eigen::Vector2d> tonePairs(const sim::Camera& camera, const sim::Board& board, const BoardImage& real, const cv::Mat& rendered,
                                       int step) {
  if (rendered.size() != real.gray.size() || rendered.type() != CV_8UC1 || real.gray.type() != CV_8UC1) {
    throw std::invalid_argument("tonePairs: expected a real and a rendered CV_8UC1 image of one size");
  }
  cv::Mat inside = cv::Mat::zeros(real.gray.size(), CV_8UC1);
  std::vector<cv::Point> poly;
  for (const Eigen::Vector3d& p : sim::squaresOutline(board)) {
    if ((real.camera_T_board * p).z() <= 0.0) return {};
    const Eigen::Vector2d px = projectBoardPoint(camera, real.camera_T_board, p);
    poly.emplace_back(static_cast<int>(std::lround(px.x())), static_cast<int>(std::lround(px.y())));
  }
  std::vector<cv::Point> hull;
  cv::convexHull(poly, hull);
  cv::fillConvexPoly(inside, hull, cv::Scalar(255));
  std::vector<Eigen::Vector2d> out;
  for (int v = 0; v < inside.rows; v += step) {
    for (int u = 0; u < inside.cols; u += step) {
      if (!inside.at<uchar>(v, u) || (!real.ignored.empty() && real.ignored.at<uchar>(v, u))) continue;
      out.emplace_back(rendered.at<uchar>(v, u), real.gray.at<uchar>(v, u));
    }
  }
  return out;
}

}  // namespace orbcal::vision
