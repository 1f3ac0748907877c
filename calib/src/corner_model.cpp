#include "orbcal/calib/corner_model.hpp"

#include <cmath>
#include <stdexcept>

#include "orbcal/sim/se3.hpp"

namespace orbcal::calib {

namespace {

/// The camera's coefficients with (dk1, dk2, dp1, dp2) added.
sim::Camera withDelta(const sim::Camera& camera, const Eigen::Ref<const Eigen::VectorXd>& delta) {
  sim::Camera c = camera;
  for (int i = 0; i < 4; ++i) c.distortion[static_cast<std::size_t>(i)] += delta[i];
  return c;
}

}  // namespace

CornerMeasurementModel::CornerMeasurementModel(sim::KinematicModel model, sim::Camera camera, sim::Board board,
                                               std::vector<CornerObservation> observations, CornerNoise noise,
                                               Eigen::VectorXd p0, sim::HandEyeSetup setup)
    : model_(std::move(model)),
      camera_(camera),
      board_(board),
      observations_(std::move(observations)),
      noise_(noise),
      p0_(std::move(p0)),
      layout_(model_.layout),
      setup_(setup) {
  layout_.add(sim::distortionBlock());
  if (p0_.size() == 0) p0_ = Eigen::VectorXd::Zero(layout_.size());
  if (p0_.size() != layout_.size()) throw std::invalid_argument("CornerMeasurementModel: p0 has the wrong size");
  if (!(noise_.sigma_px > 0.0)) throw std::invalid_argument("CornerMeasurementModel: sigma_px must be positive");
  for (const CornerObservation& o : observations_) {
    sim::checkJointVector(model_.arm, o.sample.q_rad, "CornerMeasurementModel");
    if (o.ids.empty() && static_cast<int>(o.corners_px.size()) != board_.numCorners()) {
      throw std::invalid_argument("CornerMeasurementModel: an observation has " + std::to_string(o.corners_px.size()) +
                                  " corners, the board " + std::to_string(board_.numCorners()));
    }
    if (!o.ids.empty()) {
      if (o.ids.size() != o.corners_px.size()) throw std::invalid_argument("CornerMeasurementModel: one id per corner");
      for (const int id : o.ids) {
        if (id < 0 || id >= board_.numCorners()) throw std::invalid_argument("CornerMeasurementModel: corner id out of range");
      }
    }
  }
}

int CornerMeasurementModel::rows(int k) const {
  return 2 * static_cast<int>(observations_.at(static_cast<std::size_t>(k)).corners_px.size());
}

sim::Camera CornerMeasurementModel::cameraAt(const Eigen::VectorXd& p) const {
  return withDelta(camera_, p.segment(distortionOffset(), 4));
}

Eigen::Isometry3d CornerMeasurementModel::cameraTBoard(int k, const Eigen::VectorXd& p) const {
  const Eigen::Isometry3d world_T_marker =
      sim::predictMarkerPose(model_, p.head(model_.layout.size()), observations_.at(static_cast<std::size_t>(k)).sample);
  return setup_ == sim::HandEyeSetup::kEyeInHand ? world_T_marker.inverse() : world_T_marker;
}

Eigen::VectorXd CornerMeasurementModel::residual(int k, const Eigen::VectorXd& p) const {
  const CornerObservation& o = observations_.at(static_cast<std::size_t>(k));
  const Eigen::Isometry3d camera_T_board = cameraTBoard(k, p);
  const sim::Camera cam = cameraAt(p);
  Eigen::VectorXd nu(rows(k));
  for (int i = 0; i < static_cast<int>(o.corners_px.size()); ++i) {
    nu.segment<2>(2 * i) = o.corners_px[static_cast<std::size_t>(i)] -
                           sim::project(cam, camera_T_board * sim::cornerInBoard(board_, o.cornerId(static_cast<std::size_t>(i))));
  }
  return nu;
}

Linearization CornerMeasurementModel::linearize(int k, const Eigen::VectorXd& y) const {
  const CornerObservation& o = observations_.at(static_cast<std::size_t>(k));
  const Eigen::VectorXd p = p0_ + y;
  const int nc = model_.layout.size();
  const bool joint_noise = noise_.joint_noise_sigma_rad > 0.0;
  Eigen::MatrixXd J_e_p, J_e_q;
  const bool in_hand = setup_ == sim::HandEyeSetup::kEyeInHand;
  const Eigen::Isometry3d world_T_marker = sim::predictMarkerPose(model_, p.head(nc), o.sample, &J_e_p, joint_noise ? &J_e_q : nullptr);
  const Eigen::Isometry3d camera_T_board = in_hand ? world_T_marker.inverse() : world_T_marker;
  const sim::Camera cam = cameraAt(p);
  const Eigen::Matrix2d F = Eigen::Vector2d(cam.fx_px, cam.fy_px).asDiagonal();
  const int m = rows(k);
  Linearization lin;
  lin.innovation.resize(m);
  lin.H.setZero(m, layout_.size());
  Eigen::MatrixXd G(m, 6);  // d(uv) / d(xi), xi the right perturbation of world_T_marker in the marker frame
  for (int i = 0; i < static_cast<int>(o.corners_px.size()); ++i) {
    const Eigen::Vector3d X = sim::cornerInBoard(board_, o.cornerId(static_cast<std::size_t>(i)));
    const Eigen::Vector3d pc = camera_T_board * X;
    const double z = pc.z();
    const Eigen::Vector2d xy(pc.x() / z, pc.y() / z);
    Eigen::Matrix2d J_d_xy;
    const Eigen::Vector2d d = sim::distortNormalized(cam.distortion, xy, &J_d_xy);
    lin.innovation.segment<2>(2 * i) =
        o.corners_px[static_cast<std::size_t>(i)] - Eigen::Vector2d(cam.fx_px * d.x() + cam.cx_px, cam.fy_px * d.y() + cam.cy_px);
    Eigen::Matrix<double, 2, 3> J_xy_pc;
    J_xy_pc << 1.0 / z, 0.0, -xy.x() / z, 0.0, 1.0 / z, -xy.y() / z;
    Eigen::Matrix<double, 3, 6> J_pc_xi;
    if (in_hand) {
      J_pc_xi << -Eigen::Matrix3d::Identity(), sim::skew(pc);
    } else {
      J_pc_xi << camera_T_board.linear(), -camera_T_board.linear() * sim::skew(X);
    }
    G.middleRows<2>(2 * i) = F * J_d_xy * J_xy_pc * J_pc_xi;
    // d(xd, yd) / d(k1, k2, p1, p2) of sim::distortNormalized's polynomial.
    const double x = xy.x(), yy = xy.y(), r2 = x * x + yy * yy;
    Eigen::Matrix<double, 2, 4> J_d_k;
    J_d_k << x * r2, x * r2 * r2, 2.0 * x * yy, r2 + 2.0 * x * x,  //
        yy * r2, yy * r2 * r2, r2 + 2.0 * yy * yy, 2.0 * x * yy;
    lin.H.block<2, 4>(2 * i, nc) = F * J_d_k;
  }
  lin.H.leftCols(nc) = G * J_e_p;
  lin.R = noise_.sigma_px * noise_.sigma_px * Eigen::MatrixXd::Identity(m, m);
  if (joint_noise) {
    const Eigen::MatrixXd Gq = G * J_e_q;
    lin.R += noise_.joint_noise_sigma_rad * noise_.joint_noise_sigma_rad * Gq * Gq.transpose();
  }
  return lin;
}

double cornerResidualRms(const CornerMeasurementModel& model, const Eigen::VectorXd& p) {
  double sum = 0.0;
  long n = 0;
  for (int k = 0; k < model.numSamples(); ++k) {
    const Eigen::VectorXd r = model.residual(k, p);
    sum += r.squaredNorm();
    n += r.size();
  }
  return n ? std::sqrt(sum / static_cast<double>(n)) : 0.0;
}

CornerFit fitCornerModel(const sim::KinematicModel& model, const sim::Camera& camera, const sim::Board& board,
                         const std::vector<CornerObservation>& observations, CornerNoise noise, bool estimate_sigma,
                         const Eigen::VectorXd& p0, const std::vector<int>& hold) {
  CornerFit f;
  LmOptions lm;
  lm.hold = hold;
  const int rounds = estimate_sigma ? 2 : 1;
  for (int round = 0; round < rounds; ++round) {
    const CornerMeasurementModel m(model, camera, board, observations, noise, p0);
    f.estimate = runLm(m, lm);
    f.p = m.p0() + f.estimate.y;
    f.rows = 0;
    for (int k = 0; k < m.numSamples(); ++k) f.rows += m.rows(k);
    f.dof = std::max(1, f.rows - (m.numParams() - static_cast<int>(f.estimate.held.size())));
    f.rms_px = cornerResidualRms(m, f.p);
    f.sigma_px = noise.sigma_px;
    // Variance component: the pixel sigma that makes the whitened residual's chi^2 equal to its dof.
    if (round + 1 < rounds) noise.sigma_px = std::max(1e-6, noise.sigma_px * std::sqrt(2.0 * f.estimate.cost / f.dof));
  }
  return f;
}

}  // namespace orbcal::calib
