#pragma once
// `orbcal diagnose`: the diagnosis (calib/diagnose.hpp) of measured data or of an image dataset, and its
// outputs: report.md (verdict first), diagnosis.json, model.yaml (the selected model), figures.
#include <string>

#include "orbcal/calib/diagnose.hpp"

namespace orbcal::tools {

struct DiagnoseRunOptions {
  std::string input;  ///< a measurement description (.yaml) or an image dataset folder
  std::string out;    ///< default: diagnosis/ beside the input
  calib::DiagnoseOptions diagnose;
  bool plots = true;
  bool quiet = false;
};

struct DiagnoseRunResult {
  calib::Diagnosis diagnosis;
  std::string report_path, json_path, model_path;
};

DiagnoseRunResult runDiagnose(const DiagnoseRunOptions& o);

/// diagnosis.json (the machine-readable result).
std::string diagnosisJson(const calib::Diagnosis& d);

}  // namespace orbcal::tools
