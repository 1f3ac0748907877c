#pragma once
// The figures of a measured-data calibration (measured.cpp): their CSV files and the report's lines.
// Not part of the library's interface.
#include <string>
#include <vector>

#include "orbcal/calib/measured_fit.hpp"
#include "orbcal/workflow/callbacks.hpp"

namespace orbcal::workflow::measured_detail {

/// The noise floor of held-out errors: the RMS a position error [m] and a rotation angle [rad] would
/// have if the model were exact and only the fit's measurement noise were left.
struct NoiseFloor {
  double position_m = 0.0;  ///< sqrt(mean trace R_pos): the tracker's noise, and the joint readings' through J_q
  double rotation_rad = 0.0;  ///< sqrt(3) sigma_rotation: the tracker's rotation noise on three axes
};
NoiseFloor noiseFloor(const calib::Fit& fit, const std::vector<calib::MarkerObservation>& held,
                      const std::vector<Eigen::VectorXd>& after);

/// Writes out/heldout.csv (per held-out sample: session, position error of the nominal arm with the
/// registration fitted and of the calibrated model [mm], the noise floor [mm]; the same for the rotation
/// [deg] where it is measured, empty cells elsewhere) and draws heldout.png; with `accepted` (the model is
/// written), also out/estimates.csv (every parameter: estimate and 1-sigma in its display unit, held) and
/// parameters.png, as an image calibration writes its estimates only with its calibrated files. Figures
/// are drawn with `callbacks` (drawFigure: `plots` false gives the --no-plots line). Returns the
/// figures' Markdown lines.
std::string measuredFigures(const Callbacks& callbacks, bool plots, const std::string& out, const calib::Fit& fit,
                            const std::vector<calib::MarkerObservation>& held, const std::vector<Eigen::VectorXd>& before,
                            const std::vector<Eigen::VectorXd>& after, bool accepted);

}  // namespace orbcal::workflow::measured_detail
