// The `_orbcal` extension module: the exception type, then each topic's bindings.
#include "bindings.hpp"
#include "orbcal/sim/config.hpp"

PYBIND11_MODULE(_orbcal, m) {
  m.doc() = "orbcal's libraries from Python (compiled part; import `orbcal`, not `_orbcal`). SI units: m, rad, N m, "
            "degC, s; numpy arrays in and out.";
  // Bad input (a file, a key, a value outside its physical range): orbcal's one-line message naming the file
  // and the key, as the command line prints it.
  pybind11::register_exception<orbcal::sim::InputError>(m, "Error", PyExc_RuntimeError);
  m.attr("version") = ORBCAL_VERSION;
  orbcal::python::bindRobot(m);
  orbcal::python::bindMeasurements(m);
  orbcal::python::bindCalibrate(m);
  orbcal::python::bindDiagnose(m);
  orbcal::python::bindWorkflow(m);
}
