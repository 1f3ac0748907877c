#pragma once
// The compiled part of the `orbcal` Python module (`_orbcal`): one file per topic, each adding its
// functions and classes to the module. SI units throughout (m, rad, N m, degC, s); numpy arrays in and
// out (pybind11/eigen.h); orbcal's InputError arrives in Python as orbcal.Error with its one-line message.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <functional>
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
  std::string source;   ///< the model file it was read from or written to; empty: only in memory
  std::vector<std::string> alternatives;  ///< a loaded model file's `alternatives:` (model files), as evaluate compares them
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

/// Where a workflow run from Python writes: the folder the caller gave (kept), else a fresh temporary one
/// (orbcal-NAME-XXXXXX under the system's temporary folder) removed again with this object.
class RunFolder {
 public:
  RunFolder(const std::optional<std::string>& given, const std::string& name);
  ~RunFolder();
  RunFolder(const RunFolder&) = delete;
  RunFolder& operator=(const RunFolder&) = delete;
  const std::string& path() const { return path_; }
  bool temporary() const { return !temporary_.empty(); }

 private:
  std::string temporary_, path_;
};

/// A Python progress callable (done, total) as a C++ progress callback, called with the GIL held (from
/// a thread that released it); its exception stops the run. Empty for None.
std::function<void(int done, int total)> pythonProgress(const py::object& progress);

/// A written file's text (a report).
std::string readText(const std::string& path);

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
void bindTwin(py::module_& m);
void bindImages(py::module_& m);

}  // namespace orbcal::python
