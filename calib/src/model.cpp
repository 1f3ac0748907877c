#include "orbcal/calib/model.hpp"

#include <stdexcept>

#include "orbcal/sim/model.hpp"

namespace orbcal::calib {

sim::Arm calibratedArm(const sim::Arm& nominal, const Eigen::VectorXd& y) {
  return sim::foldParameters(sim::flangeModel(nominal), y).model.arm;
}

void requireFinite(const Linearization& lin, int k) {
  if (lin.innovation.allFinite() && lin.H.allFinite() && lin.R.allFinite()) return;
  throw std::runtime_error("fit: sample " + std::to_string(k + 1) + " of the fitted samples: its residual, Jacobian or "
                           "covariance is not finite (a measured value far outside what the arm reaches?); nothing was fitted");
}

StackedLinearization linearizeAll(const MeasurementModel& model, const Eigen::VectorXd& y) {
  int total = 0;
  for (int k = 0; k < model.numSamples(); ++k) total += model.rows(k);
  StackedLinearization s;
  s.innovation.resize(total);
  s.H.resize(total, model.numParams());
  s.R.reserve(static_cast<std::size_t>(model.numSamples()));
  for (int k = 0, row = 0; k < model.numSamples(); ++k) {
    Linearization lin = model.linearize(k, y);
    requireFinite(lin, k);
    const int m = model.rows(k);
    s.innovation.segment(row, m) = lin.innovation;
    s.H.middleRows(row, m) = lin.H;
    s.R.push_back(std::move(lin.R));
    row += m;
  }
  return s;
}

}  // namespace orbcal::calib
