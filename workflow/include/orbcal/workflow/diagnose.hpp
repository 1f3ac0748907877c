#pragma once
// `orbcal diagnose`: the diagnosis (calib/diagnose.hpp) of measured data or of an image dataset, and its
// outputs: report.md and report.html (verdict first), diagnosis.json, model.yaml (the selected model), figures.
#include <array>
#include <string>

#include "orbcal/calib/diagnose.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/workflow/callbacks.hpp"

namespace orbcal::workflow {

struct DiagnoseRunOptions {
  std::string input;  ///< a measurement description (.yaml) or an image dataset folder
  std::string out;    ///< default: diagnosis/ beside the input
  calib::DiagnoseOptions diagnose;
  bool plots = true;
  bool quiet = false;
  Callbacks callbacks;  ///< progress and figures (callbacks.hpp)
};

/// Image datasets: the camera effect `distortion` (lens distortion the scene's camera does not model),
/// tested on the detected corners with every image's own pose (so neither the arm's errors nor joint
/// noise can pose as a pattern within the images): the scene's camera against the scene's camera plus
/// (dk1, dk2, dp1, dp2) fitted with every image's pose re-optimized and the other intrinsics held, cross-validated
/// by image; named when the held-out corner error falls by more than the penalty for 4 parameters and
/// the F test of the fit is significant at the diagnosis's alpha.
struct DistortionCheck {
  bool tested = false, selected = false;
  double cv_gain = 0.0;        ///< held-out corner SSE decrease, in units of the detector's noise variance
  double lr = 0.0, p_value = 1.0;
  double sigma_px = 0.0;       ///< the detector's noise, with the distortion modelled
  double heldout_rms_without_px = 0.0, heldout_rms_with_px = 0.0;
  std::array<double, 4> dk{}, dk_sigma{};  ///< dk1, dk2, dp1, dp2 on all images, and 1-sigma
};

struct DiagnoseRunResult {
  calib::Diagnosis diagnosis;
  DistortionCheck distortion;
  std::string report_path, json_path, model_path;
};

DiagnoseRunResult runDiagnose(const DiagnoseRunOptions& o);

/// The detector's power (`orbcal diagnose-study`): N seeded simulated tracker datasets per catalog effect
/// (random joint; each parameter's magnitude uniform in [0.5, 2] x its typical value, random sign;
/// random geometric errors and frames) and N clean ones, each diagnosed.
struct StudyOptions {
  std::string robot = "builtin:iiwa7.yaml";  ///< with masses (compliance is drawn among loaded joints)
  std::string base_link, tip_link;           ///< a URDF robot's chain
  sim::RobotSource robotSource() const { return {robot, base_link, tip_link}; }
  int per_effect = 20;
  int clean = 20;
  int samples = 200;
  std::uint64_t seed = 1;
  /// Kinds drawn ("compliance/3": with that order).
  std::vector<std::string> effects{"compliance", "compliance/3", "cyclic", "scale", "backlash", "thermal",
                                   "drift",      "mount",        "coupling", "link_bending"};
  calib::DiagnoseOptions diagnose;
  bool quiet = false;
  /// Where the confusion table also goes (diagnose_study.csv and report.md, written as one folder whether
  /// the study finishes or not); empty: nowhere.
  std::string out;
  Callbacks callbacks;  ///< progress (callbacks.hpp)
};
struct StudyRow {
  std::string injected;   ///< effect name, or "clean"
  int datasets = 0;
  int named = 0;          ///< the injected effect named (with the right joint, where it has one)
  int wrong_joint = 0;    ///< the effect named, on another joint only
  int clean_verdict = 0;  ///< "clean"
  int other = 0;          ///< named only other effects
  int extra = 0;          ///< named the injected one plus others
  std::vector<std::string> misses;  ///< "scale:3 -> cyclic:3" for every dataset not named right
};
struct StudyResult {
  std::vector<StudyRow> rows;
  double seconds = 0.0;
};
StudyResult runDiagnoseStudy(const StudyOptions& o);
/// The confusion table (markdown).
std::string formatStudy(const StudyResult& r);
/// The confusion table as CSV: counts per injected effect and their rates (fractions of its datasets).
std::string formatStudyCsv(const StudyResult& r);

/// diagnosis.json (the machine-readable result).
std::string diagnosisJson(const calib::Diagnosis& d, const DistortionCheck& distortion = {});

}  // namespace orbcal::workflow
