// orbcal.calibrate_images: `orbcal calibrate DESC.yaml` on a description of images (workflow::runImageCalibrate:
// detection, closed form, corner fit, every level with joint readings, cross-validation, refusals, frames.yaml,
// views.csv, report.md), its result as plain Python values. Nothing is re-assembled here.
#include <algorithm>
#include <cmath>
#include <optional>

#include "bindings.hpp"
#include "orbcal/calib/levels.hpp"
#include "orbcal/workflow/measured_images.hpp"

namespace orbcal::python {

namespace {

py::list geometryRecords(const workflow::ImageCalibrateResult& r) {
  py::list out;
  if (!r.robot) return out;
  const sim::ParamLayout& L = r.robot->start.layout;
  const sim::ParamBlock& g = L.block(L.find(sim::BlockKind::kGeometry));
  for (int i = g.offset; i < g.offset + g.size(); ++i) {
    const bool held = std::binary_search(r.robot->estimate.held.begin(), r.robot->estimate.held.end(), i);
    const double fit = r.robot->estimate.covariance.rows() > i ? std::sqrt(std::max(0.0, r.robot->estimate.covariance(i, i))) : NAN;
    out.append(py::dict(py::arg("name") = L.param(i).name, py::arg("unit") = L.param(i).unit, py::arg("value") = r.robot->p[i],
                        py::arg("sigma") = held ? 0.0 : fit, py::arg("sigma_jackknife") = held ? 0.0 : r.robot_sigma[i],
                        py::arg("held") = held));
  }
  return out;
}

py::dict imageDict(const workflow::ImageCalibrateResult& r, const std::string& report) {
  py::list tried;
  for (const calib::CornerLevelCrossValidation& t : r.tried) {
    tried.append(py::dict(py::arg("level") = calib::levelName(t.level), py::arg("heldout_rms_m") = t.heldout_rms_m,
                          py::arg("t") = t.verdict.gain.t, py::arg("p_value") = t.verdict.gain.p_value,
                          py::arg("accepted") = t.verdict.refusal.empty()));
  }
  py::object lens = py::none();  // the lens check (ImageCalibrateResult::lens_*), when it ran
  if (r.lens_checked) {
    lens = py::dict(py::arg("taken") = r.lens_taken, py::arg("k1_k2_added") = Eigen::VectorXd(r.lens_k),
                    py::arg("sigma") = Eigen::VectorXd(r.lens_sigma), py::arg("shift_at_image_corner_px") = r.lens_shift_px,
                    py::arg("stated_heldout_rms_px") = r.lens_stated_heldout_rms_px,
                    py::arg("stated_heldout_rms_m") = r.lens_stated_heldout_rms_mm * 1e-3, py::arg("t") = r.lens_verdict.gain.t,
                    py::arg("p_value") = r.lens_verdict.gain.p_value);
  }
  return py::dict(py::arg("accepted") = r.refusals.empty(), py::arg("refusals") = r.refusals, py::arg("warnings") = r.warnings,
                  py::arg("setup") = sim::handEyeSetupName(r.setup), py::arg("views") = r.views.size(), py::arg("used") = r.used,
                  py::arg("configurations") = r.configurations, py::arg("level") = calib::levelName(r.level),
                  py::arg("level_reason") = r.level_sentence, py::arg("levels_tried") = tried,
                  py::arg("hand_T_eye") = Eigen::Matrix4d(r.hand_T_eye.matrix()), py::arg("base_T_other") = Eigen::Matrix4d(r.base_T_other.matrix()),
                  py::arg("hand_sigma") = Eigen::VectorXd(r.hand_sigma), py::arg("base_sigma") = Eigen::VectorXd(r.base_sigma),
                  py::arg("cross_validated") = r.cross_validated, py::arg("heldout_rms_px") = r.heldout_rms_px,
                  py::arg("heldout_rms_m") = r.heldout_rms_mm * 1e-3, py::arg("frames_heldout_rms_m") = r.frames_heldout_rms_mm * 1e-3,
                  py::arg("fitted_rms_px") = r.fitted_rms_px, py::arg("detection_sigma_px") = r.detection_sigma_px,
                  py::arg("parameters") = geometryRecords(r), py::arg("lens") = lens, py::arg("report") = report);
}

}  // namespace

void bindImages(py::module_& m) {
  m.def(
      "calibrate_images",
      [](const std::string& description, const std::string& level, bool accept_worse, const std::optional<std::string>& out) {
        const RunFolder folder(out, "calibration");
        workflow::MeasuredCalibrateOptions o;
        o.description = description;
        o.level = calib::parseLevel(level, "level");
        o.accept_worse = accept_worse;
        o.out = folder.path();
        o.plots = false;
        workflow::ImageCalibrateResult r;
        {
          py::gil_scoped_release release;
          r = workflow::runImageCalibrate(o);
        }
        return imageDict(r, readText(r.report_path));
      },
      py::arg("description"), py::kw_only(), py::arg("level") = "auto", py::arg("accept_worse") = false, py::arg("out") = py::none(),
      "Calibrates a description of images (`images:`; docs/real-images.md) as `orbcal calibrate DESC.yaml` does (the same "
      "code): detection, the closed-form start, the corner fit of the frames and, with joint readings (robot + joints), the "
      "robot level `level` ('frames', 'offsets', 'map', 'full', a list, or 'auto'), judged by leave-one-configuration-out "
      "cross-validation. Returns a dict: accepted, refusals, level, level_reason, levels_tried (level, heldout_rms_m, t, "
      "p_value, accepted), hand_T_eye and base_T_other (4x4, m: flange_T_camera and base_T_board eye in hand, flange_T_board "
      "and base_T_camera eye to hand) with their jackknife 1-sigma ([x, y, z (m), rotation (rad)]), the cross-validated and "
      "fitted residuals, parameters (the robot level's geometric parameters: name, unit, value, sigma, sigma_jackknife, held; "
      "SI) and report (report.md's text). out: the folder to write frames.yaml, views.csv and report.md into; None: nothing "
      "is kept. A refused calibration is returned with accepted False (frames.yaml is written only when accepted or with "
      "accept_worse).");
}

}  // namespace orbcal::python
