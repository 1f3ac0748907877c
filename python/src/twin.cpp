// orbcal.twin: real views of a board beside their rendered twins, what differs, the camera profile fitted
// from it (workflow/twin.hpp), with twin.json's content as `orbcal twin` writes it.
#include "bindings.hpp"
#include "orbcal/workflow/twin.hpp"

namespace orbcal::python {

void bindTwin(py::module_& m) {
  m.def(
      "twin",
      [](const std::string& description, const std::string& out, const std::optional<std::string>& profile, std::uint64_t seed) {
        workflow::TwinOptions o;
        o.description = description;
        o.out = out;
        o.profile = profile.value_or("");
        o.seed = seed;
        workflow::TwinResult r;
        {
          py::gil_scoped_release release;
          r = workflow::runTwin(o);
        }
        return py::module_::import("json").attr("loads")(readText(r.json_path));
      },
      py::arg("description"), py::arg("out"), py::arg("profile") = py::none(), py::kw_only(), py::arg("seed") = 1,
      "Renders the twin of every real view of a description of images (format orbcal-measurements-1 with images:) "
      "and compares real with rendered (and, with `profile`, a camera_profile.yaml, profiled) statistic by statistic, "
      "as `orbcal twin DESCRIPTION -o OUT [--profile PROFILE]` does; writes twin.json, camera_profile.yaml and the "
      "report into `out`. Returns twin.json's content as a dict: statistics (per key: real, rendered, profiled, each "
      "{value, sigma, views}; significant, profiled_within_30_percent) and effects (name, size, unit, statistic, detail). "
      "Raises orbcal.Error naming the file and the key for bad input.");
}

}  // namespace orbcal::python
