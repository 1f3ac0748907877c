// orbcal.render_dataset and orbcal.run_study: a rendered calibration dataset (render/dataset_writer.hpp), as
// `orbcal render` writes it, and a study run here (workflow/study.hpp), as `orbcal study run` runs it.
#include "bindings.hpp"
#include "orbcal/render/dataset_writer.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/cores.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/workflow/study.hpp"

namespace orbcal::python {

std::function<void(int done, int total)> pythonProgress(const py::object& progress) {
  if (progress.is_none()) return {};
  // A handle (no reference counting): the callee may copy the callback without the GIL, and the callable
  // outlives the call (the caller's argument).
  return [callable = py::handle(progress)](int done, int total) {
    py::gil_scoped_acquire gil;
    callable(done, total);
  };
}

namespace {

py::dict reportDict(const render::DatasetRunReport& r) {
  return py::dict(py::arg("rendered") = r.rendered, py::arg("skipped") = r.skipped, py::arg("first_sample") = r.first_sample,
                  py::arg("end_sample") = r.end_sample, py::arg("resumed") = r.resumed, py::arg("msaa_samples") = r.msaa_samples,
                  py::arg("plan_seconds") = r.plan_seconds, py::arg("render_seconds") = r.render_seconds,
                  py::arg("warnings") = r.warnings);
}

/// `orbcal study run` without the command line: the study's folder prepared and locked, the tasks not done
/// run `jobs` at once (each a run of the orbcal program built with this module), then merged. The option
/// names and values of the study are checked by the program as each task starts (a bad one fails its tasks).
py::dict runStudy(const std::string& study_file, const std::string& dir, std::optional<int> jobs, bool merge, const py::object& progress) {
  const int n = static_cast<int>(workflow::expandStudy(workflow::prepareStudy(study_file, dir)).size());
  const sim::FolderLock lock(dir, "orbcal.run_study");
  const std::vector<int> todo = workflow::tasksToRun(dir, n);
  workflow::ProgressFn fn;
  if (!progress.is_none()) {
    fn = [callable = py::handle(progress)](const std::string& stage, int done, int total) {
      py::gil_scoped_acquire gil;
      callable(stage, done, total);
    };
  }
  std::vector<std::string> failures;
  {
    py::gil_scoped_release release;
    failures = workflow::runStudyTasks(dir, n, todo, jobs.value_or(sim::availableCores()), ORBCAL_PROGRAM, fn);
  }
  if (!failures.empty()) {
    throw sim::InputError(std::to_string(failures.size()) + " of " + std::to_string(n) + " tasks failed, the first: " + failures.front() +
                          "; call run_study again to run them again");
  }
  py::dict r(py::arg("folder") = dir, py::arg("tasks") = n, py::arg("ran") = todo.size(), py::arg("report") = py::none());
  if (merge) r["report"] = workflow::mergeStudy(dir, "", false).report_path;
  return r;
}

}  // namespace

void bindWorkflow(py::module_& m) {
  m.def(
      "render_dataset",
      [](const std::string& scene, int count, const std::string& out, const std::optional<std::string>& errors, std::uint64_t seed,
         const std::string& robot, const std::optional<std::string>& base_link, const std::optional<std::string>& tip_link,
         double joint_noise_rad, bool force, const std::optional<std::string>& configs, const std::optional<std::string>& profile,
         const py::object& progress) {
        if (configs && count != 0) throw sim::InputError("count: not with configs (their rows are the samples; give 0)");
        render::DatasetJob job;
        job.configs = configs.value_or("");
        job.profile = profile.value_or("");
        job.robot = robot;
        job.base_link = base_link.value_or("");
        job.tip_link = tip_link.value_or("");
        job.scene = scene;
        job.count = count;
        job.out = out;
        job.errors.name = errors.value_or("zero");
        job.errors.seed = seed;
        job.configuration_seed = job.noise_seed = job.render_seed = seed;
        job.joint_noise_sigma_rad = joint_noise_rad;
        job.force = force;
        const render::DatasetProgress callback = pythonProgress(progress);
        render::DatasetRunReport r;
        {
          py::gil_scoped_release release;
          r = render::renderDataset(job, callback);
        }
        return reportDict(r);
      },
      py::arg("scene"), py::arg("count"), py::arg("out"), py::kw_only(), py::arg("errors") = py::none(), py::arg("seed") = 1,
      py::arg("robot") = sim::kDefaultRobot, py::arg("base_link") = py::none(), py::arg("tip_link") = py::none(),
      py::arg("joint_noise_rad") = 0.01 * sim::kDegToRad, py::arg("force") = false, py::arg("configs") = py::none(),
      py::arg("profile") = py::none(), py::arg("progress") = py::none(),
      "Renders a calibration dataset into the folder `out` as `orbcal render` does: `count` configurations of `robot` "
      "(default the built-in SSRMS), the true arm (nominal + `errors`: None for none, 'table3', 'random' drawn with `seed`, "
      "or an error-set file) at the noisy plant joints (joint_noise_rad, 1 sigma), and the eye-in-hand camera's images "
      "of the board of `scene` ('builtin:default_scene.yaml' or a scene file). `configs`: a configurations CSV rendered "
      "instead of `count` planned ones (count 0): joints, or flange poses (flange_x_m .. flange_qz; the folder's images.yaml "
      "then calibrates with calibrate_images); `profile`: a camera_profile.yaml applied to every image. A rerun with the same inputs resumes. "
      "progress(done, total) is called as images are written. Returns what was rendered.");

  m.def("run_study", &runStudy, py::arg("study_file"), py::arg("out"), py::kw_only(), py::arg("jobs") = py::none(),
        py::arg("merge") = true, py::arg("progress") = py::none(),
        "Runs every task of a study file (YAML, format orbcal-study-1) here, as `orbcal study run STUDY -o OUT` does: "
        "`jobs` at once (default: the cores this process may use), each task a run of the orbcal program into "
        "OUT/shards/task-N, then the merge into OUT/merged (without figures) unless merge=False. A rerun resumes: only "
        "missing and failed tasks run. progress(stage, done, total) is called as tasks finish. Returns {folder, tasks, "
        "ran, report}. Raises orbcal.Error naming the study file and the key for a bad study, and the failed tasks "
        "with their logs.");
}

}  // namespace orbcal::python
