// The held-out samples diagnose scores its models on: random folds and the extremes of driving variables.
#include "diagnose_folds.hpp"

#include <algorithm>
#include <cmath>
#include <future>
#include <limits>
#include <numeric>

#include "orbcal/calib/dense_kernels.hpp"
#include "stacked_system.hpp"
#include "orbcal/calib/heldout.hpp"
#include "orbcal/sim/csv.hpp"

namespace orbcal::calib {

Folds makeFolds(const std::vector<MarkerObservation>& obs, int k, std::uint64_t seed) {
  Folds f;
  f.k = k;
  f.fold = splitByConfiguration(obs, std::vector<double>(static_cast<std::size_t>(k), 1.0), seed);
  return f;
}

double CvResult::extremesSse() const {
  double t = 0.0;
  for (const auto& [column, sse] : extremes) t += sse;
  return t;
}

std::vector<sim::DrivingVariable> drivingVariablesOf(const std::vector<sim::Effect>& effects, const sim::Arm& arm) {
  std::vector<sim::DrivingVariable> out;
  for (const sim::Effect& e : effects) {
    for (sim::DrivingVariable& v : e.kind().drivingVariables(e, arm)) {
      if (std::none_of(out.begin(), out.end(), [&](const sim::DrivingVariable& o) { return o.column == v.column; })) out.push_back(std::move(v));
    }
  }
  return out;
}

std::vector<int> extremesFold(const std::vector<MarkerObservation>& obs, const sim::DrivingVariable& v, double share) {
  std::vector<double> x;
  for (const MarkerObservation& o : obs) x.push_back(v.value(o.sample));
  std::vector<double> sorted = x;
  std::sort(sorted.begin(), sorted.end());
  const double median = sorted.empty() ? 0.0 : sorted[sorted.size() / 2];
  const auto load = [&](double value) {
    switch (v.extremes) {
      case sim::DrivingVariable::Extremes::kMagnitude: return std::abs(value);
      case sim::DrivingVariable::Extremes::kUpper: return value;
      case sim::DrivingVariable::Extremes::kBothEnds: break;
    }
    return std::abs(value - median);
  };
  // Each configuration by its largest load, so that repeats of one go to one side together.
  std::vector<std::pair<double, const std::vector<int>*>> groups;
  const std::map<std::vector<long long>, std::vector<int>> by_config = configurationGroups(obs);
  for (const auto& [key, members] : by_config) {
    double l = -std::numeric_limits<double>::infinity();
    for (const int i : members) l = std::max(l, load(x[static_cast<std::size_t>(i)]));
    groups.emplace_back(l, &members);
  }
  std::stable_sort(groups.begin(), groups.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  const auto wanted = static_cast<std::size_t>(std::ceil(share * static_cast<double>(groups.size())));
  const std::size_t held = groups.size() < 2 ? 0 : std::min(std::max<std::size_t>(wanted, 1), groups.size() - 1);
  std::vector<int> fold(obs.size(), 0);
  for (std::size_t g = 0; g < held; ++g) {
    for (const int i : *groups[g].second) fold[static_cast<std::size_t>(i)] = 1;
  }
  return fold;
}

std::string beyondRangeAdvice(const std::vector<sim::Effect>& effects, const sim::Arm& arm, const std::vector<MarkerObservation>& obs) {
  std::string out;
  for (const sim::DrivingVariable& v : drivingVariablesOf(effects, arm)) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const MarkerObservation& o : obs) {
      const double x = v.value(o.sample) * v.scale;
      if (!std::isfinite(x)) continue;
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
    if (!(lo <= hi)) continue;
    const bool load = v.extremes == sim::DrivingVariable::Extremes::kMagnitude;
    out += (out.empty() ? "" : ", ") + v.name + " outside " + sim::formatNumber("%.3g", lo) + ".." + sim::formatNumber("%.3g", hi) +
           " " + v.unit + (load ? " (e.g. a heavier payload)" : "");
  }
  return out.empty() ? out : "data beyond the ranges this data covers, where their predictions part: " + out;
}

/// Two effects that claim one cause (a key in common: cyclic:2 and cyclic:2/6, compliance:3 and
/// compliance:3/3) cannot both be in a model.
bool sharesCause(const sim::Effect& a, const sim::Effect& b) {
  if (&a.kind() != &b.kind()) return false;
  const std::vector<std::string> ka = a.kind().keys(a), kb = b.kind().keys(b);
  return std::any_of(ka.begin(), ka.end(), [&](const std::string& k) { return std::find(kb.begin(), kb.end(), k) != kb.end(); });
}

/// The alternatives of the selection (Diagnosis::alternatives): each other member of a kept confounded
/// set in place of the selected effect it is confounded with, where it shares no cause with the rest.
std::vector<Alternative> alternativesOf(const std::vector<sim::Effect>& selected, const std::vector<ConfoundedSet>& confounded,
                                        const std::function<Fit(const std::vector<sim::Effect>&)>& fit) {
  std::vector<Alternative> alts;
  for (const ConfoundedSet& c : confounded) {
    for (std::size_t m = 1; m < c.effects.size(); ++m) {
      std::vector<sim::Effect> effects;
      bool clash = false;
      for (const sim::Effect& s : selected) {
        const bool replaced = sharesCause(s, c.effects.front());
        clash |= !replaced && sharesCause(s, c.effects[m]);
        effects.push_back(replaced ? c.effects[m] : s);
      }
      if (!clash) alts.push_back({effects, Fit{}});
    }
  }
  std::vector<std::future<Fit>> jobs;  // side by side, on every core
  for (const Alternative& a : alts) jobs.push_back(std::async(std::launch::async, [&fit, &a] { return fit(a.effects); }));
  for (std::size_t k = 0; k < alts.size(); ++k) alts[k].fit = jobs[k].get();
  return alts;
}

namespace {

struct Normals {
  std::vector<Eigen::MatrixXd> N;  ///< lower triangles
  std::vector<Eigen::VectorXd> g;
};

/// The groups (indices into `groups`) that hold every sample exactly once, taken from one fold vector
/// (a k-fold split): their sums add up to all samples', which then need no sums of their own. Empty
/// where no such set exists.
std::vector<std::size_t> partitionOf(const std::vector<HeldOutGroup>& groups, int n) {
  if (groups.empty() || !groups.front().fold) return {};
  const std::vector<int>& fold = *groups.front().fold;
  std::vector<std::size_t> parts;
  std::vector<int> values;
  for (std::size_t i = 0; i < groups.size(); ++i) {
    if (groups[i].fold != &fold || std::count(values.begin(), values.end(), groups[i].value)) continue;
    parts.push_back(i);
    values.push_back(groups[i].value);
  }
  const bool covers = static_cast<int>(fold.size()) == n &&
                      std::all_of(fold.begin(), fold.end(), [&](int v) { return std::count(values.begin(), values.end(), v) == 1; });
  return covers ? parts : std::vector<std::size_t>{};
}

/// groupNormals' sums over samples k0..k1; over all samples as the last entry unless `partition` is
/// given (partitionOf: the caller adds its groups' sums).
Normals groupNormalsOf(const MeasurementModel& m, const std::vector<int>& cols, const Eigen::VectorXd& scale,
                       const std::vector<HeldOutGroup>& groups, bool partition, int k0, int k1) {
  constexpr int kBlock = 128;
  const auto nc = static_cast<Eigen::Index>(cols.size());
  Normals s;
  s.N.assign(groups.size() + 1, Eigen::MatrixXd::Zero(nc, nc));
  s.g.assign(groups.size() + 1, Eigen::VectorXd::Zero(nc));
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(m.numParams());
  Eigen::MatrixXd A, H;
  Eigen::VectorXd b, bk;
  std::vector<Eigen::Index> first(kBlock + 1);
  for (int c0 = k0; c0 < k1; c0 += kBlock) {
    const int c1 = std::min(k1, c0 + kBlock);
    Eigen::Index rows = 0;
    for (int k = c0; k < c1; ++k) rows += m.rows(k);
    A.resize(rows, nc);
    b.resize(rows);
    for (int k = c0, row = 0; k < c1; row += m.rows(k), ++k) {
      first[static_cast<std::size_t>(k - c0)] = row;
      whitenedRows(m, k, zero, H, bk);
      for (Eigen::Index c = 0; c < nc; ++c) A.block(row, c, m.rows(k), 1) = H.col(cols[static_cast<std::size_t>(c)]) * scale[c];
      b.segment(row, m.rows(k)) = bk;
    }
    first[static_cast<std::size_t>(c1 - c0)] = rows;
    Eigen::MatrixXd Ar;
    const auto add = [&](std::size_t i, const std::vector<Eigen::Index>& r) {
      if (r.empty()) return;
      Ar = A(r, Eigen::all);
      addGram(s.N[i], Ar);
      s.g[i].noalias() += Ar.transpose() * b(r);
    };
    if (!partition) {
      std::vector<Eigen::Index> all(static_cast<std::size_t>(rows));
      std::iota(all.begin(), all.end(), Eigen::Index{0});
      add(groups.size(), all);
    }
    for (std::size_t i = 0; i < groups.size(); ++i) {
      std::vector<Eigen::Index> r;
      for (int k = c0; k < c1; ++k) {
        if ((*groups[i].fold)[static_cast<std::size_t>(k)] != groups[i].value) continue;
        for (Eigen::Index j = first[static_cast<std::size_t>(k - c0)]; j < first[static_cast<std::size_t>(k - c0 + 1)]; ++j) r.push_back(j);
      }
      add(i, r);
    }
  }
  return s;
}

}  // namespace

void groupNormals(const MeasurementModel& m, const std::vector<int>& cols, const Eigen::VectorXd& scale,
                  const std::vector<HeldOutGroup>& groups, std::vector<Eigen::MatrixXd>& N, std::vector<Eigen::VectorXd>& g) {
  const int n = m.numSamples();
  const std::vector<std::size_t> parts = partitionOf(groups, n);
  const bool partition = !parts.empty();
  Normals s;
  if (n < 64) {
    s = groupNormalsOf(m, cols, scale, groups, partition, 0, n);
  } else {  // two halves side by side, added in a fixed order
    auto upper = std::async(std::launch::async, [&] { return groupNormalsOf(m, cols, scale, groups, partition, n / 2, n); });
    s = groupNormalsOf(m, cols, scale, groups, partition, 0, n / 2);
    const Normals u = upper.get();
    for (std::size_t i = 0; i < s.N.size(); ++i) {
      s.N[i] += u.N[i];
      s.g[i] += u.g[i];
    }
  }
  for (const std::size_t i : parts) {  // all samples' sums: the partition's, in its order
    s.N.back() += s.N[i];
    s.g.back() += s.g[i];
  }
  N.clear();
  for (const Eigen::MatrixXd& x : s.N) N.push_back(x.selfadjointView<Eigen::Lower>());
  g = std::move(s.g);
}

}  // namespace orbcal::calib
