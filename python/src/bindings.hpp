#pragma once
// The compiled part of the `orbcal` Python module (`_orbcal`): one file per topic, each adding its
// functions and classes to the module. SI units throughout (m, rad, N m, degC, s); numpy arrays in and
// out (pybind11/eigen.h); orbcal's InputError arrives in Python as orbcal.Error with its one-line message.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <optional>
#include <string>
#include <vector>

#include "orbcal/calib/measured_fit.hpp"
#include "orbcal/sim/arm.hpp"
#include "orbcal/sim/model.hpp"
#include "orbcal/sim/model_io.hpp"

namespace orbcal::python {

namespace py = pybind11;

/// A model as Python sees it: the kinematic model, its effect parameters (sim::foldParameters' p) and
/// the parameter rows a model file lists (every parameter of the fit, SI, with its 1-sigma).
struct PyModel {
  sim::KinematicModel model;
  Eigen::VectorXd p;
  std::vector<sim::ParameterRow> rows;
  py::dict statistics;  ///< of the fit that made it (empty for a loaded or true model)
};

/// Effects from their specs ("compliance:2", joints from 1, as the command line writes them); InputError
/// naming `what` for a bad one.
std::vector<sim::Effect> parseEffects(const std::vector<std::string>& specs, int joints, const std::string& what);

/// Residual statistics as a dict: samples, position_mean_m, position_rms_m, position_max_m,
/// rotation_rms_rad, rotation_max_rad.
py::dict residualDict(const calib::ResidualStats& s);

/// The statistics of a fit: residuals at the fit (residualDict), chi2, dof, noise {position_m,
/// rotation_rad, joint_rad}, noise_estimated, weak (parameter names).
py::dict fitStatistics(const calib::Fit& fit);

/// Parameter rows as records: one dict per parameter (name, effect, unit, value, sigma, held; SI).
py::list parameterRecords(const std::vector<sim::ParameterRow>& rows);

/// orbcal.Refused, the exception of a refused calibration (an orbcal.Error), made at the module's start.
py::handle refusedType();

/// Parameter rows of a model whose values are known exactly (a truth, a loaded model): sigma NaN.
std::vector<sim::ParameterRow> exactRows(const sim::KinematicModel& model, const Eigen::VectorXd& p);

void bindRobot(py::module_& m);
void bindMeasurements(py::module_& m);
void bindCalibrate(py::module_& m);
void bindCalibration(py::module_& m);
void bindDiagnose(py::module_& m);
void bindWorkflow(py::module_& m);

}  // namespace orbcal::python
