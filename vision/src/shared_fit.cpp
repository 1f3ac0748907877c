#include "orbcal/vision/shared_fit.hpp"

#include <Eigen/Dense>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

namespace orbcal::vision {

namespace {

constexpr std::size_t kMinCorners = 6;

}  // namespace

Eigen::Isometry3d refitPose(const CornerView& v, const CornerModel& model) {
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  for (std::size_t n = 0; n < v.ids.size(); ++n) {
    const Eigen::Vector3d p = model.point(v.ids[n]);
    object.emplace_back(p.x(), p.y(), p.z());
    image.emplace_back(v.corners_px[n].x(), v.corners_px[n].y());
  }
  const sim::Camera& c = model.camera;
  const cv::Matx33d K(c.fx_px, 0, c.cx_px, 0, c.fy_px, c.cy_px, 0, 0, 1);
  const cv::Mat dist(std::vector<double>(c.distortion.begin(), c.distortion.end()), true);
  cv::Mat R;
  cv::eigen2cv(Eigen::Matrix3d(v.camera_T_board.linear()), R);
  cv::Mat rvec, tvec = (cv::Mat_<double>(3, 1) << v.camera_T_board.translation().x(), v.camera_T_board.translation().y(),
                        v.camera_T_board.translation().z());
  cv::Rodrigues(R, rvec);
  cv::solvePnPRefineLM(object, image, K, dist, rvec, tvec, cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 30, 1e-10));
  cv::Rodrigues(rvec, R);
  Eigen::Matrix3d Re;
  cv::cv2eigen(R, Re);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Re;
  T.translation() = Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  return T;
}

Eigen::VectorXd refittedResiduals(const std::vector<CornerView>& views, const CornerModel& model) {
  std::size_t n = 0;
  for (const CornerView& v : views) n += v.ids.size();
  Eigen::VectorXd r(2 * static_cast<Eigen::Index>(n));
  Eigen::Index row = 0;
  for (const CornerView& v : views) {
    const Eigen::Isometry3d T = refitPose(v, model);
    for (std::size_t k = 0; k < v.ids.size(); ++k) {
      r.segment<2>(row) = v.corners_px[k] - sim::project(model.camera, T * model.point(v.ids[k]));
      row += 2;
    }
  }
  return r;
}

SharedFit fitSharedWithPoses(const std::vector<CornerView>& all, const SharedModel& model, const Eigen::VectorXd& start,
                             const Eigen::VectorXd& step) {
  constexpr int kIterations = 10;
  SharedFit fit;
  std::vector<CornerView> views;
  for (const CornerView& v : all) {
    if (v.ids.size() >= kMinCorners && v.ids.size() == v.corners_px.size()) views.push_back(v);
  }
  fit.views = static_cast<int>(views.size());
  if (views.size() < 2) return fit;
  const Eigen::Index P = start.size();
  const auto residuals = [&](const Eigen::VectorXd& p) { return refittedResiduals(views, model(p)); };
  Eigen::VectorXd p = start, r = residuals(p);
  const Eigen::Index N = r.size();
  fit.corners = static_cast<int>(N / 2);
  fit.rms_start_px = std::sqrt(r.squaredNorm() / static_cast<double>(fit.corners));
  Eigen::MatrixXd J(N, P);
  for (int it = 0; it < kIterations; ++it) {
    for (Eigen::Index j = 0; j < P; ++j) {  // forward differences: the residuals are smooth in the shared parameters
      Eigen::VectorXd hi = p;
      hi(j) += step(j);
      J.col(j) = (residuals(hi) - r) / step(j);  // d r / d p: r = detected - projected
    }
    const Eigen::VectorXd dp = -(J.transpose() * J).ldlt().solve(J.transpose() * r);
    const Eigen::VectorXd r_new = residuals(p + dp);
    if (!(r_new.squaredNorm() <= r.squaredNorm())) break;
    const double gain = r.squaredNorm() - r_new.squaredNorm();
    p += dp;
    r = r_new;
    if ((dp.array().abs() < 1e-3 * step.array()).all() || gain < 1e-6 * r.squaredNorm()) break;
  }
  const double dof = static_cast<double>(N - 6 * static_cast<Eigen::Index>(views.size()) - P);
  if (dof <= 0.0) return fit;
  const Eigen::MatrixXd cov = r.squaredNorm() / dof * (J.transpose() * J).inverse();
  fit.value = p;
  fit.covariance = cov;
  fit.sigma = cov.diagonal().cwiseSqrt();
  fit.rms_fit_px = std::sqrt(r.squaredNorm() / static_cast<double>(fit.corners));
  fit.ok = fit.value.allFinite() && fit.sigma.allFinite();
  return fit;
}

}  // namespace orbcal::vision
