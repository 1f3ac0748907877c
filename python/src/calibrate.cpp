// orbcal.evaluate, orbcal.load_model and the Model class: a model of geometry + registration + effects
// (what orbcal.calibrate makes, python/src/calibration.cpp), the prediction of other data with it, and the
// model file (sim/model_io.hpp), as `orbcal evaluate` and `orbcal calibrate DESC.yaml` write them.
#include <filesystem>

#include "bindings.hpp"
#include "orbcal/calib/levels.hpp"
#include "orbcal/calib/measured_fit.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/workflow/measured.hpp"

namespace orbcal::python {

namespace {

/// The model file's path split as sim::writeModelFile takes it: model.yaml goes with robot.yaml (as the
/// command line writes them), NAME.yaml with NAME.robot.yaml.
std::string saveModel(const PyModel& m, const std::string& path) {
  const std::filesystem::path p(path);
  const std::string folder = p.parent_path().empty() ? "." : p.parent_path().string();
  const std::string name = p.filename().string();
  const std::string robot = name == "model.yaml" ? "robot.yaml" : p.stem().string() + ".robot.yaml";
  return sim::writeModelFile(m.model, m.p, m.rows, folder, "Written by orbcal " ORBCAL_VERSION " from Python", name, robot);
}

/// What `orbcal calibrate` writes into a folder: model.yaml with robot.yaml, and for programs outside
/// orbcal robot_calibrated.urdf, frames.yaml and effects.yaml (workflow::writeModelAndExports).
std::string exportModel(const PyModel& m, const std::string& folder) {
  std::error_code ec;
  std::filesystem::create_directories(folder, ec);
  if (ec) throw sim::InputError(folder + ": cannot create the folder: " + ec.message());
  return workflow::writeModelAndExports({m.model, m.p}, m.rows, folder, "Written by orbcal " ORBCAL_VERSION " from Python");
}

std::vector<std::string> effectSpecs(const PyModel& pm) {
  std::vector<std::string> specs;
  for (const sim::Effect& e : pm.model.effects) specs.push_back(sim::formatEffect(e));
  return specs;
}

py::dict parameterDict(const PyModel& m) {
  py::dict out;
  for (const sim::ParameterRow& r : m.rows) {
    out[py::str(r.name)] = py::dict(py::arg("value") = r.value, py::arg("sigma") = r.sigma, py::arg("unit") = r.unit,
                                    py::arg("effect") = r.effect, py::arg("held") = r.held);
  }
  return out;
}

/// Per driving variable of each effect with a fitted range: how far the samples leave it.
py::list rangeRecords(const std::vector<sim::RangeExcess>& excess) {
  py::list out;
  for (const sim::RangeExcess& x : excess) {
    out.append(py::dict(py::arg("effect") = x.effect, py::arg("variable") = x.variable.column, py::arg("unit") = x.variable.unit,
                        py::arg("lo") = x.range.lo, py::arg("hi") = x.range.hi, py::arg("samples_outside") = x.outside,
                        py::arg("max_excess") = x.max_excess, py::arg("excess") = x.excess));
  }
  return out;
}

/// The model's alternatives predicting the data (evaluation.json's `alternatives`, SI).
py::list alternativeRecords(const std::vector<workflow::AlternativePrediction>& alternatives) {
  py::list out;
  for (const workflow::AlternativePrediction& a : alternatives) {
    out.append(py::dict(py::arg("model") = a.path, py::arg("effects") = a.effects, py::arg("position_rms_m") = a.residuals.position_rms_m,
                        py::arg("samples_beyond") = a.beyond, py::arg("apart_beyond_rms_m") = a.beyond_rms_m,
                        py::arg("apart_beyond_max_m") = a.beyond_max_m, py::arg("apart_within_rms_m") = a.within_rms_m,
                        py::arg("divergence_m") = a.divergence_m));
  }
  return out;
}

}  // namespace

/// The fit's statistics: residuals at the fit, chi-square and its degrees of freedom, the noise used.
py::dict fitStatistics(const calib::Fit& fit) {
  py::dict d = residualDict(fit.residuals);
  d["chi2"] = fit.chi2;
  d["dof"] = fit.dof;
  d["effective_parameters"] = fit.effective_parameters;
  d["noise"] = py::dict(py::arg("position_m") = fit.noise.sigma_position_m, py::arg("rotation_rad") = fit.noise.sigma_rotation_rad,
                        py::arg("joint_rad") = fit.noise.joint_noise_sigma_rad);
  d["noise_estimated"] = fit.noise_estimated;
  std::vector<std::string> weak;
  for (int i : fit.weak) weak.push_back(fit.model.layout.param(i).name);
  d["weak"] = weak;
  return d;
}

py::list parameterRecords(const std::vector<sim::ParameterRow>& rows) {
  py::list out;
  for (const sim::ParameterRow& r : rows) {
    out.append(py::dict(py::arg("name") = r.name, py::arg("effect") = r.effect, py::arg("unit") = r.unit, py::arg("value") = r.value,
                        py::arg("sigma") = r.sigma, py::arg("held") = r.held));
  }
  return out;
}

py::dict residualDict(const calib::ResidualStats& s) {
  return py::dict(py::arg("samples") = s.samples, py::arg("position_mean_m") = s.position_mean_m,
                  py::arg("position_rms_m") = s.position_rms_m, py::arg("position_max_m") = s.position_max_m,
                  py::arg("rotation_rms_rad") = s.rotation_rms_rad, py::arg("rotation_max_rad") = s.rotation_max_rad);
}

namespace {

/// orbcal.evaluate: workflow::runEvaluate on the model and data in memory (a loaded model's alternatives
/// compared), its result as plain Python values.
py::dict evaluate(const PyModel& model, const sim::MeasuredData& data, const std::optional<std::string>& out) {
  const RunFolder folder(out, "evaluation");
  workflow::EvaluateResult r;
  {
    py::gil_scoped_release release;
    r = workflow::runEvaluate({model.model, model.p, model.alternatives}, model.source.empty() ? "(model in memory)" : model.source,
                              data, folder.path());
  }
  py::dict d = residualDict(r.fit.residuals);
  d["refitted"] = r.refitted;
  d["baseline"] = residualDict(r.baseline);
  d["warnings"] = r.warnings;
  d["beyond_range"] = rangeRecords(r.excess);
  d["alternatives"] = alternativeRecords(r.alternatives);
  d["report"] = readText(r.report_path);
  return d;
}

}  // namespace

void bindCalibrate(py::module_& m) {
  py::class_<PyModel>(m, "Model",
                      "A kinematic model: the geometry (DH rows with the identified errors folded in), the registration "
                      "frames, the effects with their parameters (SI), and every fitted parameter with its 1-sigma.")
      .def_property_readonly("robot", [](const PyModel& pm) { return pm.model.arm; }, "the model's arm (calibrated geometry)")
      .def_property_readonly("effects", &effectSpecs, "the effects' specs ('compliance:2', joints from 1)")
      .def_property_readonly("parameters", &parameterDict,
                             "every parameter by name: {value, sigma (NaN: not known), unit (SI), effect (its block), held}")
      .def_property_readonly("parameter_names", [](const PyModel& pm) {
            std::vector<std::string> n;
            for (const sim::ParameterRow& r : pm.rows) n.push_back(r.name);
            return n;
          }, "parameter names, in the layout's order")
      .def_property_readonly("parameter_units", [](const PyModel& pm) {
            std::vector<std::string> u;
            for (const sim::ParameterRow& r : pm.rows) u.push_back(r.unit);
            return u;
          }, "their SI units")
      .def_property_readonly("values", [](const PyModel& pm) {
            Eigen::VectorXd v(static_cast<Eigen::Index>(pm.rows.size()));
            for (std::size_t i = 0; i < pm.rows.size(); ++i) v[static_cast<Eigen::Index>(i)] = pm.rows[i].value;
            return v;
          }, "parameter values (SI), in the layout's order")
      .def_property_readonly("sigmas", [](const PyModel& pm) {
            Eigen::VectorXd v(static_cast<Eigen::Index>(pm.rows.size()));
            for (std::size_t i = 0; i < pm.rows.size(); ++i) v[static_cast<Eigen::Index>(i)] = pm.rows[i].sigma;
            return v;
          }, "their 1-sigma (SI; NaN where not known, 0 where held)")
      .def_property_readonly("source", [](const PyModel& pm) { return pm.source.empty() ? py::object(py::none()) : py::object(py::str(pm.source)); },
                             "the model file it was read from (load_model) or written to (calibrate's out); None: only in memory")
      .def_readonly("alternatives", &PyModel::alternatives,
                    "the model files of diagnose's confounded alternatives a loaded model file lists (alternatives:), which "
                    "evaluate compares with it")
      .def_readonly("statistics", &PyModel::statistics,
                    "of the fit that made it: residuals (samples, position_mean_m, position_rms_m, position_max_m, "
                    "rotation_rms_rad, rotation_max_rad), chi2, dof, effective_parameters, noise, noise_estimated, weak; empty for a loaded or true model")
      .def("to_records", [](const PyModel& pm) { return parameterRecords(pm.rows); },
           "One dict per parameter (name, effect, unit, value, sigma, held; SI): pandas.DataFrame(model.to_records())")
      .def("as_dict", [](const PyModel& pm) {
            return py::dict(py::arg("robot") = pm.model.arm.name, py::arg("effects") = effectSpecs(pm),
                            py::arg("parameters") = parameterRecords(pm.rows), py::arg("statistics") = pm.statistics);
          }, "robot (name), effects (specs), parameters (records) and statistics as plain Python values")
      .def("save", &saveModel, py::arg("path"),
           "Writes the model file (format orbcal-model-2, as orbcal calibrate writes model.yaml) and its robot file beside "
           "it (robot.yaml for model.yaml, else NAME.robot.yaml), each atomically. Returns the model file's path.")
      .def("export", &exportModel, py::arg("folder"),
           "Writes into `folder` (created if missing) what orbcal calibrate writes: model.yaml with robot.yaml, and for "
           "programs outside orbcal robot_calibrated.urdf (the calibrated chain), frames.yaml (the registration frames) "
           "and effects.yaml (the effects with their formulas; docs/export.md), each atomically. Returns model.yaml's path.")
      .def("__repr__", [](const PyModel& pm) {
        return "<orbcal.Model of " + pm.model.arm.name + ": " + std::to_string(pm.rows.size()) + " parameters, " +
               std::to_string(pm.model.effects.size()) + " effect(s)>";
      });

  m.def("evaluate", &evaluate, py::arg("model"), py::arg("data"), py::kw_only(), py::arg("out") = py::none(),
        "Predicts `data` with `model` as `orbcal evaluate` does (the same code): every geometric and effect parameter is "
        "the model's, only the frames the data calls per_session are refitted. Returns a dict: the prediction errors' "
        "statistics (samples, position_mean_m, position_rms_m, position_max_m, rotation_rms_rad, rotation_max_rad), "
        "refitted (parameters fitted to the data), baseline (the same statistics of the data's nominal arm with every "
        "registration frame fitted to it, as evaluation.json's 'baseline'), warnings (joint readings past a limit, effects "
        "applied beyond their fitted ranges; one line each, as the command line prints them), beyond_range (per driving "
        "variable of each effect with a fitted range, model.yaml's range:: effect, variable, unit, the range lo and hi in "
        "its display unit, samples_outside, max_excess and each sample's excess, 0 inside), alternatives (for a model file "
        "listing diagnose's confounded alternatives: each one's model file, effects, position_rms_m, samples_beyond, "
        "apart_beyond_rms_m, apart_beyond_max_m, apart_within_rms_m and divergence_m per sample: how far its predicted "
        "positions lie from the model's) and report (evaluation.md's text). out: a folder to write what the command line "
        "writes (evaluation.md, report.html, evaluation.json, residuals.csv); None: nothing is kept. The report names a "
        "loaded model by its file, any other as '(model in memory)'.");

  m.def(
      "load_model",
      [](const std::string& path) {
        const sim::LoadedModel lm = sim::loadModelFile(path);
        return PyModel{lm.model, lm.p, exactRows(lm.model, lm.p), py::dict(), path, lm.alternatives};
      },
      py::arg("path"),
      "Reads a model file (model.yaml of orbcal calibrate or diagnose, a simulation's truth/model.yaml), with the "
      "alternatives it lists (diagnose's alternativeN.yaml), which evaluate compares.");
}

}  // namespace orbcal::python
