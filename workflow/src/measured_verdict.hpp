#pragma once
// The verdict lines of a measured-data calibration (measured.cpp): the report's first lines, the
// structure its held-out residuals leave, and the model files' header. Not part of the library's interface.
#include <string>
#include <vector>

#include "orbcal/calib/lack_of_fit.hpp"
#include "orbcal/workflow/measured.hpp"

namespace orbcal::workflow::measured_detail {

/// Diagnose's lack-of-fit tests (calib/lack_of_fit.hpp) on the calibrated model's held-out residuals:
/// the global test against the noise where it is given, and the extended variable family. Where they
/// flag something, the sentence that says structure is left and which command names it (fills `lof`).
std::string structureLeft(const MeasuredCalibrateResult& r, const sim::MeasuredData& data, const std::string& description,
                          const std::vector<calib::MarkerObservation>& held, const std::vector<Eigen::VectorXd>& after,
                          calib::LackOfFit& lof);

/// The comment at the top of the model files a calibration writes: what wrote them, from what.
std::string modelHeader(const sim::MeasuredData& data, const MeasuredCalibrateOptions& o);

/// The joint readings of `data` accepted past a limit (sim::nearLimitWarnings), one line per joint:
/// calibrate's and evaluate's warnings.
std::vector<std::string> readingWarnings(const sim::MeasuredData& data);

/// Per parameter of a layout of `n`, the other members of its unidentifiable combination (`groups`),
/// empty where it is determined on its own: the parameter table's and the registration frames' words.
std::vector<std::string> combinationPartners(const std::vector<sim::Redundancy>& groups, int n);

/// The report's first lines: each reason the calibration is not accepted, or that it is, and whether
/// model.yaml was written.
std::string verdictLines(const MeasuredCalibrateResult& r, bool write_model);

}  // namespace orbcal::workflow::measured_detail
