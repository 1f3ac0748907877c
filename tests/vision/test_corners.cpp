#include <catch2/catch.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "orbcal/vision/corners.hpp"
#include "orbcal/vision/pose.hpp"
#include "orbcal/vision/synthetic.hpp"
#include "vision_test_util.hpp"

using namespace orbcal;

namespace {
// Drawn boards are exact up to 4x supersampling and 8-bit quantisation: classic corners land within
// ~0.1 px of the projection; 0.5 px still tells the right corner from its neighbour (45-75 px away).
constexpr double kCornerTolPx = 0.5;
// The drawing's squares are grey 230 (white) and 25 (black): 205 levels of contrast, which is what
// the sampled square middles give (measured 205). Bars well below that, yet far above the detector's
// own threshold (DetectorSettings::min_orientation_contrast, 20), prove the colours were read, not
// merely a sign: 150 for orientationEvidence on the exact corners, 100 for what detectCorners reports
// (its corners, hence its sampled areas, carry the detection error).
constexpr double kMinDrawnContrast = 150.0;
constexpr double kMinDetectedContrast = 100.0;

bool insideImage(const sim::Camera& cam, const Eigen::Vector2d& uv, double margin_px) {
  return uv.x() >= margin_px - 0.5 && uv.y() >= margin_px - 0.5 && uv.x() <= cam.width_px - 0.5 - margin_px &&
         uv.y() <= cam.height_px - 0.5 - margin_px;
}

// Pixel of board point (x, y) (m) seen from camera_T_board.
Eigen::Vector2d pixelOf(const sim::Camera& cam, const Eigen::Isometry3d& camera_T_board, double x, double y) {
  return sim::project(cam, camera_T_board * Eigen::Vector3d(x, y, 0.0));
}

// Paints the middle of square (i, j) (all but a border of `inset` squares, larger than nothing and
// smaller than the detector's sampling inset 0.25) with `grey`: the corners stay untouched.
void paintSquareMiddle(cv::Mat& img, const sim::Camera& cam, const sim::Board& board, const Eigen::Isometry3d& T,
                       int i, int j, int grey) {
  constexpr double kInset = 0.15;
  const double s = board.square_m;
  const double x0 = (i - 1 + kInset) * s, x1 = (i - kInset) * s, y0 = (j - 1 + kInset) * s, y1 = (j - kInset) * s;
  std::vector<cv::Point> poly;
  for (const auto& [x, y] : {std::pair{x0, y0}, std::pair{x1, y0}, std::pair{x1, y1}, std::pair{x0, y1}}) {
    const Eigen::Vector2d uv = pixelOf(cam, T, x, y);
    poly.emplace_back(static_cast<int>(std::lround(uv.x())), static_cast<int>(std::lround(uv.y())));
  }
  cv::fillConvexPoly(img, poly, cv::Scalar(grey));
}

double maxCornerError(const std::vector<Eigen::Vector2d>& a, const std::vector<Eigen::Vector2d>& b) {
  REQUIRE(a.size() == b.size());
  double e = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k) e = std::max(e, (a[k] - b[k]).norm());
  return e;
}
}  // namespace

TEST_CASE("corners come out in board order for any camera roll", "[vision][corners]") {
  const sim::Scene& scene = test::defaultScene();
  for (const vision::Detector det : {vision::Detector::kClassic, vision::Detector::kSectorBased}) {
    for (double roll_deg : {0.0, 45.0, 95.0, 135.0, 180.0, -100.0, 270.0}) {
      CAPTURE(vision::toString(det), roll_deg);
      const Eigen::Isometry3d T = test::lookAtBoard(scene.board, 2.0, 0.2, -0.15, roll_deg * sim::kDegToRad);
      REQUIRE(sim::boardVisibility(scene, T) == sim::Visibility::kVisible);
      const cv::Mat img = vision::drawSyntheticBoard(scene.camera, scene.board, T);
      vision::DetectorSettings st;
      st.detector = det;
      const auto d = vision::detectCorners(img, scene.board, st);
      CAPTURE(d.reason, d.detail);
      REQUIRE(d.found());
      REQUIRE(d.orientation_known);
      CHECK(d.orientation_contrast > kMinDetectedContrast);
      CHECK(maxCornerError(d.corners_px, vision::projectBoard(scene.camera, scene.board, T)) < kCornerTolPx);
    }
  }
}

TEST_CASE("a half-turned image gives the half-turned corners, not a flipped order", "[vision][corners]") {
  const sim::Scene& scene = test::defaultScene();
  int reversed_count = 0;
  int n = 0;
  for (const Eigen::Isometry3d& T : test::randomViews(scene, 12, 7)) {
    const cv::Mat img = vision::drawSyntheticBoard(scene.camera, scene.board, T);
    cv::Mat turned;
    cv::rotate(img, turned, cv::ROTATE_180);
    vision::DetectorSettings st;
    st.detector = (n++ % 3 == 0) ? vision::Detector::kSectorBased : vision::Detector::kClassic;
    CAPTURE(vision::toString(st.detector));
    const auto a = vision::detectCorners(img, scene.board, st);
    const auto b = vision::detectCorners(turned, scene.board, st);
    REQUIRE(a.found());
    REQUIRE(b.found());
    reversed_count += a.reversed + b.reversed;
    std::vector<Eigen::Vector2d> mapped;
    for (const auto& p : a.corners_px) mapped.emplace_back(img.cols - 1 - p.x(), img.rows - 1 - p.y());
    CHECK(maxCornerError(b.corners_px, mapped) < kCornerTolPx);
    CHECK(maxCornerError(a.corners_px, vision::projectBoard(scene.camera, scene.board, T)) < kCornerTolPx);
  }
  // The detectors' own order did need fixing in some of these (SB starts from either end): the
  // orientation check is not vacuous here.
  CHECK(reversed_count > 0);
}

TEST_CASE("orientation evidence reads the colouring", "[vision][corners]") {
  const sim::Scene& scene = test::defaultScene();
  const Eigen::Isometry3d T = test::lookAtBoard(scene.board, 1.8, 0.1, 0.1, 0.3);
  const cv::Mat img = vision::drawSyntheticBoard(scene.camera, scene.board, T);
  auto corners = vision::projectBoard(scene.camera, scene.board, T);
  const auto good = vision::orientationEvidence(img, scene.board, corners);
  std::reverse(corners.begin(), corners.end());
  const auto bad = vision::orientationEvidence(img, scene.board, corners);
  CHECK(good.ends_sampled == 2);
  CHECK(good.consistent);
  CHECK(good.signed_contrast > kMinDrawnContrast);  // white 230 vs black 25 in the drawing
  CHECK(bad.signed_contrast < -kMinDrawnContrast);
  CHECK(bad.consistent);
  CHECK_THROWS_AS(vision::orientationEvidence(img, scene.board, {}), std::invalid_argument);
}

TEST_CASE("a half-turn-symmetric board is rejected unless orientation is optional", "[vision][corners]") {
  sim::Scene scene = test::defaultScene();
  scene.board.corners_x = 8;  // 9 x 7 squares: same after a half turn
  REQUIRE(vision::isHalfTurnSymmetric(scene.board));
  const Eigen::Isometry3d T = test::lookAtBoard(scene.board, 1.8, 0.1, 0.1, 0.0);
  const cv::Mat img = vision::drawSyntheticBoard(scene.camera, scene.board, T);
  const auto d = vision::detectCorners(img, scene.board);
  CHECK(d.status == vision::ImageStatus::kRejected);
  CHECK(d.reason == "orientation undecidable");
  vision::DetectorSettings st;
  st.require_orientation = false;
  const auto e = vision::detectCorners(img, scene.board, st);
  CHECK(e.found());
  CHECK_FALSE(e.orientation_known);
}

TEST_CASE("blank images and boards of the wrong size are not found, with a reason", "[vision][corners]") {
  const sim::Scene& scene = test::defaultScene();
  const cv::Mat black = cv::Mat::zeros(scene.camera.height_px, scene.camera.width_px, CV_8UC1);
  const auto a = vision::detectCorners(black, scene.board);
  CHECK(a.status == vision::ImageStatus::kNotFound);
  CHECK(a.reason == "blank image");

  sim::Board other = scene.board;
  other.corners_x = 7;
  other.corners_y = 4;
  const cv::Mat img = vision::drawSyntheticBoard(scene.camera, other, test::lookAtBoard(other, 1.8, 0.1, 0.0, 0.0));
  const auto b = vision::detectCorners(img, scene.board);
  CHECK(b.status == vision::ImageStatus::kNotFound);
  CHECK(b.reason == "no board found");
  CHECK(b.detail.find("9x6") != std::string::npos);
  // and the same image does hold a 7 x 4 board: the negative result is about the size only
  CHECK(vision::detectCorners(img, other).found());
}

TEST_CASE("detectCorners rejects caller bugs", "[vision][corners]") {
  const sim::Scene& scene = test::defaultScene();
  CHECK_THROWS_AS(vision::detectCorners(cv::Mat(), scene.board), std::invalid_argument);
  CHECK_THROWS_AS(vision::detectCorners(cv::Mat::zeros(10, 10, CV_8UC3), scene.board), std::invalid_argument);
  sim::Board tiny = scene.board;
  tiny.corners_y = 1;
  CHECK_THROWS_AS(vision::detectCorners(cv::Mat::zeros(10, 10, CV_8UC1), tiny), std::invalid_argument);
  CHECK(vision::parseDetector("sb") == vision::Detector::kSectorBased);
  CHECK_THROWS_AS(vision::parseDetector("fast"), std::invalid_argument);
  for (auto s : {vision::ImageStatus::kFound, vision::ImageStatus::kNotFound, vision::ImageStatus::kRejected,
                 vision::ImageStatus::kUnreadable}) {
    CHECK(vision::parseImageStatus(vision::toString(s)) == s);
  }
}

TEST_CASE("a close view whose outer squares leave the image is found, in board order", "[vision][corners]") {
  // Only the interior squares, each bounded by four detected corners, carry the orientation: the
  // outer squares beyond the end corners may be cut by the image border while every inner corner is
  // inside. Before, those outer squares were sampled and such views were rejected as undecidable.
  const sim::Scene& scene = test::defaultScene();
  const sim::Board& b = scene.board;
  const double s = b.square_m;
  constexpr double kCornerMarginPx = 15.0;  // every inner corner this far inside: the detector's windows fit
  // This test is about the order: a wrong one is off by at least a square (~150 px at this range).
  // SB's own corners on these 150 px squares are up to ~0.6 px off the projection (classic ~0.1 px);
  // 2 px covers that and is still 1/75 of a square.
  constexpr double kCloseCornerTolPx = 2.0;
  for (const vision::Detector det : {vision::Detector::kClassic, vision::Detector::kSectorBased}) {
    for (double roll_deg : {0.0, 180.0, 90.0, -90.0}) {  // rows across or along the image, either way up
      CAPTURE(vision::toString(det), roll_deg);
      // The nearest distance (1 cm steps) at which every inner corner is inside the image: ~0.8 m
      // unrolled, where the 0.64 m row of inner corners spans ~1120 of 1280 px and the outer squares
      // (0.08 m more on each side) cannot fit.
      const auto cornersInside = [&](const Eigen::Isometry3d& T) {
        for (const auto& p : vision::projectBoard(scene.camera, b, T)) {
          if (!insideImage(scene.camera, p, kCornerMarginPx)) return false;
        }
        return true;
      };
      double distance_m = 0.5;
      while (!cornersInside(test::lookAtBoard(b, distance_m, 0.0, 0.0, roll_deg * sim::kDegToRad))) distance_m += 0.01;
      CAPTURE(distance_m);
      const Eigen::Isometry3d T = test::lookAtBoard(b, distance_m, 0.0, 0.0, roll_deg * sim::kDegToRad);
      const auto truth = vision::projectBoard(scene.camera, b, T);
      // the old evidence's outer squares: (0, 0) beyond corner 0 and (corners_x, corners_y) beyond the last
      // corner, each sampled over its middle half, are not wholly inside the image at either end
      const auto middleInside = [&](int i, int j) {
        for (double fx : {0.25, 0.75}) {
          for (double fy : {0.25, 0.75}) {
            if (!insideImage(scene.camera, pixelOf(scene.camera, T, (i - 1 + fx) * s, (j - 1 + fy) * s), 0.0)) return false;
          }
        }
        return true;
      };
      REQUIRE_FALSE(middleInside(0, 0));
      REQUIRE_FALSE(middleInside(b.corners_x, b.corners_y));

      const cv::Mat img = vision::drawSyntheticBoard(scene.camera, b, T);
      vision::DetectorSettings st;
      st.detector = det;
      const auto d = vision::detectCorners(img, b, st);
      CAPTURE(d.reason, d.detail);
      REQUIRE(d.found());
      CHECK(d.orientation_known);
      CHECK(d.orientation_contrast > kMinDetectedContrast);
      CHECK(maxCornerError(d.corners_px, truth) < kCloseCornerTolPx);
    }
  }
}

TEST_CASE("ends whose colours disagree are rejected as inconsistent, not averaged", "[vision][corners]") {
  // A board whose colouring is wrong at the last end: the middles of the four interior squares next
  // to the last corner painted in the opposite colour. The corners are untouched, so the detector
  // still finds the board; the first end says "in order", the last end says "reversed".
  const sim::Scene& scene = test::defaultScene();
  const sim::Board& b = scene.board;
  const Eigen::Isometry3d T = test::lookAtBoard(b, 1.8, 0.1, 0.1, 0.3);
  const vision::SyntheticImageSettings draw;
  cv::Mat img = vision::drawSyntheticBoard(scene.camera, b, T, draw);
  for (int j = b.corners_y - 2; j <= b.corners_y - 1; ++j) {
    for (int i = b.corners_x - 2; i <= b.corners_x - 1; ++i) {
      paintSquareMiddle(img, scene.camera, b, T, i, j, sim::isBlackSquare(i, j) ? draw.white : draw.black);
    }
  }
  const auto truth = vision::projectBoard(scene.camera, b, T);
  const auto ev = vision::orientationEvidence(img, b, truth);
  REQUIRE(ev.ends_sampled == 2);
  CHECK(*ev.end_contrast[0] > kMinDrawnContrast);
  CHECK(*ev.end_contrast[1] < -kMinDrawnContrast);
  CHECK_FALSE(ev.consistent);

  for (const vision::Detector det : {vision::Detector::kClassic, vision::Detector::kSectorBased}) {
    CAPTURE(vision::toString(det));
    vision::DetectorSettings st;
    st.detector = det;
    const auto d = vision::detectCorners(img, b, st);
    CAPTURE(d.detail);
    CHECK(d.status == vision::ImageStatus::kRejected);
    CHECK(d.reason == "orientation evidence inconsistent");
    // optional orientation (intrinsics): kept, but not claimed to be known
    st.require_orientation = false;
    const auto e = vision::detectCorners(img, b, st);
    CHECK(e.found());
    CHECK_FALSE(e.orientation_known);
  }
  // the untouched board is consistent and found (the painting, not the view, is what fails)
  const auto clean = vision::detectCorners(vision::drawSyntheticBoard(scene.camera, b, T, draw), b);
  CHECK(clean.found());
}

TEST_CASE("intrinsics --subpix-window: OpenCV's fixed 11 px half window is used when asked, and said", "[vision][corners]") {
  const sim::Scene& scene = test::defaultScene();
  const Eigen::Isometry3d T = test::lookAtBoard(scene.board, 2.0, 0.2, -0.15, 0.3);
  vision::SyntheticImageSettings noisy;
  noisy.noise_sigma = 4.0;  // grey levels: the window then decides which noise the refinement averages
  noisy.seed = 5;
  const cv::Mat img = vision::drawSyntheticBoard(scene.camera, scene.board, T, noisy);
  vision::DetectorSettings orbcal_window, opencv_window;
  opencv_window.fixed_subpix_half_window_px = 11;
  const auto a = vision::detectCorners(img, scene.board, orbcal_window);
  const auto b = vision::detectCorners(img, scene.board, opencv_window);
  REQUIRE(a.found());
  REQUIRE(b.found());
  const std::vector<Eigen::Vector2d> truth = vision::projectBoard(scene.camera, scene.board, T);
  CHECK(maxCornerError(a.corners_px, truth) < kCornerTolPx);
  CHECK(maxCornerError(b.corners_px, truth) < kCornerTolPx);
  // A 5 px and an 11 px half window average different pixels: the corners differ (a window ignored
  // would give the same ones to the last bit).
  CHECK(maxCornerError(a.corners_px, b.corners_px) > 1e-3);
  CHECK(vision::subpixWindowText(orbcal_window).find("--subpix-window 11") != std::string::npos);
  CHECK(vision::subpixWindowText(opencv_window).find("half window 11 px") != std::string::npos);
}
