// Real images through `orbcal calibrate DESCRIPTION.yaml` (workflow::runMeasuredCalibrate): the two shared sets
// (../shared/data/doosan-a0509, eye in hand; ../shared/data/ic-charuco, eye to hand; never copied into the
// project) described by examples/real-images/*.yaml. The independent reference is OpenCV's own hand-eye solver
// (cv::calibrateHandEye, Park and Martin 1994) on the same detections: a different estimator (pose-level, closed
// form) from orbcal's corner-level fit. Each set is detected once (runOf); the subsets reuse its detections.
#include <Eigen/Core>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include <numeric>

#include "orbcal/calib/hand_eye.hpp"
#include "orbcal/sim/image_views.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/workflow/measured.hpp"
#include "orbcal/workflow/measured_images.hpp"
#include "test_util.hpp"

using namespace orbcal;

namespace {

bool haveSet(const std::string& name) {
  if (std::filesystem::exists(test::sharedDataPath(name + "/README.md"))) return true;
  ORBCAL_SKIP("the real image set is not at " << test::sharedDataPath(name));
  return false;
}

/// A set calibrated once per test run through `orbcal calibrate DESC.yaml` (workflow::runMeasuredCalibrate), with
/// its description read again (sim::loadImageViews) for the subsets: detection is most of the time, so every check
/// of a set reuses this run's detections (ImageCalibrateResult::detections).
struct SetRun {
  sim::ImageViews data;
  workflow::ImageCalibrateResult r;
};

const SetRun& runOf(const std::string& name) {
  static std::map<std::string, SetRun> cache;
  auto it = cache.find(name);
  if (it != cache.end()) return it->second;
  const std::string description = test::sourcePath("examples/real-images/" + name + ".yaml");
  workflow::MeasuredCalibrateOptions o;
  o.description = description;
  o.out = test::tempDir("real-images-" + name) + "/all";
  o.plots = false;
  const workflow::MeasuredCalibrateResult m = workflow::runMeasuredCalibrate(o);
  REQUIRE(m.images);
  return cache[name] = SetRun{sim::loadImageViews(description), *m.images};
}

/// The rows `rows` of a set (0-based; repeats allowed) with their detections, calibrated as runImageCalibrate does.
workflow::ImageCalibrateResult calibrateRows(const SetRun& s, const std::vector<int>& rows) {
  sim::ImageViews data = s.data;
  data.views.clear();
  std::vector<vision::ViewMeasurement> det;
  for (int k : rows) {
    data.views.push_back(s.data.views.at(static_cast<std::size_t>(k)));
    det.push_back(s.r.detections.at(static_cast<std::size_t>(k)));
  }
  return workflow::calibrateImageViews(data, det);
}

/// The views orbcal used, as the hand-eye solvers take them (the same detections: corners and each view's PnP).
std::vector<calib::HandEyeView> usedViews(const workflow::ImageCalibrateResult& r) {
  std::vector<calib::HandEyeView> out;
  for (std::size_t k = 0; k < r.views.size(); ++k) {
    if (!r.views[k].used) continue;
    const vision::Measurement& m = r.detections[k].measurement;
    calib::HandEyeView h;
    h.base_T_flange = r.views[k].base_T_flange;
    h.corners_px = m.corners_px;
    for (std::size_t n = 0; n < m.corners_px.size(); ++n) h.ids.push_back(m.cornerId(n));
    h.camera_T_board = m.camera_T_board;
    out.push_back(h);
  }
  return out;
}

Eigen::Isometry3d isometry(const cv::Mat& R, const cv::Mat& t) {
  Eigen::Matrix3d Re;
  Eigen::Vector3d te;
  cv::cv2eigen(R, Re);
  cv::cv2eigen(t, te);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Re;
  T.translation() = te;
  return T;
}

/// The flange pose as OpenCV's calibrateHandEye takes it: eye in hand base_T_flange; eye to hand its inverse (OpenCV's
/// documentation), the solve then giving base_T_camera.
Eigen::Isometry3d gripperPose(const calib::HandEyeView& v, sim::HandEyeSetup setup) {
  return setup == sim::HandEyeSetup::kEyeInHand ? v.base_T_flange : v.base_T_flange.inverse();
}

/// OpenCV's hand-eye (PARK) on the views `which`: eye in hand flange_T_camera, eye to hand base_T_camera.
Eigen::Isometry3d opencvHandEye(const std::vector<calib::HandEyeView>& views, const std::vector<int>& which, sim::HandEyeSetup setup) {
  std::vector<cv::Mat> R_g2b, t_g2b, R_t2c, t_t2c;
  for (int k : which) {
    const calib::HandEyeView& v = views[static_cast<std::size_t>(k)];
    const Eigen::Isometry3d g = gripperPose(v, setup);
    cv::Mat R, t, Rc, tc;
    cv::eigen2cv(Eigen::Matrix3d(g.linear()), R);
    cv::eigen2cv(Eigen::Vector3d(g.translation()), t);
    cv::eigen2cv(Eigen::Matrix3d(v.camera_T_board.linear()), Rc);
    cv::eigen2cv(Eigen::Vector3d(v.camera_T_board.translation()), tc);
    R_g2b.push_back(R);
    t_g2b.push_back(t);
    R_t2c.push_back(Rc);
    t_t2c.push_back(tc);
  }
  cv::Mat R, t;
  cv::calibrateHandEye(R_g2b, t_g2b, R_t2c, t_t2c, R, t, cv::CALIB_HAND_EYE_PARK);
  return isometry(R, t);
}

/// OpenCV's robot-world / hand-eye solve (calibrateRobotWorldHandEye, `method` SHAH or LI) on every view, in its own
/// terms cam_T_world world_T_base = cam_T_gripper gripper_T_base: eye in hand its camera is the camera and its world the
/// board; eye to hand its "camera" is the board on the flange and its "world" the static camera. Returns the hand-eye as
/// calibrateHandEye gives it: eye in hand flange_T_camera, eye to hand base_T_camera.
Eigen::Isometry3d opencvRobotWorld(const std::vector<calib::HandEyeView>& views, sim::HandEyeSetup setup,
                                   cv::RobotWorldHandEyeCalibrationMethod method) {
  std::vector<cv::Mat> R_w2c, t_w2c, R_b2g, t_b2g;
  const auto add = [](const Eigen::Isometry3d& T, std::vector<cv::Mat>& Rs, std::vector<cv::Mat>& ts) {
    cv::Mat R, t;
    cv::eigen2cv(Eigen::Matrix3d(T.linear()), R);
    cv::eigen2cv(Eigen::Vector3d(T.translation()), t);
    Rs.push_back(R);
    ts.push_back(t);
  };
  const bool in_hand = setup == sim::HandEyeSetup::kEyeInHand;
  for (const calib::HandEyeView& v : views) {
    add(in_hand ? v.camera_T_board : Eigen::Isometry3d(v.camera_T_board.inverse()), R_w2c, t_w2c);
    add(v.base_T_flange.inverse(), R_b2g, t_b2g);
  }
  cv::Mat R_b2w, t_b2w, R_g2c, t_g2c;
  cv::calibrateRobotWorldHandEye(R_w2c, t_w2c, R_b2g, t_b2g, R_b2w, t_b2w, R_g2c, t_g2c, method);
  return in_hand ? isometry(R_g2c, t_g2c).inverse() : isometry(R_b2w, t_b2w).inverse();
}

/// Both frames from OpenCV's hand-eye X on the views `which`: the fixed frame the chain closes on (eye in hand
/// base_T_board = base_T_flange X camera_T_board; eye to hand flange_T_board = flange_T_base X camera_T_board),
/// averaged over the views (translations averaged, rotations by the chordal mean).
calib::HandEyeFrames opencvFrames(const std::vector<calib::HandEyeView>& views, const std::vector<int>& which, sim::HandEyeSetup setup) {
  const Eigen::Isometry3d X = opencvHandEye(views, which, setup);
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  for (int k : which) {
    const calib::HandEyeView& v = views[static_cast<std::size_t>(k)];
    const Eigen::Isometry3d fixed = gripperPose(v, setup) * X * v.camera_T_board;
    t += fixed.translation() / static_cast<double>(which.size());
    M += fixed.linear();
  }
  Eigen::Isometry3d fixed = Eigen::Isometry3d::Identity();
  fixed.linear() = sim::projectToSO3(M);
  fixed.translation() = t;
  // orbcal's frames: eye in hand world = board (board_T_base), marker = camera; eye to hand world = camera, marker = board.
  return setup == sim::HandEyeSetup::kEyeInHand ? calib::HandEyeFrames{fixed.inverse(), X} : calib::HandEyeFrames{X.inverse(), fixed};
}

/// The hand-eye as OpenCV's solve gives it: eye in hand flange_T_camera, eye to hand base_T_camera.
Eigen::Isometry3d handEyeOf(const calib::HandEyeFrames& f, sim::HandEyeSetup setup) {
  return setup == sim::HandEyeSetup::kEyeInHand ? f.flange_T_marker : Eigen::Isometry3d(f.world_T_base.inverse());
}

/// OpenCV's hand-eye judged as orbcal's is: its jackknife 1-sigma over the views (each left out in turn; the sets have
/// no repeated rows) and the RMS over the views of each view's residual (px) under OpenCV's frames fitted without it.
struct OpenCvReference {
  Eigen::Isometry3d hand_eye;
  sim::Vector6d sigma;
  double heldout_rms_px = 0.0;
};

OpenCvReference opencvReference(const std::vector<calib::HandEyeView>& views, const SetRun& s) {
  const sim::HandEyeSetup setup = s.data.setup;
  std::vector<int> all(views.size());
  std::iota(all.begin(), all.end(), 0);
  OpenCvReference ref;
  ref.hand_eye = opencvHandEye(views, all, setup);
  std::vector<Eigen::Isometry3d> refits;
  double sse = 0.0;
  for (int held : all) {
    std::vector<int> train;
    for (int k : all) {
      if (k != held) train.push_back(k);
    }
    const calib::HandEyeFrames f = opencvFrames(views, train, setup);
    refits.push_back(handEyeOf(f, setup));
    const calib::ViewResidual e = calib::viewResidual(views[static_cast<std::size_t>(held)], f, s.data.camera, s.data.board, setup);
    sse += e.rms_px * e.rms_px;
  }
  ref.sigma = calib::jackknifeSigma(refits, ref.hand_eye);
  ref.heldout_rms_px = std::sqrt(sse / static_cast<double>(views.size()));
  return ref;
}

void requireNear(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double m, double rad) {
  CHECK((a.translation() - b.translation()).norm() <= m);
  CHECK(sim::rotationAngle(a.linear().transpose() * b.linear()) <= rad);
}

/// The set accepted with its cross-validated residuals written; its hand-eye against OpenCV's calibrateHandEye (PARK)
/// on the same detections: within 2 mm and 0.5 deg, or, where OpenCV's own jackknife 1-sigma on the set is larger
/// than that allows, within twice it; and orbcal's corner fit predicts the views held out better than OpenCV's frames
/// fitted without them (the truth the data imply: which frames put the corners where the camera saw them).
void checkSet(const std::string& name, int min_used, bool within_criterion) {
  const SetRun& s = runOf(name);
  const workflow::ImageCalibrateResult& r = s.r;
  INFO(name << ": " << r.used << " views used; refusals: " << (r.refusals.empty() ? "none" : r.refusals.front()));
  REQUIRE(r.refusals.empty());
  CHECK(r.used >= min_used);
  CHECK(std::filesystem::exists(r.frames_path));
  const std::vector<calib::HandEyeView> views = usedViews(r);
  const OpenCvReference ref = opencvReference(views, s);
  const Eigen::Isometry3d ours = r.setup == sim::HandEyeSetup::kEyeInHand ? r.hand_T_eye : r.base_T_other;
  const double dt = (ours.translation() - ref.hand_eye.translation()).norm();
  const double dr = sim::rotationAngle(ours.linear().transpose() * ref.hand_eye.linear());
  const double sigma_t = ref.sigma.head<3>().norm(), sigma_r = ref.sigma.tail<3>().norm();
  std::cout << name << ": orbcal vs OpenCV's PARK " << dt * 1e3 << " mm, " << dr * sim::kRadToDeg << " deg; OpenCV's jackknife 1-sigma "
            << sigma_t * 1e3 << " mm, " << sigma_r * sim::kRadToDeg << " deg; held out per view: orbcal " << r.heldout_rms_px << " px, "
            << r.heldout_rms_mm << " mm (closed form " << r.heldout_start_rms_px << " px), OpenCV " << ref.heldout_rms_px << " px; "
            << r.seconds << " s" << std::endl;
  // OpenCV's robot-world / hand-eye solvers on the same detections, a further independent reference (measured and
  // stated in docs/real-images.md, not a criterion): each must give a rotation, and its distance from orbcal's is printed.
  for (const auto& [label, method] : {std::make_pair("SHAH", cv::CALIB_ROBOT_WORLD_HAND_EYE_SHAH),
                                      std::make_pair("LI", cv::CALIB_ROBOT_WORLD_HAND_EYE_LI)}) {
    const Eigen::Isometry3d rw = opencvRobotWorld(views, r.setup, method);
    CHECK((rw.linear().transpose() * rw.linear() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-6);
    std::cout << name << ": orbcal vs OpenCV's calibrateRobotWorldHandEye " << label << " "
              << (ours.translation() - rw.translation()).norm() * 1e3 << " mm, "
              << sim::rotationAngle(ours.linear().transpose() * rw.linear()) * sim::kRadToDeg << " deg; vs PARK "
              << (ref.hand_eye.translation() - rw.translation()).norm() * 1e3 << " mm, "
              << sim::rotationAngle(ref.hand_eye.linear().transpose() * rw.linear()) * sim::kRadToDeg << " deg; translation "
              << (rw.translation() * 1e3).transpose() << " mm" << std::endl;
  }
  CHECK(dt <= std::max(2e-3, 2.0 * sigma_t));
  CHECK(dr <= std::max(0.5 * sim::kDegToRad, 2.0 * sigma_r));
  if (within_criterion) requireNear(ours, ref.hand_eye, 2e-3, 0.5 * sim::kDegToRad);
  CHECK(r.heldout_rms_px < ref.heldout_rms_px);
  CHECK(r.cross_validated);
  CHECK(r.heldout_rms_px >= r.fitted_rms_px);  // a view predicted without itself fits no better than with it
  const std::string report = sim::readTextSource(r.report_path);
  CHECK(report.find("held out (cross-validated), corner fit") != std::string::npos);

  // Calibrating the same detections again gives the same frames, bit for bit (the folds run in parallel).
  std::vector<int> rows(r.views.size());
  std::iota(rows.begin(), rows.end(), 0);
  const workflow::ImageCalibrateResult again = calibrateRows(s, rows);
  CHECK(again.hand_T_eye.matrix() == r.hand_T_eye.matrix());
  CHECK(again.base_T_other.matrix() == r.base_T_other.matrix());
  // 12 of the views the board was found in: judged by cross-validation, not refused for too few held out; the same
  // 12 rows each written twice: the copies are one configuration, left out together, and give the same frames.
  std::vector<int> twelve, twice;
  for (std::size_t k = 0; k < r.views.size() && twelve.size() < 12; ++k) {
    if (r.views[k].used) twelve.push_back(static_cast<int>(k));
  }
  for (int k : twelve) twice.insert(twice.end(), {k, k});
  const workflow::ImageCalibrateResult small = calibrateRows(s, twelve);
  INFO("12 views: " << (small.refusals.empty() ? "accepted" : small.refusals.front()));
  std::cout << name << ", 12 views: held out per view " << small.heldout_rms_px << " px, " << small.heldout_rms_mm << " mm" << std::endl;
  CHECK(small.refusals.empty());
  CHECK(small.configurations == 12);
  const workflow::ImageCalibrateResult doubled = calibrateRows(s, twice);
  CHECK(doubled.configurations == 12);  // a repeated row is its configuration's, never a view of its own
  requireNear(doubled.hand_T_eye, small.hand_T_eye, 1e-6, 1e-6);
  requireNear(doubled.base_T_other, small.base_T_other, 1e-6, 1e-6);
  CHECK(std::abs(doubled.heldout_rms_mm - small.heldout_rms_mm) <= 1e-3);  // the copies are left out together
  // Fewer configurations than the judge needs: refused by crossValidatedVerdict's rule, nothing cross-validated.
  const workflow::ImageCalibrateResult nine = calibrateRows(s, std::vector<int>(twelve.begin(), twelve.begin() + 9));
  CHECK_FALSE(nine.refusals.empty());
  CHECK_FALSE(nine.cross_validated);
}

}  // namespace

TEST_CASE("real images: the Doosan A0509 eye-in-hand set calibrates its hand-eye as OpenCV does", "[real-images][slow]") {
  if (!haveSet("doosan-a0509")) return;
  checkSet("doosan-a0509", 21, true);
}

TEST_CASE("real images: the industrial_calibration eye-to-hand set calibrates its camera within OpenCV's own uncertainty",
          "[real-images]") {
  if (!haveSet("ic-charuco")) return;
  // Not within 2 mm and 0.5 deg of OpenCV's PARK (12.2 mm, 0.70 deg): OpenCV's own jackknife 1-sigma on this set is
  // 10.0 mm and 0.91 deg (the camera 1.3 m from the base: a PnP rotation error's lever), and its frames predict the
  // views held out at 8.1 px against the corner fit's 2.4 px (docs/real-images.md).
  checkSet("ic-charuco", 15, false);
}

TEST_CASE("real images: controller rotations rounded to 4 digits are re-orthonormalised, worse ones refused", "[real-images]") {
  const double c = 0.7071;  // 1/sqrt(2) as a controller prints it: |R^T R - I| = 1.9e-5
  Eigen::Matrix3d R;
  R << c, -c, 0, c, c, 0, 0, 0, 1;
  std::string warning;
  const Eigen::Matrix3d fixed = sim::controllerRotation(R, "poses.csv: line 2", &warning);
  CHECK((fixed.transpose() * fixed - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-12);
  CHECK(warning.find("re-orthonormalised") != std::string::npos);
  R(0, 0) = 0.70;  // off by 1e-2
  CHECK_THROWS_AS(sim::controllerRotation(R, "poses.csv: line 2", nullptr), sim::InputError);
}
