// orbcal.calibrate and the Calibration class: the measured-data calibration of `orbcal calibrate
// DESC.yaml` (workflow::runMeasuredCalibrate: hold-out split, fit, plausibility checks, held-out verdict,
// refusals, model files and report), run on data in memory. A refused calibration raises orbcal.Refused
// (an orbcal.Error carrying the Calibration) unless accept_worse=True, as the command line exits 1.
#include <optional>

#include "bindings.hpp"
#include "orbcal/sim/model_io.hpp"
#include "orbcal/calib/levels.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/workflow/measured.hpp"

namespace orbcal::python {

namespace {

/// What Python sees of a calibration: the workflow's result, the model where one was written (accepted,
/// or accept_worse), the report's text, and the folder (empty where it was a temporary one, removed).
struct PyCalibration {
  workflow::MeasuredCalibrateResult r;
  std::optional<PyModel> model;
  std::string report, out;
};

bool accepted(const workflow::MeasuredCalibrateResult& r) { return !r.worse && r.refusals.empty(); }

py::dict heldoutDict(const workflow::MeasuredCalibrateResult& r) {
  return py::dict(py::arg("samples") = r.held_out, py::arg("configurations") = r.gain.configurations,
                  py::arg("before") = residualDict(r.heldout_before), py::arg("after") = residualDict(r.heldout_after),
                  py::arg("t") = r.gain.t, py::arg("p_value") = r.gain.p_value, py::arg("enough") = r.gain.enough,
                  py::arg("significant") = r.gain.significant, py::arg("cross_validated") = r.cross_validated);
}

/// Everything of a calibration as plain Python values (numbers, strings, lists, dicts), JSON-friendly.
py::dict calibrationDict(const PyCalibration& c) {
  return py::dict(py::arg("accepted") = accepted(c.r), py::arg("refusals") = c.r.refusals, py::arg("worse") = c.r.worse,
                  py::arg("samples") = c.r.samples, py::arg("fitted") = c.r.identification, py::arg("heldout") = heldoutDict(c.r),
                  py::arg("level") = calib::levelName(c.r.level.chosen), py::arg("level_reason") = calib::levelSentence(c.r.level),
                  py::arg("chi2") = c.r.fit.chi2, py::arg("dof") = c.r.fit.dof, py::arg("consistency_p") = c.r.consistency_p,
                  py::arg("inconsistent") = c.r.inconsistent, py::arg("statistics") = fitStatistics(c.r.fit),
                  py::arg("parameters") = parameterRecords(workflow::parameterRows(c.r.fit)));
}

struct CalibrateArgs {
  std::vector<std::string> effects;
  std::string method, level;
  std::optional<double> holdout;
  std::uint64_t seed;
  bool accept_worse;
  std::optional<std::string> out;
  std::optional<double> noise_position_m, noise_rotation_rad;
};

/// Raises orbcal.Refused (an orbcal.Error) with the reasons in one line and the calibration attached.
[[noreturn]] void raiseRefused(PyCalibration c, const std::string& description) {
  std::string why;
  for (const std::string& line : c.r.refusals) why += (why.empty() ? "" : "; ") + line;
  if (why.empty()) why = "the calibrated model predicts the held-out samples worse than the nominal arm";
  const py::handle type = refusedType();
  py::object e = py::reinterpret_borrow<py::object>(type)(
      description + ": the calibration is not accepted: " + why + "; no model returned (accept_worse=True returns it)");
  e.attr("calibration") = py::cast(std::move(c));
  PyErr_SetObject(type.ptr(), e.ptr());
  throw py::error_already_set();
}

PyCalibration calibrate(const sim::MeasuredData& data, const CalibrateArgs& a) {
  workflow::MeasuredCalibrateOptions o;
  o.description = data.description;
  o.effects = a.effects;
  o.method = workflow::parseFitMethod(a.method, "method");
  o.level = calib::parseLevel(a.level, "level");
  o.holdout = a.holdout;
  o.seed = a.seed;
  o.accept_worse = a.accept_worse;
  o.noise_position_m = a.noise_position_m;
  o.noise_rotation_rad = a.noise_rotation_rad;
  o.plots = false;  // no figure drawer here: the report says so
  const RunFolder folder(a.out, "calibration");
  o.out = folder.path();
  PyCalibration c;
  {
    py::gil_scoped_release release;
    c.r = workflow::runMeasuredCalibrate(data, o);
  }
  c.report = readText(c.r.report_path);
  if (folder.temporary()) {  // removed on return: no paths to files that are gone
    c.r.report_path.clear();
    c.r.model_path.clear();
  } else {
    c.out = o.out;
  }
  if (c.r.model) {  // the model written as model.yaml (accepted, or accept_worse): each effect with its fitted range
    py::dict stats = fitStatistics(c.r.fit);
    stats["level"] = calib::levelName(c.r.level.chosen);
    stats["level_reason"] = calib::levelSentence(c.r.level);
    c.model = PyModel{c.r.model->model, c.r.model->p, workflow::parameterRows(c.r.fit), stats, c.r.model_path, {}};
  }
  if (!accepted(c.r) && !a.accept_worse) raiseRefused(std::move(c), o.description);
  return c;
}

py::object optionalPath(const std::string& path) { return path.empty() ? py::object(py::none()) : py::object(py::str(path)); }

}  // namespace

void bindCalibration(py::module_& m) {
  py::class_<PyCalibration>(m, "Calibration",
                            "The outcome of orbcal.calibrate, as `orbcal calibrate DESC.yaml` reports it: accepted or the "
                            "reasons it is not, the held-out prediction of the nominal arm and of the calibrated model, the "
                            "level fitted, the model (None when refused without accept_worse) and report.md's text. SI units.")
      .def_property_readonly("accepted", [](const PyCalibration& c) { return accepted(c.r); },
                             "True when the held-out check and the checks on the fit accept the calibration")
      .def_property_readonly("refusals", [](const PyCalibration& c) { return c.r.refusals; },
                             "every reason the calibration is not accepted, one line each, as the command line prints them")
      .def_property_readonly("worse", [](const PyCalibration& c) { return c.r.worse; },
                             "the calibrated model predicts the held-out samples worse than the nominal arm")
      .def_property_readonly("model", [](const PyCalibration& c) { return c.model ? py::cast(*c.model) : py::object(py::none()); },
                             "the calibrated Model: when accepted, or with accept_worse=True (as model.yaml is written)")
      .def_property_readonly("heldout", [](const PyCalibration& c) { return heldoutDict(c.r); },
                             "held-out prediction: samples, configurations, before (nominal arm, registration fitted) and after "
                             "(calibrated) residual statistics (m, rad), and the gain's one-sided paired test (t, p_value, "
                             "enough configurations, significant; cross_validated: a set too small to hold out, every configuration predicted by a fit "
                             "without it)")
      .def_property_readonly("samples", [](const PyCalibration& c) { return c.r.samples; }, "samples in all")
      .def_property_readonly("fitted", [](const PyCalibration& c) { return c.r.identification; }, "samples fitted")
      .def_property_readonly("level", [](const PyCalibration& c) { return calib::levelName(c.r.level.chosen); },
                             "the level fitted: 'frames', 'offsets', 'full' or the list of free parameters")
      .def_property_readonly("level_reason", [](const PyCalibration& c) { return calib::levelSentence(c.r.level); },
                             "why that level (asked for, or chosen by cross-validation)")
      .def_property_readonly("statistics", [](const PyCalibration& c) { return fitStatistics(c.r.fit); },
                             "of the fit on the fitted samples: residuals, chi2, dof, noise, noise_estimated, weak")
      .def_readonly("report", &PyCalibration::report, "report.md's text (as orbcal calibrate --no-plots writes it)")
      .def_property_readonly("report_path", [](const PyCalibration& c) { return optionalPath(c.r.report_path); },
                             "report.md in `out`; None when no out folder was given (the files were temporary)")
      .def_property_readonly("model_path", [](const PyCalibration& c) { return optionalPath(c.r.model_path); },
                             "model.yaml in `out` where written; else None")
      .def("as_dict", &calibrationDict,
           "Everything as plain Python values (JSON-friendly): accepted, refusals, worse, samples, fitted, heldout, level, "
           "level_reason, chi2, dof, consistency_p, inconsistent, statistics, parameters (records)")
      .def("to_records", [](const PyCalibration& c) { return parameterRecords(workflow::parameterRows(c.r.fit)); },
           "One dict per fitted parameter (name, effect, unit, value, sigma, held; SI): pandas.DataFrame(c.to_records())")
      .def("__repr__", [](const PyCalibration& c) {
        return std::string("<orbcal.Calibration: ") + (accepted(c.r) ? "accepted" : "not accepted") + ", " +
               std::to_string(c.r.identification) + " fitted, " + std::to_string(c.r.held_out) + " held out>";
      });

  m.def(
      "calibrate",
      [](const sim::MeasuredData& data, const std::vector<std::string>& effects, const std::string& method, const std::string& level,
         std::optional<double> holdout, std::uint64_t seed, bool accept_worse, std::optional<std::string> out,
         std::optional<double> noise_position_m, std::optional<double> noise_rotation_rad) {
        return calibrate(data, {effects, method, level, holdout, seed, accept_worse, out, noise_position_m, noise_rotation_rad});
      },
      py::arg("data"), py::arg("effects") = std::vector<std::string>{}, py::arg("method") = calib::kDefaultMethod,
      py::arg("level") = "auto", py::kw_only(), py::arg("holdout") = py::none(), py::arg("seed") = 1,
      py::arg("accept_worse") = false, py::arg("out") = py::none(), py::arg("noise_position_m") = py::none(),
      py::arg("noise_rotation_rad") = py::none(),
      "Calibrates `data` as `orbcal calibrate DESC.yaml` does (the same code): holds out a seeded share of the "
      "configurations (holdout; None: the command line's default), fits geometry + registration + the chosen effects "
      "('compliance:2', 'cyclic:4', ...; joints from 1) on the rest at `level` ('frames', 'offsets', 'full', a list "
      "'theta1,theta3,d2', or 'auto': by cross-validation, seeded with `seed`), checks the fit against the noise the "
      "data states (noise_position_m / noise_rotation_rad replace it) and the held-out prediction against the nominal "
      "arm's. method: 'LM', 'LSE', 'EKF' or a variant `orbcal calibrate --help` lists. out: a folder to write what the "
      "command line writes (report.md, heldout.csv, model.yaml and its exports when accepted; no figures); None: "
      "nothing is kept. Returns a Calibration. A calibration the command line refuses raises orbcal.Refused (an "
      "orbcal.Error; its .calibration says why) unless accept_worse=True, which returns it with the model.");
}

}  // namespace orbcal::python
