// The `_orbcal` extension module: the exception types, then each topic's bindings.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "bindings.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/io.hpp"

namespace orbcal::python {

namespace {
py::handle refused;  // orbcal.Refused; the module holds the reference
}  // namespace

py::handle refusedType() { return refused; }

RunFolder::RunFolder(const std::optional<std::string>& given, const std::string& name) {
  if (given) {
    path_ = *given;
    return;
  }
  std::string pattern = (std::filesystem::temp_directory_path() / ("orbcal-" + name + "-XXXXXX")).string();
  if (!mkdtemp(pattern.data())) throw sim::InputError(pattern + ": cannot create a temporary folder");
  temporary_ = pattern;
  path_ = temporary_ + "/" + name;
}

RunFolder::~RunFolder() {
  std::error_code ec;  // nothing to do about a temporary folder that cannot be removed
  if (!temporary_.empty()) std::filesystem::remove_all(temporary_, ec);
}

std::string readText(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace orbcal::python

PYBIND11_MODULE(_orbcal, m) {
  m.doc() = "orbcal's libraries from Python (compiled part; import `orbcal`, not `_orbcal`). SI units: m, rad, N m, "
            "degC, s; numpy arrays in and out.";
  // Bad input (a file, a key, a value outside its physical range): orbcal's one-line message naming the file
  // and the key, as the command line prints it.
  const auto error = pybind11::register_exception<orbcal::sim::InputError>(m, "Error", PyExc_RuntimeError);
  // A calibration the command line refuses (exit 1): an Error whose .calibration says why.
  PyObject* refused = PyErr_NewExceptionWithDoc("orbcal.Refused",
                                                "A calibration not accepted (as `orbcal calibrate` refuses it, exit 1): its "
                                                ".calibration (an orbcal.Calibration) holds the reasons and the held-out numbers.",
                                                error.ptr(), nullptr);
  if (!refused) throw pybind11::error_already_set();
  m.add_object("Refused", pybind11::reinterpret_steal<pybind11::object>(refused));
  orbcal::python::refused = refused;  // the module holds it
  m.attr("version") = ORBCAL_VERSION;
  m.attr("__version__") = ORBCAL_VERSION;
  orbcal::python::bindRobot(m);
  orbcal::python::bindMeasurements(m);
  orbcal::python::bindCalibrate(m);
  orbcal::python::bindCalibration(m);
  orbcal::python::bindDiagnose(m);
  orbcal::python::bindWorkflow(m);
  orbcal::python::bindTwin(m);
  orbcal::python::bindImages(m);
}
