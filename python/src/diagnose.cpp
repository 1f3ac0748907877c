// orbcal.diagnose and the Diagnosis class: what the geometry + registration model leaves in the residuals of
// measured data, which cause of the effect catalog explains it, and how much better the extended model
// predicts held-out data (calib/diagnose.hpp), with diagnosis.json as `orbcal diagnose` writes it.
#include "bindings.hpp"
#include "orbcal/calib/diagnose.hpp"
#include "orbcal/workflow/diagnose.hpp"
#include "orbcal/workflow/measured.hpp"

namespace orbcal::python {

namespace {

using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// Position residuals (N x 3, m) of every sample.
RowMatrix positionRows(const std::vector<Eigen::VectorXd>& r) {
  RowMatrix out(static_cast<Eigen::Index>(r.size()), 3);
  for (std::size_t k = 0; k < r.size(); ++k) out.row(static_cast<Eigen::Index>(k)) = r[k].head<3>().transpose();
  return out;
}

/// A diagnosis and its diagnosis.json, parsed once for the keys Python reads from it.
struct PyDiagnosis {
  calib::Diagnosis d;
  calib::CalibratedModel model;  ///< the selected model as diagnose writes model.yaml (with its effects' fitted ranges)
  std::string json;
  py::object parsed;
};

/// The selected effects' parameters, one flat dict each.
py::list selectedRecords(const PyDiagnosis& p) {
  py::list out;
  for (const py::handle effect : p.parsed["selected"]) {
    for (const py::handle param : effect["parameters"]) {
      py::dict row(py::arg("effect") = effect["effect"], py::arg("joints") = effect["joints"]);
      for (const char* key : {"name", "value", "sigma", "unit"}) row[key == std::string("name") ? "parameter" : key] = param[key];
      out.append(row);
    }
  }
  return out;
}

}  // namespace

void bindDiagnose(py::module_& m) {
  py::class_<PyDiagnosis>(m, "Diagnosis",
                          "The outcome of orbcal.diagnose: the verdict, the selected effects with their parameters, the "
                          "confounded sets, the held-out statistics and the residuals for figures. SI units.")
      .def_property_readonly("verdict", [](const PyDiagnosis& p) { return py::object(p.parsed["verdict"]); },
                             "'clean' (the residuals are noise), 'effects' (the selected effects explain them) or "
                             "'unexplained' (something is left above the noise)")
      .def_property_readonly("sentence", [](const PyDiagnosis& p) { return p.d.verdict; }, "the verdict in one sentence a user can act on")
      .def_property_readonly("selected", [](const PyDiagnosis& p) { return py::object(p.parsed["selected"]); },
                             "the selected effects as diagnosis.json lists them: dicts with effect, joints (from 1) and "
                             "parameters (name, value, sigma, unit; SI)")
      .def_property_readonly("confounded", [](const PyDiagnosis& p) { return py::object(p.parsed["confounded"]); },
                             "sets of causes this data cannot tell apart (lists of {effect, joints}; 'geometry' where the "
                             "geometric and registration parameters absorb one)")
      .def_property_readonly("alternatives", [](const PyDiagnosis& p) { return py::object(p.parsed["alternatives"]); },
                             "the models the data cannot tell from the selection (each the selection with one effect replaced "
                             "by another member of its confounded set, fitted on all the data), as diagnosis.json lists them: "
                             "dicts with model (the file orbcal diagnose writes, alternativeN.yaml), effects ({effect, joints}) "
                             "and fit_position_rms_mm")
      .def_property_readonly("heldout", [](const PyDiagnosis& p) {
            return py::dict(py::arg("base") = residualDict(p.d.heldout.base), py::arg("selected") = residualDict(p.d.heldout.selected),
                            py::arg("noise_position_rms_m") = p.d.heldout.noise_position_rms_m);
          }, "cross-validated held-out residual statistics of geometry + registration ('base') and of the selected model, "
             "and the 3-D position RMS the noise alone gives; m and rad")
      .def_property_readonly("residual_base", [](const PyDiagnosis& p) { return positionRows(p.d.residual_base); },
                             "held-out position residual per sample (N x 3, m) of geometry + registration")
      .def_property_readonly("residual_selected", [](const PyDiagnosis& p) { return positionRows(p.d.residual_selected); },
                             "held-out position residual per sample (N x 3, m) of the selected model")
      .def_property_readonly("model", [](const PyDiagnosis& p) {
            return PyModel{p.model.model, p.model.p, workflow::parameterRows(p.d.fit), py::dict(), "", {}};
          }, "the selected model fitted to all the data (what orbcal diagnose writes as model.yaml, each effect with the range "
             "of the data it was fitted on)")
      .def_property_readonly("seconds", [](const PyDiagnosis& p) { return p.d.seconds; }, "wall time of the diagnosis (s)")
      .def("to_json", [](const PyDiagnosis& p) { return p.json; }, "diagnosis.json as orbcal diagnose writes it (text)")
      .def("as_dict", [](const PyDiagnosis& p) { return py::module_::import("json").attr("loads")(p.json); },
           "diagnosis.json as plain Python values (a fresh copy)")
      .def("to_records", &selectedRecords,
           "One dict per parameter of the selected effects (effect, joints (from 1), parameter, value, sigma, unit; SI): "
           "pandas.DataFrame(diagnosis.to_records())")
      .def("__repr__", [](const PyDiagnosis& p) { return "<orbcal.Diagnosis: " + p.d.verdict + ">"; });

  m.def(
      "diagnose",
      [](const sim::MeasuredData& data, int folds, std::uint64_t seed, double alpha, double penalty, int max_effects,
         int max_order, bool empirical, std::optional<double> joint_noise_rad, int noise_observations, int selection_observations,
         const py::object& progress) {
        calib::DiagnoseOptions o;
        o.folds = folds;
        o.seed = seed;
        o.alpha = alpha;
        o.penalty_per_param = penalty;
        o.max_effects = max_effects;
        o.max_order = max_order;
        o.empirical = empirical;
        o.joint_noise_sigma_rad = joint_noise_rad;
        if (noise_observations < 0) throw py::value_error("diagnose: noise_observations must be >= 0 (0: all)");
        o.noise_observations = noise_observations;
        if (selection_observations < 0) throw py::value_error("diagnose: selection_observations must be >= 0 (0: all)");
        o.selection_observations = selection_observations;
        o.progress = pythonProgress(progress);
        PyDiagnosis p;
        {
          py::gil_scoped_release release;
          const std::vector<calib::MarkerObservation> obs = calib::observationsFrom(data, data.has_torque || !data.arm.masses.empty());
          p.d = calib::diagnose(data, obs, o);
          p.model = calib::calibratedModel(p.d.fit, obs);
        }
        p.json = workflow::diagnosisJson(p.d);
        p.parsed = py::module_::import("json").attr("loads")(p.json);
        return p;
      },
      py::arg("data"), py::kw_only(), py::arg("folds") = 5, py::arg("seed") = 1, py::arg("alpha") = 0.01, py::arg("penalty") = 2.0,
      py::arg("max_effects") = 4, py::arg("max_order") = 6, py::arg("empirical") = true, py::arg("joint_noise_rad") = py::none(),
      py::arg("noise_observations") = calib::DiagnoseOptions{}.noise_observations,
      py::arg("selection_observations") = calib::DiagnoseOptions{}.selection_observations, py::arg("progress") = py::none(),
      "Diagnoses measured data as `orbcal diagnose` does: folds-fold cross-validation by configuration (seeded), each "
      "catalog cause tested (Holm at family-wise error alpha) and added while its held-out gain exceeds `penalty` per "
      "parameter, at most max_effects; empirical corrections where no cause fits. Torques come from the data, else the "
      "robot's masses. joint_noise_rad: joint readings vs true angles (1 sigma; default estimated). noise_observations: "
      "where the noise is estimated, on a seeded random subset of this many observations where there are more (0: all; "
      "never fewer than the flexible model needs), as orbcal diagnose --noise-observations. selection_observations: the "
      "effects selected on a seeded random subset of this many observations where there are more (0: all), the selected "
      "model then fitted and judged on all, as orbcal diagnose --selection-observations. progress: called (done, "
      "total) as each phase starts, before phase done of orbcal.diagnose_phases, then (total, total) at the end. Returns a "
      "Diagnosis.");
  py::list phases;
  for (const char* name : calib::kDiagnosePhases) phases.append(name);
  m.attr("diagnose_phases") = py::tuple(phases);
}

}  // namespace orbcal::python
