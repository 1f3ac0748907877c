#include "orbcal/sim/identifiability.hpp"

#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>

namespace orbcal::sim {

Eigen::MatrixXd stackedJacobian(const Arm& arm, const std::vector<Eigen::VectorXd>& configs, ErrorFrame frame) {
  Eigen::MatrixXd J(6 * configs.size(), arm.numParams());
  for (std::size_t k = 0; k < configs.size(); ++k) {
    J.middleRows<6>(6 * static_cast<Eigen::Index>(k)) = identificationJacobian(arm, configs[k], frame);
  }
  return J;
}

namespace {

/// D of scaledSvd: 1 / |column| per column of J (1 for a zero column).
Eigen::VectorXd unitColumnScale(const Eigen::MatrixXd& J) {
  Eigen::VectorXd scale(J.cols());
  for (Eigen::Index c = 0; c < J.cols(); ++c) {
    const double n = J.col(c).norm();
    scale[c] = n > 0.0 ? 1.0 / n : 1.0;
  }
  return scale;
}

/// The singular values above rank_tolerance times the largest.
int rankOf(const Eigen::VectorXd& singular_values, double rank_tolerance) {
  const double smax = singular_values.size() ? singular_values[0] : 0.0;
  int rank = 0;
  for (Eigen::Index i = 0; i < singular_values.size(); ++i) rank += singular_values[i] > rank_tolerance * smax;
  return rank;
}

/// The thin U (where asked for), the singular values and the full V of A.
template <typename Svd>
void decompose(const Eigen::MatrixXd& A, bool with_u, ScaledSvd& out) {
  const Svd svd(A, (with_u ? Eigen::ComputeThinU : 0) | Eigen::ComputeFullV);
  out.singular_values = svd.singularValues();
  if (with_u) out.U = svd.matrixU();
  out.V = svd.matrixV();
}

}  // namespace

ScaledSvd scaledSvd(const Eigen::MatrixXd& J, double rank_tolerance, bool with_u, SvdMethod method) {
  ScaledSvd out;
  out.scale = unitColumnScale(J);
  if (J.cols() == 0) return out;  // nothing to decompose: rank 0, no directions
  Eigen::MatrixXd JD = J * out.scale.asDiagonal();
  if (!with_u && J.rows() > J.cols()) {
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr(JD);  // JD = Q R: R has JD's singular values and V
    JD = qr.matrixQR().topRows(J.cols()).triangularView<Eigen::Upper>();
  }
  if (method == SvdMethod::kJacobi) {
    decompose<Eigen::JacobiSVD<Eigen::MatrixXd>>(JD, with_u, out);
  } else {
    decompose<Eigen::BDCSVD<Eigen::MatrixXd>>(JD, with_u, out);
  }
  out.rank = rankOf(out.singular_values, rank_tolerance);
  return out;
}

std::vector<int> ineffectiveColumns(const Eigen::MatrixXd& A, const Eigen::VectorXd& typical, double zero_tolerance) {
  Eigen::VectorXd effect(A.cols());
  for (Eigen::Index c = 0; c < A.cols(); ++c) effect[c] = A.col(c).norm() * (typical.size() ? typical[c] : 1.0);
  const double largest = effect.size() ? effect.maxCoeff() : 0.0;
  std::vector<int> out;
  for (Eigen::Index c = 0; c < A.cols(); ++c) {
    if (effect[c] <= zero_tolerance * largest) out.push_back(static_cast<int>(c));
  }
  return out;
}

NumericalRank numericalRank(const Eigen::MatrixXd& A_all, const Eigen::VectorXd& typical, const std::vector<int>& held) {
  NumericalRank out;
  out.held = held;
  // Ineffective columns first: a column that is zero up to round-off (a rigid motion of the whole
  // chain seen by a frame-invariant measurement) would be scaled to unit norm by the SVD and look
  // independent.
  for (int p : ineffectiveColumns(A_all, typical)) out.held.push_back(p);
  std::sort(out.held.begin(), out.held.end());
  out.held.erase(std::unique(out.held.begin(), out.held.end()), out.held.end());
  std::vector<int> free;  // columns of A -> parameters
  for (int p = 0; p < static_cast<int>(A_all.cols()); ++p) {
    if (!std::binary_search(out.held.begin(), out.held.end(), p)) free.push_back(p);
  }
  Eigen::MatrixXd A(A_all.rows(), static_cast<Eigen::Index>(free.size()));
  for (std::size_t c = 0; c < free.size(); ++c) A.col(static_cast<Eigen::Index>(c)) = A_all.col(free[c]);
  // Divide and conquer: the decisions are discrete (a rank at kRankTolerance, far above round-off, and
  // which parameters span the null space, compared with a margin of 1e-9), and Jacobi's SVD of a flexible
  // model's 200 columns took a tenth of a diagnosis.
  const ScaledSvd svd = scaledSvd(A, kRankTolerance, false, SvdMethod::kDivideAndConquer);
  out.rank = svd.rank;
  const int lost = static_cast<int>(A.cols()) - svd.rank;
  // Greedily hold the parameter most involved in the remaining null space (scaled coordinates), last
  // ones first on ties, until the free columns have full rank.
  Eigen::MatrixXd N = svd.V.rightCols(lost);
  for (int k = 0; k < lost && N.cols() > 0; ++k) {
    Eigen::Index best = 0;
    double best_w = -1.0;
    for (Eigen::Index p = N.rows() - 1; p >= 0; --p) {
      const double w = N.row(p).norm();
      if (w > best_w + 1e-9) {
        best_w = w;
        best = p;
      }
    }
    out.held.push_back(free[static_cast<std::size_t>(best)]);
    // The null directions left once it is held: those with no component along it.
    const Eigen::JacobiSVD<Eigen::MatrixXd> nsvd(N.row(best), Eigen::ComputeFullV);
    N = (N * nsvd.matrixV().rightCols(N.cols() - 1)).eval();
  }
  std::sort(out.held.begin(), out.held.end());
  return out;
}

Eigen::MatrixXd ScaledSvd::nullSpace() const {
  const Eigen::Index k = V.cols() - rank;
  return scale.asDiagonal() * V.rightCols(k);
}

namespace {

std::string formatCombination(const std::vector<std::string>& names, const Eigen::VectorXd& coeffs) {
  std::string out;
  char buf[64];
  for (std::size_t i = 0; i < names.size(); ++i) {
    const double c = coeffs[static_cast<Eigen::Index>(i)];
    if (std::abs(c) < 1e-6) continue;
    const bool unit = std::abs(std::abs(c) - 1.0) < 1e-6;
    if (out.empty()) {
      std::snprintf(buf, sizeof buf, "%s", c < 0 ? "-" : "");
    } else {
      std::snprintf(buf, sizeof buf, " %s ", c < 0 ? "-" : "+");
    }
    out += buf;
    if (!unit) {
      std::snprintf(buf, sizeof buf, "%.4g ", std::abs(c));
      out += buf;
    }
    out += names[i];
  }
  return out;
}

}  // namespace

std::string Redundancy::describe() const {
  std::string names;
  for (const std::string& n : this->names) names += (names.empty() ? "" : ", ") + n;
  std::string out = names + ": " + std::to_string(lost) + (lost == 1 ? " direction" : " directions") + " lost";
  if (observable.rows() == 0) return out + "; none of them is observable";
  if (this->names.size() > 6) {
    // Long combinations over many parameters say nothing a person can use: the count does.
    return out + " among " + std::to_string(this->names.size()) + " parameters; observable only as " +
           std::to_string(observable.rows()) + " combinations of them";
  }
  out += "; observable only as ";
  for (Eigen::Index r = 0; r < observable.rows(); ++r) {
    out += (r ? ", " : "") + formatCombination(this->names, observable.row(r).transpose());
  }
  return out;
}

IdentifiabilityReport analyzeIdentifiability(const Arm& arm, const std::vector<Eigen::VectorXd>& configs,
                                             double rank_tolerance, ErrorFrame frame) {
  std::vector<std::string> names;
  for (int i = 0; i < arm.numParams(); ++i) names.push_back(paramName(arm, i));
  return analyzeJacobian(stackedJacobian(arm, configs, frame), names, static_cast<int>(configs.size()), rank_tolerance);
}

IdentifiabilityReport analyzeJacobian(const Eigen::MatrixXd& J, const std::vector<std::string>& names, int num_configs,
                                      double rank_tolerance) {
  IdentifiabilityReport r;
  r.num_params = static_cast<int>(J.cols());
  r.num_configs = num_configs;
  r.num_rows = static_cast<int>(J.rows());
  r.rank_tolerance = rank_tolerance;
  const ScaledSvd svd = scaledSvd(J, rank_tolerance, false);
  r.singular_values = svd.singular_values;
  r.rank = svd.rank;
  r.condition_number = r.rank > 0 ? r.singular_values[0] / r.singular_values[r.rank - 1] : 0.0;
  const int k = r.num_params - r.rank;
  r.null_space = svd.nullSpace();  // physical directions: J D n_s = 0 => n = D n_s
  if (k == 0) return r;

  // Group the parameters that share null directions (connected components).
  const Eigen::MatrixXd N = svd.V.rightCols(k);  // scaled, orthonormal columns
  std::vector<int> involved;
  for (int p = 0; p < r.num_params; ++p) {
    if (N.row(p).norm() > 1e-6) involved.push_back(p);
  }
  std::vector<int> group(r.num_params, -1);
  int groups = 0;
  for (int p : involved) {
    if (group[p] >= 0) continue;
    std::vector<int> stack{p};
    group[p] = groups;
    while (!stack.empty()) {
      const int a = stack.back();
      stack.pop_back();
      for (int b : involved) {
        if (group[b] >= 0) continue;
        // a and b are linked if some null direction involves both; the projector N N^T shows it.
        if (std::abs(N.row(a).dot(N.row(b))) > 1e-6) {
          group[b] = groups;
          stack.push_back(b);
        }
      }
    }
    ++groups;
  }
  for (int g = 0; g < groups; ++g) {
    Redundancy red;
    for (int p : involved) {
      if (group[p] == g) {
        red.params.push_back(p);
        red.names.push_back(names[static_cast<std::size_t>(p)]);
      }
    }
    const int m = static_cast<int>(red.params.size());
    // Physical null directions restricted to the group; their rank is what is lost in the group.
    Eigen::MatrixXd Ng(m, k);
    for (int i = 0; i < m; ++i) Ng.row(i) = r.null_space.row(red.params[i]);
    const Eigen::JacobiSVD<Eigen::MatrixXd> gsvd(Ng, Eigen::ComputeFullU);
    const double gmax = gsvd.singularValues().size() ? gsvd.singularValues()[0] : 0.0;
    for (Eigen::Index i = 0; i < gsvd.singularValues().size(); ++i) {
      if (gsvd.singularValues()[i] > 1e-6 * gmax) ++red.lost;
    }
    // Observable functionals w^T y within the group: orthogonal to every physical null direction.
    const Eigen::MatrixXd W = gsvd.matrixU().rightCols(m - red.lost).transpose();
    red.observable = W;
    for (Eigen::Index row = 0; row < W.rows(); ++row) {
      Eigen::Index imax = 0;
      W.row(row).cwiseAbs().maxCoeff(&imax);
      red.observable.row(row) /= W(row, imax);
    }
    r.redundancies.push_back(red);
  }
  return r;
}

std::string formatIdentifiability(const IdentifiabilityReport& r) {
  std::string out;
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "Identifiability over %d configurations (%d rows, %d parameters, columns scaled to unit norm):\n",
                r.num_configs, r.num_rows, r.num_params);
  out += buf;
  std::snprintf(buf, sizeof buf, "  numerical rank %d of %d (singular values below %.0e x sigma_max count as zero)\n",
                r.rank, r.num_params, r.rank_tolerance);
  out += buf;
  std::snprintf(buf, sizeof buf, "  condition number of the identifiable part: %.4g\n", r.condition_number);
  out += buf;
  out += "  smallest singular values:";
  for (Eigen::Index i = std::max<Eigen::Index>(0, r.singular_values.size() - 4); i < r.singular_values.size(); ++i) {
    std::snprintf(buf, sizeof buf, " %.3g", r.singular_values[i]);
    out += buf;
  }
  out += "\n";
  if (r.redundancies.empty()) {
    out += "  every parameter is identifiable\n";
  } else {
    out += "  unidentifiable directions:\n";
    for (const Redundancy& red : r.redundancies) out += "    " + red.describe() + "\n";
  }
  return out;
}

}  // namespace orbcal::sim
