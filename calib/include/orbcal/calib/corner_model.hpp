#pragma once
// The corner-level measurement model of image datasets: the detected inner corners of each image
// against the board corners projected through the camera, the camera pose predicted by a
// sim::KinematicModel with world = the board and marker = the camera (world_T_marker = board_T_camera,
// as tools' imageMeasuredData sets it up), and the lens distortion corrected by a `distortion`
// parameter block (sim::distortionBlock) on top of the scene camera's:
//
//   h_k,i(p, d) = project(camera with (k1 + dk1, k2 + dk2, p1 + dp1, p2 + dp2, k3), camera_T_board(p) X_i)
//   camera_T_board(p) = predictMarkerPose(model, p, s_k)^-1,   X_i = sim::cornerInBoard(board, i)
//   nu_k = [u_0 - h_0u, v_0 - h_0v, u_1 - ...] (px, 2 rows per corner, corners in cornerInBoard order)
//
// Parameters: the KinematicModel's layout, then the distortion block (4 dimensionless coefficients)
// at the end; y is the change from p0 as in marker_model.hpp. H = d h / d y: for the chain columns,
// d(uv)/d(p_cam) [-I, S(p_cam)] J_e_p, where J_e_p is predictMarkerPose's Jacobian of the right
// perturbation xi = [rho; omega] of board_T_camera in the camera frame (p_cam' ≈ p_cam - rho + p_cam x
// omega); for the distortion columns d(uv)/d(dk). Both derived from sim::distortNormalized's formula
// and checked against central differences (tests/calib/test_corner_model.cpp).
//
// R_k = sigma_px^2 I, plus, where joint_noise_sigma_rad > 0, the joint noise carried through the
// corner Jacobian (G J_e_q sigma_q^2 J_e_q^T G^T, one rank-n term per image: joint noise moves all the
// corners of an image together). With joint_noise_sigma_rad = 0 (the default) joint noise is not
// modelled: its per-image common shift then counts as pixel noise.
//
// Eye to hand (sim::HandEyeSetup::kEyeToHand: a fixed camera, the board on the flange) the model's world
// is the camera and its marker the board: camera_T_board(p) = predictMarkerPose(model, p, s_k) itself,
// and the chain columns are d(uv)/d(p_cam) R [I, -S(X_i)] J_e_p (the right perturbation of
// camera_T_board in the board frame: p_cam' = p_cam + R (rho + omega x X_i)).
#include <Eigen/Core>
#include <vector>

#include "orbcal/calib/estimators.hpp"
#include "orbcal/calib/model.hpp"
#include "orbcal/sim/model.hpp"
#include "orbcal/sim/image_views.hpp"
#include "orbcal/sim/scene.hpp"

namespace orbcal::calib {

struct CornerObservation {
  sim::JointSample sample;
  std::vector<Eigen::Vector2d> corners_px;  ///< every inner corner, k as in sim::cornerInBoard, or those of `ids`
  std::vector<int> ids;  ///< empty: corners_px holds every corner in order; else corners_px[n] is corner ids[n] (ChArUco)
  int cornerId(std::size_t n) const { return ids.empty() ? static_cast<int>(n) : ids[n]; }
};

struct CornerNoise {
  double sigma_px = 0.1;               ///< per image coordinate
  double joint_noise_sigma_rad = 0.0;  ///< 0: joint noise not modelled
};

class CornerMeasurementModel : public MeasurementModel {
 public:
  /// `model`: world = the board, marker = the camera. `camera`: the scene's (its distortion is the
  /// starting point dk = 0). Throws std::invalid_argument on an observation without every corner of
  /// the board, or p0 of the wrong size (the model's layout + 4).
  /// `setup`: eye in hand (the default) or eye to hand (file comment).
  CornerMeasurementModel(sim::KinematicModel model, sim::Camera camera, sim::Board board,
                         std::vector<CornerObservation> observations, CornerNoise noise, Eigen::VectorXd p0 = {},
                         sim::HandEyeSetup setup = sim::HandEyeSetup::kEyeInHand);
  int numSamples() const override { return static_cast<int>(observations_.size()); }
  int rows(int k) const override;
  const sim::ParamLayout& layout() const override { return layout_; }
  Linearization linearize(int k, const Eigen::VectorXd& y) const override;

  /// Offset of the distortion block in the layout (the KinematicModel's parameters come first).
  int distortionOffset() const { return model_.layout.size(); }
  const sim::KinematicModel& model() const { return model_; }
  const sim::Camera& camera() const { return camera_; }
  const std::vector<CornerObservation>& observations() const { return observations_; }
  const Eigen::VectorXd& p0() const { return p0_; }
  /// The scene camera with the distortion of p (model parameters + distortion block) applied.
  sim::Camera cameraAt(const Eigen::VectorXd& p) const;
  /// nu_k at parameters p (not y).
  Eigen::VectorXd residual(int k, const Eigen::VectorXd& p) const;
  /// camera_T_board of observation k at parameters p (model parameters + distortion block).
  Eigen::Isometry3d cameraTBoard(int k, const Eigen::VectorXd& p) const;

 private:
  sim::KinematicModel model_;
  sim::Camera camera_;
  sim::Board board_;
  std::vector<CornerObservation> observations_;
  CornerNoise noise_;
  Eigen::VectorXd p0_;
  sim::ParamLayout layout_;
  sim::HandEyeSetup setup_ = sim::HandEyeSetup::kEyeInHand;
};

/// RMS over every corner coordinate of nu at parameters p (px).
double cornerResidualRms(const CornerMeasurementModel& model, const Eigen::VectorXd& p);

/// A fit of the corner model by LM from p0, the pixel sigma re-estimated from the residuals (rows over
/// degrees of freedom) and the model refitted with it when `estimate_sigma`, so the covariance is that
/// of the data's scatter.
struct CornerFit {
  Estimate estimate;        ///< y, covariance, held parameters
  Eigen::VectorXd p;        ///< p0 + y
  double sigma_px = 0.0;    ///< as used in the final fit
  double rms_px = 0.0;      ///< residual RMS at the fit
  int rows = 0, dof = 0;
};
CornerFit fitCornerModel(const sim::KinematicModel& model, const sim::Camera& camera, const sim::Board& board,
                         const std::vector<CornerObservation>& observations, CornerNoise noise, bool estimate_sigma,
                         const Eigen::VectorXd& p0 = {}, const std::vector<int>& hold = {});

}  // namespace orbcal::calib
