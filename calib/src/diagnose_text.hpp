#pragma once
// What diagnose says in words (calib/src/diagnose_text.cpp), shared by its selection and its report.
#include <string>
#include <vector>

#include "orbcal/calib/diagnose.hpp"

namespace orbcal::calib {

/// The measurement that separates a confounded set: that of its first cause in catalog order, except
/// that thermal expansion and drift, both growing through a warm-up, part in a cool-down.
std::string separationAdvice(const std::vector<sim::Effect>& set);
/// The verdict: one paragraph a user can act on.
std::string verdictText(const Diagnosis& out);

}  // namespace orbcal::calib
