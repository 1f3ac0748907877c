#pragma once
// Where an evaluated model extrapolates (`orbcal evaluate`): the samples beyond the ranges its effects
// were fitted on, and how far the predictions of the alternatives the fitting data could not tell from
// it (diagnose's alternativeN.yaml) part from its own there.
#include <string>
#include <vector>

#include "orbcal/workflow/measured.hpp"

namespace orbcal::workflow::extrapolation {

/// Each of `alternatives` (model files) predicting `data` as evaluate predicts it with the model, compared
/// per sample with the model's prediction `model` (its residuals on `obs`); `excess` marks the samples
/// beyond the model's fitted ranges.
std::vector<AlternativePrediction> compareAlternatives(const std::vector<std::string>& alternatives, const sim::MeasuredData& data,
                                                       const std::vector<calib::MarkerObservation>& obs, const calib::FitOptions& fo,
                                                       const calib::Fit& model, const std::vector<sim::RangeExcess>& excess);
/// Whether sample i lies beyond some range of `excess`.
bool beyond(const std::vector<sim::RangeExcess>& excess, std::size_t i);
/// residuals.csv's extra columns: ",beyond_range,alternative1_mm,..." and sample i's cells: the variables
/// it leaves a range of, with the excess ("joint 4 torque +12.3 N m; ..."), and each alternative's divergence.
std::string csvHeader(const EvaluateResult& r);
std::string csvCells(const EvaluateResult& r, std::size_t i);
/// evaluation.md's section (empty when nothing leaves a range and there are no alternatives) and
/// evaluation.json's fields (", \"beyond_range\": [...], \"alternatives\": [...]").
std::string reportSection(const EvaluateResult& r);
std::string jsonFields(const EvaluateResult& r, const std::string& key);

}  // namespace orbcal::workflow::extrapolation
