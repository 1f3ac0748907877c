#pragma once
// The whitened stacked system on some of the parameters (calib/src/estimators.cpp), for the library's
// own long-log paths.
#include <Eigen/Dense>
#include <algorithm>
#include <vector>

#include "orbcal/calib/dense_kernels.hpp"
#include "orbcal/calib/model.hpp"
#include "orbcal/calib/observability.hpp"

namespace orbcal::calib {

/// whitenedSystem (estimators.hpp) on the parameters `cols` alone, column c times scale[c] (empty: 1),
/// filled sample by sample: no copy of the other columns nor of the whole linearization (a long log's
/// whole Jacobian is gigabytes).
void whitenedSystem(const MeasurementModel& model, const Eigen::VectorXd& y, const std::vector<int>& cols, const Eigen::VectorXd& scale,
                    Eigen::MatrixXd& A, Eigen::VectorXd& b);

/// The R factor (n x n, n parameters) of the whitened Jacobian at y with the columns `zeroed` set to
/// zero: its column norms, singular values and right singular vectors, a few samples at a time.
Eigen::MatrixXd whitenedRFactor(const MeasurementModel& model, const Eigen::VectorXd& y, const std::vector<int>& zeroed = {});

/// observability (observability.hpp) of `model` from R, its whitened Jacobian's R factor at the point
/// wanted (whitenedRFactor's), where the caller already has it.
ObservabilityIndices observability(const Eigen::MatrixXd& R, const MeasurementModel& model, const std::vector<int>& held,
                                   double rank_tolerance = sim::kRankTolerance);

/// Sample k's rows of the whitened system at y (whitenedSystem's): W H_k (every column) and W nu_k.
void whitenedRows(const MeasurementModel& model, int k, const Eigen::VectorXd& y, Eigen::MatrixXd& H, Eigen::VectorXd& b);

/// The R factor of a tall matrix given a few rows at a time (A = Q R, accumulated over blocks of rows:
/// [R; next rows] = Q' R'): A's column norms, singular values and right singular vectors in n x n,
/// without A (a long log's whitened Jacobian is gigabytes).
class RFactor {
 public:
  RFactor() : RFactor(0) {}
  explicit RFactor(Eigen::Index n) : n_(n), block_(std::max<Eigen::Index>(256, 4 * n)), stacked_(block_ + n + 6, n) {}
  void add(const Eigen::MatrixXd& rows) {
    if (used_ + rows.rows() > stacked_.rows()) stacked_.conservativeResize(used_ + rows.rows() + block_, Eigen::NoChange);
    stacked_.middleRows(used_, rows.rows()) = rows;
    used_ += rows.rows();
    if (used_ >= block_) reduce();
  }
  Eigen::MatrixXd matrix() {
    reduce();
    return stacked_.topRows(used_);
  }

 private:
  void reduce() {
    if (used_ == kept_) return;  // nothing added since the last reduction
    householderRInPlace(stacked_, used_);
    kept_ = std::min(used_, n_);
    used_ = kept_;
  }
  Eigen::Index n_, block_;
  Eigen::MatrixXd stacked_;
  Eigen::Index used_ = 0, kept_ = 0;
};

}  // namespace orbcal::calib
