#include "orbcal/vision/image_stats.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace orbcal::vision {

namespace {

void checkView(const BoardImage& view, const char* who) {
  if (view.gray.empty() || view.gray.type() != CV_8UC1) throw std::invalid_argument(std::string(who) + ": expected a CV_8UC1 image");
  if (!view.ignored.empty() && (view.ignored.type() != CV_8UC1 || view.ignored.size() != view.gray.size())) {
    throw std::invalid_argument(std::string(who) + ": expected an ignored mask of the image's size (CV_8UC1)");
  }
}

double median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

/// The ignored mask grown by 2 px (a sample's neighbours stay clear of it); zeros where none.
cv::Mat grownIgnored(const BoardImage& view) {
  if (view.ignored.empty()) return cv::Mat::zeros(view.gray.size(), CV_8UC1);
  cv::Mat grown;
  cv::dilate(view.ignored, grown, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(5, 5)));
  return grown;
}

/// Pixels per metre of the board near square (i, j): the shortest projected side over the side.
double squareScale(const sim::Camera& camera, const sim::Board& board, const Eigen::Isometry3d& T, int i, int j) {
  const double s = board.square_m;
  const Eigen::Vector3d c[4] = {{(i - 1) * s, (j - 1) * s, 0}, {i * s, (j - 1) * s, 0}, {i * s, j * s, 0}, {(i - 1) * s, j * s, 0}};
  double shortest = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 4; ++k) {
    shortest = std::min(shortest, (projectBoardPoint(camera, T, c[k]) - projectBoardPoint(camera, T, c[(k + 1) % 4])).norm());
  }
  return shortest / s;
}

/// Whether board point (x, y) of square (i, j) lies at least `inset` (m) inside its flat part: the black
/// square, the white square's ring around its marker (ChArUco) or the whole white square (chessboard).
bool insideFlat(const sim::Board& board, int i, int j, double x, double y, double inset) {
  const double s = board.square_m;
  const double x0 = (i - 1) * s, y0 = (j - 1) * s;
  const double dx = std::min(x - x0, x0 + s - x), dy = std::min(y - y0, y0 + s - y);
  if (std::min(dx, dy) < inset) return false;
  if (sim::isBlackSquare(i, j) || board.type != sim::BoardType::kCharuco) return true;
  const double ring = 0.5 * (s - board.marker_m);  // the marker's margin in its square
  return std::min(dx, dy) <= ring - inset;
}

}  // namespace

Estimate meanOverViews(const std::vector<double>& per_view) {
  std::vector<double> v;
  for (double x : per_view) {
    if (std::isfinite(x)) v.push_back(x);
  }
  Estimate e;
  e.n = static_cast<int>(v.size());
  if (v.empty()) return e;
  double mean = 0.0;
  for (double x : v) mean += x;
  mean /= static_cast<double>(v.size());
  double ss = 0.0;
  for (double x : v) ss += (x - mean) * (x - mean);
  e.value = mean;
  e.sigma = v.size() > 1 ? std::sqrt(ss / static_cast<double>(v.size() - 1) / static_cast<double>(v.size())) : 0.0;
  return e;
}

bool differsSignificantly(const Estimate& a, const Estimate& b) {
  if (!a.valid() || !b.valid()) return false;
  return std::abs(a.value - b.value) > 2.0 * std::hypot(a.sigma, b.sigma);
}

double normalizedRadius(const sim::Camera& camera, const Eigen::Vector2d& px) {
  const double half_diagonal = 0.5 * std::hypot(camera.width_px, camera.height_px);
  return std::hypot(px.x() - camera.cx_px, px.y() - camera.cy_px) / half_diagonal;
}

Eigen::Vector2d projectBoardPoint(const sim::Camera& camera, const Eigen::Isometry3d& camera_T_board, const Eigen::Vector3d& p_board) {
  return sim::project(camera, camera_T_board * p_board);
}

std::map<int, Eigen::Vector2d> cornerResiduals(const sim::Camera& camera, const sim::Board& board, const BoardImage& view) {
  if (view.ids.size() != view.corners_px.size()) throw std::invalid_argument("cornerResiduals: one id per corner expected");
  std::map<int, Eigen::Vector2d> out;
  for (std::size_t n = 0; n < view.ids.size(); ++n) {
    out[view.ids[n]] = view.corners_px[n] - projectBoardPoint(camera, view.camera_T_board, sim::cornerInBoard(board, view.ids[n]));
  }
  return out;
}

double cornerScatterPx(const std::map<int, Eigen::Vector2d>& residuals) {
  if (residuals.empty()) return std::numeric_limits<double>::quiet_NaN();
  double ss = 0.0;
  for (const auto& [id, r] : residuals) ss += r.squaredNorm();
  return std::sqrt(ss / static_cast<double>(residuals.size()));
}

RepeatablePart repeatableCornerPart(const std::vector<std::map<int, Eigen::Vector2d>>& residuals_per_view) {
  constexpr std::size_t kMinViews = 3;
  std::map<int, std::vector<Eigen::Vector2d>> by_id;
  for (const auto& view : residuals_per_view) {
    for (const auto& [id, r] : view) by_id[id].push_back(r);
  }
  RepeatablePart out;
  double total = 0.0, repeating = 0.0;
  for (const auto& [id, rs] : by_id) {
    if (rs.size() < kMinViews) continue;
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const auto& r : rs) mean += r;
    const double n = static_cast<double>(rs.size());
    mean /= n;
    double spread = 0.0;
    for (const auto& r : rs) {
      spread += (r - mean).squaredNorm();
      total += r.squaredNorm();
    }
    repeating += n * std::max(0.0, mean.squaredNorm() - spread / (n - 1.0) / n);
    out.mean_px[id] = mean;
  }
  out.share = total > 0.0 ? repeating / total : 0.0;
  return out;
}

Eigen::Vector2d boardPlaneShift(const sim::Camera& camera, const sim::Board& board, const Eigen::Isometry3d& camera_T_board, int id,
                                const Eigen::Vector2d& residual_px) {
  constexpr double kStep = 1e-5;  // m: central differences of a projection that is smooth over millimetres
  const Eigen::Vector3d p = sim::cornerInBoard(board, id);
  Eigen::Matrix2d J;
  for (int c = 0; c < 2; ++c) {
    Eigen::Vector3d d = Eigen::Vector3d::Zero();
    d[c] = kStep;
    J.col(c) = (projectBoardPoint(camera, camera_T_board, p + d) - projectBoardPoint(camera, camera_T_board, p - d)) / (2 * kStep);
  }
  return J.fullPivLu().solve(residual_px);
}

std::vector<FlatSample> flatSamples(const sim::Camera& camera, const sim::Board& board, const BoardImage& view) {
  checkView(view, "flatSamples");
  const cv::Mat ignored = grownIgnored(view);
  cv::Mat taken = cv::Mat::zeros(view.gray.size(), CV_8UC1);
  std::vector<FlatSample> out;
  const double s = board.square_m;
  for (int i = 0; i <= board.corners_x; ++i) {
    for (int j = 0; j <= board.corners_y; ++j) {
      const double scale = squareScale(camera, board, view.camera_T_board, i, j);
      if (!(scale > 0.0)) continue;
      const double inset = kFlatInsetPx / scale, step = 0.7 / scale;
      for (double x = (i - 1) * s + inset; x <= i * s - inset; x += step) {
        for (double y = (j - 1) * s + inset; y <= j * s - inset; y += step) {
          if (!insideFlat(board, i, j, x, y, inset)) continue;
          const Eigen::Vector3d p_cam = view.camera_T_board * Eigen::Vector3d(x, y, 0.0);
          if (p_cam.z() <= 0.0) continue;
          const Eigen::Vector2d px = sim::project(camera, p_cam);
          const int u = static_cast<int>(std::lround(px.x())), v = static_cast<int>(std::lround(px.y()));
          if (u < 1 || v < 1 || u >= view.gray.cols - 1 || v >= view.gray.rows - 1) continue;
          if (ignored.at<uchar>(v, u) || taken.at<uchar>(v, u)) continue;
          taken.at<uchar>(v, u) = 1;
          FlatSample f;
          f.u = u;
          f.v = v;
          const auto at = [&](int uu, int vv) { return static_cast<double>(view.gray.at<uchar>(vv, uu)); };
          f.value = at(u, v);
          f.detail = f.value - 0.25 * (at(u - 1, v) + at(u + 1, v) + at(u, v - 1) + at(u, v + 1));
          f.r = normalizedRadius(camera, Eigen::Vector2d(u, v));
          f.white = !sim::isBlackSquare(i, j);
          out.push_back(f);
        }
      }
    }
  }
  return out;
}

Levels blackWhiteLevels(const std::vector<FlatSample>& samples) {
  std::vector<double> black, white;
  for (const FlatSample& f : samples) (f.white ? white : black).push_back(f.value);
  return {median(black), median(white)};
}

NoiseLevels noiseLevels(const std::vector<FlatSample>& samples) {
  constexpr double kDetailVariance = 1.25;  // var(x0 - mean of 4 independent neighbours) / var(x)
  constexpr double kKept = 0.99;            // the largest 1 % of |detail| left out (specks, dust)
  NoiseLevels out;
  for (const bool white : {false, true}) {
    std::vector<double> d;
    double level = 0.0;
    for (const FlatSample& f : samples) {
      if (f.white != white) continue;
      d.push_back(f.detail);
      level += f.value;
    }
    if (d.size() < 20) continue;
    level /= static_cast<double>(d.size());
    std::sort(d.begin(), d.end(), [](double a, double b) { return std::abs(a) < std::abs(b); });
    d.resize(static_cast<std::size_t>(kKept * static_cast<double>(d.size())));
    double mean = 0.0, ss = 0.0;
    for (double x : d) mean += x;
    mean /= static_cast<double>(d.size());
    for (double x : d) ss += (x - mean) * (x - mean);
    const double sd = std::sqrt(ss / static_cast<double>(d.size() - 1) / kDetailVariance);
    (white ? out.white_sd : out.black_sd) = sd;
    (white ? out.white_level : out.black_level) = level;
  }
  return out;
}

PoissonGaussian fitPoissonGaussian(const std::vector<NoiseLevels>& views) {
  std::vector<Eigen::Vector2d> pts;  // (level, variance)
  for (const NoiseLevels& n : views) {
    if (std::isfinite(n.black_sd)) pts.emplace_back(n.black_level, n.black_sd * n.black_sd);
    if (std::isfinite(n.white_sd)) pts.emplace_back(n.white_level, n.white_sd * n.white_sd);
  }
  PoissonGaussian pg;
  if (pts.empty()) return pg;
  Eigen::Matrix2d A = Eigen::Matrix2d::Zero();
  Eigen::Vector2d rhs = Eigen::Vector2d::Zero();
  double sum_l2 = 0.0, sum_lv = 0.0, sum_v = 0.0;
  for (const auto& p : pts) {
    const Eigen::Vector2d row(p.x(), 1.0);
    A += row * row.transpose();
    rhs += row * p.y();
    sum_l2 += p.x() * p.x();
    sum_lv += p.x() * p.y();
    sum_v += p.y();
  }
  const Eigen::Vector2d ab = A.fullPivLu().isInvertible() ? Eigen::Vector2d(A.fullPivLu().solve(rhs)) : Eigen::Vector2d(-1.0, 0.0);
  if (ab.x() >= 0.0 && ab.y() >= 0.0) return {ab.x(), ab.y()};
  if (ab.x() < 0.0 || sum_l2 <= 0.0) return {0.0, sum_v / static_cast<double>(pts.size())};
  return {sum_lv / sum_l2, 0.0};
}

Falloff radialFalloff(const std::vector<std::vector<FlatSample>>& samples) {
  // Per view the gain drops out by centring log value and r^2 on the view's means; each view adds its sums
  // to the normal equation, so the jackknife subtracts one view's.
  std::vector<double> sxx, sxy;
  for (const auto& view : samples) {
    double n = 0, mx = 0, my = 0;
    for (const FlatSample& f : view) {
      if (!f.white || f.value < 1.0) continue;
      n += 1;
      mx += f.r * f.r;
      my += std::log(f.value);
    }
    if (n < 20) continue;
    mx /= n;
    my /= n;
    double xx = 0, xy = 0;
    for (const FlatSample& f : view) {
      if (!f.white || f.value < 1.0) continue;
      xx += (f.r * f.r - mx) * (f.r * f.r - mx);
      xy += (f.r * f.r - mx) * (std::log(f.value) - my);
    }
    sxx.push_back(xx);
    sxy.push_back(xy);
  }
  Falloff out;
  double tx = 0, ty = 0;
  for (std::size_t k = 0; k < sxx.size(); ++k) {
    tx += sxx[k];
    ty += sxy[k];
  }
  if (!(tx > 0.0)) return out;
  const auto atHalf = [](double c2) { return std::exp(c2 / 4.0) - 1.0; };
  out.c2 = ty / tx;
  out.at_half.value = atHalf(out.c2);
  out.at_half.n = static_cast<int>(sxx.size());
  std::vector<double> jack;
  for (std::size_t k = 0; k < sxx.size() && sxx.size() > 2; ++k) {
    if (tx - sxx[k] > 0.0) jack.push_back(atHalf((ty - sxy[k]) / (tx - sxx[k])));
  }
  double mean = 0.0, ss = 0.0;
  for (double x : jack) mean += x;
  if (!jack.empty()) mean /= static_cast<double>(jack.size());
  for (double x : jack) ss += (x - mean) * (x - mean);
  const double n = static_cast<double>(jack.size());
  out.at_half.sigma = jack.empty() ? 0.0 : std::sqrt((n - 1.0) / n * ss);
  return out;
}

cv::Mat boardHullMask(const sim::Camera& camera, const sim::Board& board, const Eigen::Isometry3d& camera_T_board, double grow_m) {
  // Each side sampled densely: a lens's distortion curves the sides. Beyond the image's own radius (1.2 times
  // its corners', normalised) the distortion polynomial is not the lens's and may fold back into the image:
  // there the pinhole projection stands in (those points lie outside the image either way).
  constexpr int kPerSide = 24;
  constexpr double kTrusted = 1.2;
  cv::Mat mask = cv::Mat::zeros(camera.height_px, camera.width_px, CV_8UC1);
  const std::array<Eigen::Vector3d, 4> outline = sim::boardOutline(board);
  const Eigen::Vector3d centre = sim::boardCentre(board);
  double image_radius = 0.0;
  for (const double u : {0.0, static_cast<double>(camera.width_px)}) {
    for (const double v : {0.0, static_cast<double>(camera.height_px)}) {
      image_radius = std::max(image_radius, std::hypot((u - camera.cx_px) / camera.fx_px, (v - camera.cy_px) / camera.fy_px));
    }
  }
  std::array<Eigen::Vector3d, 4> grown;
  for (int k = 0; k < 4; ++k) {
    grown[k] = outline[k];
    grown[k].x() += (outline[k].x() > centre.x() ? 1.0 : -1.0) * grow_m;
    grown[k].y() += (outline[k].y() > centre.y() ? 1.0 : -1.0) * grow_m;
  }
  std::vector<cv::Point> poly;
  for (int k = 0; k < 4; ++k) {
    for (int i = 0; i < kPerSide; ++i) {
      const Eigen::Vector3d p_cam = camera_T_board * (grown[k] + (grown[(k + 1) % 4] - grown[k]) * (static_cast<double>(i) / kPerSide));
      if (p_cam.z() <= 0.0) return cv::Mat(mask.size(), CV_8UC1, cv::Scalar(255));  // the hull reaches behind: all board
      const Eigen::Vector2d xy = p_cam.head<2>() / p_cam.z();
      sim::Camera pinhole = camera;
      if (xy.norm() > kTrusted * image_radius) pinhole.distortion = {0.0, 0.0, 0.0, 0.0, 0.0};
      const Eigen::Vector2d px = sim::project(pinhole, p_cam);
      poly.emplace_back(static_cast<int>(std::lround(std::clamp(px.x(), -1e6, 1e6))), static_cast<int>(std::lround(std::clamp(px.y(), -1e6, 1e6))));
    }
  }
  cv::fillPoly(mask, std::vector<std::vector<cv::Point>>{poly}, cv::Scalar(255));
  return mask;
}

BackgroundStats backgroundStats(const sim::Camera& camera, const sim::Board& board, const BoardImage& view) {
  checkView(view, "backgroundStats");
  const cv::Mat hull = boardHullMask(camera, board, view.camera_T_board, board.square_m);
  double sum = 0.0, ss = 0.0;
  int n = 0;
  for (int v = 0; v < view.gray.rows; v += 2) {
    for (int u = 0; u < view.gray.cols; u += 2) {
      if (hull.at<uchar>(v, u) || (!view.ignored.empty() && view.ignored.at<uchar>(v, u))) continue;
      const double x = view.gray.at<uchar>(v, u);
      sum += x;
      ss += x * x;
      ++n;
    }
  }
  BackgroundStats out;
  out.pixels = n;
  if (n < 2) return out;
  out.mean = sum / n;
  out.sd = std::sqrt(std::max(0.0, (ss - sum * sum / n) / (n - 1)));
  return out;
}

}  // namespace orbcal::vision
