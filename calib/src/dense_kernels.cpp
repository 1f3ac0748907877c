#include "orbcal/calib/dense_kernels.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <vector>

// The Fortran interface of BLAS and LAPACK (every implementation has it).
extern "C" {
void dsyrk_(const char* uplo, const char* trans, const int* n, const int* k, const double* alpha, const double* a,
            const int* lda, const double* beta, double* c, const int* ldc);
void dgemm_(const char* ta, const char* tb, const int* m, const int* n, const int* k, const double* alpha, const double* a,
            const int* lda, const double* b, const int* ldb, const double* beta, double* c, const int* ldc);
void dtrsm_(const char* side, const char* uplo, const char* ta, const char* diag, const int* m, const int* n, const double* alpha,
            const double* a, const int* lda, double* b, const int* ldb);
void dgeqrf_(const int* m, const int* n, double* a, const int* lda, double* tau, double* work, const int* lwork, int* info);
void openblas_set_num_threads(int);
}

namespace orbcal::calib {

namespace {

/// One thread per call: the callers already split the samples between the cores.
void singleThreaded() {
  static const bool once = [] {
    openblas_set_num_threads(1);
    return true;
  }();
  (void)once;
}

int toInt(Eigen::Index i) {
  if (i > std::numeric_limits<int>::max()) throw std::length_error("dense kernel: a dimension beyond BLAS's int");
  return static_cast<int>(i);
}

}  // namespace

void addGram(Eigen::MatrixXd& lower, const Eigen::MatrixXd& rows) {
  if (rows.rows() == 0 || rows.cols() == 0) return;
  singleThreaded();
  const int n = toInt(rows.cols()), k = toInt(rows.rows()), lda = toInt(rows.outerStride()), ldc = toInt(lower.outerStride());
  const double one = 1.0;
  dsyrk_("L", "T", &n, &k, &one, rows.data(), &lda, &one, lower.data(), &ldc);
}

void addCrossProduct(Eigen::MatrixXd& out, const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  if (a.rows() == 0) return;
  singleThreaded();
  const int m = toInt(a.cols()), n = toInt(b.cols()), k = toInt(a.rows());
  const int lda = toInt(a.outerStride()), ldb = toInt(b.outerStride()), ldc = toInt(out.outerStride());
  const double one = 1.0;
  dgemm_("T", "N", &m, &n, &k, &one, a.data(), &lda, b.data(), &ldb, &one, out.data(), &ldc);
}

void solveUnitLowerInPlace(const Eigen::MatrixXd& ldlt_matrix, Eigen::MatrixXd& y) {
  if (y.size() == 0) return;
  singleThreaded();
  const int m = toInt(y.rows()), n = toInt(y.cols()), lda = toInt(ldlt_matrix.outerStride()), ldb = toInt(y.outerStride());
  const double one = 1.0;
  dtrsm_("L", "L", "N", "U", &m, &n, &one, ldlt_matrix.data(), &lda, y.data(), &ldb);
}

void householderRInPlace(Eigen::MatrixXd& a, Eigen::Index rows) {
  const Eigen::Index kept = std::min(rows, a.cols());
  if (kept == 0) return;
  singleThreaded();
  const int m = toInt(rows), n = toInt(a.cols()), lda = toInt(a.outerStride());
  std::vector<double> tau(static_cast<std::size_t>(kept));
  int info = 0, lwork = -1;
  double size = 0.0;
  dgeqrf_(&m, &n, a.data(), &lda, tau.data(), &size, &lwork, &info);
  lwork = std::max(1, static_cast<int>(size));
  thread_local std::vector<double> work;
  if (work.size() < static_cast<std::size_t>(lwork)) work.resize(static_cast<std::size_t>(lwork));
  dgeqrf_(&m, &n, a.data(), &lda, tau.data(), work.data(), &lwork, &info);
  if (info != 0) throw std::runtime_error("dense kernel: dgeqrf failed");
  a.topRows(kept).triangularView<Eigen::StrictlyLower>().setZero();
}

}  // namespace orbcal::calib
