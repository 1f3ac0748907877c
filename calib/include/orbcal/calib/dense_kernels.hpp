#pragma once
// The few large dense products of a long log's fits, on the machine's BLAS and LAPACK (OpenBLAS: its
// kernels are chosen for the processor at run time, 2.5 to 3 times as fast as Eigen's portable ones on
// the products below). Everything smaller stays Eigen's.
#include <Eigen/Core>

namespace orbcal::calib {

/// lower += rows^T rows, on lower's lower triangle (rows: many rows, few columns; BLAS dsyrk).
void addGram(Eigen::MatrixXd& lower, const Eigen::MatrixXd& rows);

/// out += a^T b, every entry (BLAS dgemm).
void addCrossProduct(Eigen::MatrixXd& out, const Eigen::MatrixXd& a, const Eigen::MatrixXd& b);

/// y = L^-1 y with L the unit lower triangle of `ldlt_matrix` (Eigen::LDLT::matrixLDLT(); BLAS dtrsm).
void solveUnitLowerInPlace(const Eigen::MatrixXd& ldlt_matrix, Eigen::MatrixXd& y);

/// The R factor of the first `rows` rows of `a` (Householder QR, LAPACK dgeqrf): written over a's first
/// min(rows, cols) rows, zeros below the diagonal.
void householderRInPlace(Eigen::MatrixXd& a, Eigen::Index rows);

}  // namespace orbcal::calib
