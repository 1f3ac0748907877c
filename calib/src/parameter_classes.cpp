#include "orbcal/calib/parameter_classes.hpp"

#include <algorithm>
#include <stdexcept>

#include "orbcal/calib/estimators.hpp"

namespace orbcal::calib {

const char* paramClassName(ParamClass c) {
  switch (c) {
    case ParamClass::kIndependent: return "independent";
    case ParamClass::kRelative: return "relative";
    case ParamClass::kIneffective: return "ineffective";
  }
  return "?";
}

ParameterClasses classifyParameters(const Eigen::MatrixXd& J, const std::vector<std::string>& names,
                                    const Eigen::VectorXd& typical) {
  const int n = static_cast<int>(J.cols());
  if (static_cast<int>(names.size()) != n) throw std::invalid_argument("classifyParameters: names and columns differ");
  ParameterClasses out;
  out.names = names;
  out.classes.assign(static_cast<std::size_t>(n), ParamClass::kIndependent);
  out.group.assign(static_cast<std::size_t>(n), -1);
  // Zero the ineffective columns exactly, so that the column scaling of the SVD leaves them zero.
  Eigen::MatrixXd A = J;
  std::vector<int> zero = sim::ineffectiveColumns(J, typical);
  for (int c : zero) A.col(c).setZero();
  const sim::IdentifiabilityReport report = sim::analyzeJacobian(A, names, 0);
  out.rank = report.rank;
  for (const sim::Redundancy& red : report.redundancies) {
    // A group of one is a column the others do not need to explain: zero to the rank tolerance.
    if (red.params.size() == 1) {
      zero.push_back(red.params[0]);
      continue;
    }
    for (int p : red.params) out.group[static_cast<std::size_t>(p)] = static_cast<int>(out.groups.size());
    out.groups.push_back(red);
  }
  std::sort(zero.begin(), zero.end());
  zero.erase(std::unique(zero.begin(), zero.end()), zero.end());
  for (int p : zero) out.classes[static_cast<std::size_t>(p)] = ParamClass::kIneffective;
  for (int p = 0; p < n; ++p) {
    if (out.group[static_cast<std::size_t>(p)] >= 0) out.classes[static_cast<std::size_t>(p)] = ParamClass::kRelative;
    switch (out.classes[static_cast<std::size_t>(p)]) {
      case ParamClass::kIneffective: out.ineffective.push_back(p); break;
      case ParamClass::kRelative: out.relative.push_back(p); break;
      case ParamClass::kIndependent: out.independent.push_back(p); break;
    }
  }
  for (int p : zero) A.col(p).setZero();
  out.held = sim::numericalRank(A, typical, zero).held;
  for (int p = 0; p < n; ++p) {
    if (!std::binary_search(out.held.begin(), out.held.end(), p)) out.minimal.push_back(p);
  }
  return out;
}

ParameterClasses classifyParameters(const MeasurementModel& model, const Eigen::VectorXd& y) {
  std::vector<std::string> names;
  for (int i = 0; i < model.numParams(); ++i) names.push_back(model.paramName(i));
  return classifyParameters(whitenedJacobian(model, y), names, model.layout().typical());
}

std::string ParameterClasses::describe() const {
  std::string out;
  const auto list = [&](const char* what, const std::vector<int>& idx) {
    out += std::string(what) + " (" + std::to_string(idx.size()) + "):";
    for (int p : idx) out += " " + names[static_cast<std::size_t>(p)];
    out += "\n";
  };
  list("ineffective", ineffective);
  list("relative", relative);
  for (const sim::Redundancy& g : groups) out += "  " + g.describe() + "\n";
  list("independent", independent);
  list("minimal identifiable set", minimal);
  return out;
}

std::string ParameterClasses::table() const {
  std::string out = "| parameter | class | observable only as |\n|---|---|---|\n";
  for (std::size_t p = 0; p < names.size(); ++p) {
    out += "| " + names[p] + " | " + paramClassName(classes[p]) + " | ";
    if (group[p] >= 0) out += groups[static_cast<std::size_t>(group[p])].describe();
    out += " |\n";
  }
  out += "\nRank " + std::to_string(rank) + " of " + std::to_string(names.size()) + ". Minimal identifiable set (" +
         std::to_string(minimal.size()) + "):";
  for (int p : minimal) out += " " + names[static_cast<std::size_t>(p)];
  return out + "\n";
}

}  // namespace orbcal::calib
