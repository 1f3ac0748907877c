#pragma once
// The whitened stacked system on some of the parameters (calib/src/estimators.cpp), for the library's
// own long-log paths.
#include <Eigen/Dense>
#include <vector>

#include "orbcal/calib/model.hpp"

namespace orbcal::calib {

/// whitenedSystem (estimators.hpp) on the parameters `cols` alone, column c times scale[c] (empty: 1),
/// filled sample by sample: no copy of the other columns nor of the whole linearization (a long log's
/// whole Jacobian is gigabytes).
void whitenedSystem(const MeasurementModel& model, const Eigen::VectorXd& y, const std::vector<int>& cols, const Eigen::VectorXd& scale,
                    Eigen::MatrixXd& A, Eigen::VectorXd& b);

}  // namespace orbcal::calib
