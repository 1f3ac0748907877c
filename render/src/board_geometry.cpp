// The board as the renderer draws it: its triangles (a chessboard's colours per cell) and a ChArUco
// board's marker texture.
#include <algorithm>
#include <cmath>
#include <opencv2/aruco.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "renderer_detail.hpp"

namespace orbcal::render::renderer_detail {

void pushVertex(std::vector<float>& v, const Eigen::Vector3d& p, const Eigen::Vector3d& n, double albedo,
                const Eigen::Vector2d& pattern) {
  v.insert(v.end(), {float(p.x()), float(p.y()), float(p.z()), float(n.x()), float(n.y()), float(n.z()), float(albedo),
                     float(pattern.x()), float(pattern.y())});
}

namespace {
/// `lines` with every interval split into ceil(length / step) equal parts (step <= 0: unchanged).
std::vector<double> subdivide(const std::vector<double>& lines, double step) {
  if (!(step > 0)) return lines;
  std::vector<double> out;
  for (std::size_t i = 0; i + 1 < lines.size(); ++i) {
    const int n = std::max(1, static_cast<int>(std::ceil((lines[i + 1] - lines[i]) / step - 1e-9)));
    for (int k = 0; k < n; ++k) out.push_back(lines[i] + (lines[i + 1] - lines[i]) * k / n);
  }
  out.push_back(lines.back());
  return out;
}
}  // namespace

std::vector<float> boardVertices(const sim::Board& b, const RenderOptions& o, const BoardPrint& print) {
  const double s = b.square_m, m = b.margin_m;
  const std::array<Eigen::Vector3d, 4> outline = sim::boardOutline(b);  // [0] lowest x and y, [2] highest
  const std::array<Eigen::Vector3d, 4> pattern = sim::squaresOutline(b);  // whole spacings from -s
  const int nx = static_cast<int>(std::lround((pattern[2].x() - pattern[0].x()) / s)), ny = static_cast<int>(std::lround((pattern[2].y() - pattern[0].y()) / s));
  std::vector<double> xs, ys;
  if (m > 0) xs.push_back(outline[0].x());
  for (int i = -1; i < nx; ++i) xs.push_back(i * s);
  if (m > 0) xs.push_back(outline[2].x());
  if (m > 0) ys.push_back(outline[0].y());
  for (int j = -1; j < ny; ++j) ys.push_back(j * s);
  if (m > 0) ys.push_back(outline[2].y());
  const double step = print.identity() ? 0.0 : s / kPrintSubdivisions;
  const std::vector<double> fx = subdivide(xs, step), fy = subdivide(ys, step);
  std::vector<float> v;
  for (std::size_t a = 0; a + 1 < fx.size(); ++a) {
    for (std::size_t c = 0; c + 1 < fy.size(); ++c) {
      // square (i, j) of the cell's centre; margin outside 0..corners
      const int i = static_cast<int>(std::floor(0.5 * (fx[a] + fx[a + 1]) / s)) + 1;
      const int j = static_cast<int>(std::floor(0.5 * (fy[c] + fy[c + 1]) / s)) + 1;
      const bool square = b.type != sim::BoardType::kCircles && i >= 0 && i <= b.corners_x && j >= 0 && j <= b.corners_y;  // circles: white
      const double albedo = (square && sim::isBlackSquare(i, j)) ? o.board_black : o.board_white;
      const Eigen::Vector2d q00(fx[a], fy[c]), q10(fx[a + 1], fy[c]), q11(fx[a + 1], fy[c + 1]), q01(fx[a], fy[c + 1]);
      for (const auto* q : {&q00, &q10, &q11, &q00, &q11, &q01}) {
        pushVertex(v, printedBoardPoint(b, print, *q), printedBoardNormal(b, print, *q), albedo, *q);
      }
    }
  }
  return v;
}

cv::Mat charucoMarkerImage(const sim::Board& b, int texels_per_square) {
  sim::ArucoDictionaryInfo info;
  if (!sim::arucoDictionary(b.dictionary, &info)) throw std::invalid_argument("render: unknown ArUco dictionary " + b.dictionary);
  const cv::Ptr<cv::aruco::Dictionary> dictionary =
      cv::aruco::getPredefinedDictionary(static_cast<cv::aruco::PREDEFINED_DICTIONARY_NAME>(info.cv_id));
  constexpr int kSuper = 4;
  const int S = kSuper * texels_per_square;  // fine pixels per square
  cv::Mat fine((b.corners_y + 1) * S, (b.corners_x + 1) * S, CV_8UC1, cv::Scalar(0));
  const int cells = info.bits + 2;  // the code's bits and a one-cell black border
  const double side = b.marker_m / b.square_m * S;
  for (const sim::CharucoMarker& m : sim::charucoMarkers(b)) {
    cv::Mat bits;
    cv::aruco::drawMarker(dictionary, m.id, cells, bits, 1);  // one pixel per cell, 0 = black
    const double x0 = (m.top_left.x() / b.square_m + 1.0) * S, y0 = (m.top_left.y() / b.square_m + 1.0) * S;
    for (int y = static_cast<int>(std::floor(y0)); y < static_cast<int>(std::ceil(y0 + side)); ++y) {
      const int v = static_cast<int>(std::floor((y + 0.5 - y0) / side * cells));
      if (v < 0 || v >= cells) continue;
      for (int x = static_cast<int>(std::floor(x0)); x < static_cast<int>(std::ceil(x0 + side)); ++x) {
        const int u = static_cast<int>(std::floor((x + 0.5 - x0) / side * cells));
        if (u < 0 || u >= cells) continue;
        if (bits.at<unsigned char>(v, u) == 0) fine.at<unsigned char>(y, x) = 255;
      }
    }
  }
  cv::Mat texture;
  cv::resize(fine, texture, cv::Size(fine.cols / kSuper, fine.rows / kSuper), 0, 0, cv::INTER_AREA);
  return texture;
}

}  // namespace orbcal::render::renderer_detail
