// orbcal/calib/dense_kernels.hpp: the BLAS and LAPACK products agree with Eigen's own, computed here
// independently, on seeded random matrices of the shapes the fits use.
#include <catch2/catch.hpp>

#include <Eigen/Cholesky>
#include <Eigen/QR>

#include "orbcal/calib/dense_kernels.hpp"

using namespace orbcal;

namespace {

Eigen::MatrixXd seeded(Eigen::Index rows, Eigen::Index cols, unsigned seed) {
  std::srand(seed);
  return Eigen::MatrixXd::Random(rows, cols);
}

}  // namespace

TEST_CASE("dense kernels: Gram and cross products add to what is there", "[calib][dense]") {
  const Eigen::MatrixXd rows = seeded(384, 37, 1), other = seeded(384, 37, 2);
  const Eigen::MatrixXd start = seeded(37, 37, 3);
  Eigen::MatrixXd gram = start;
  calib::addGram(gram, rows);
  const Eigen::MatrixXd expected = start + rows.transpose() * rows;
  CHECK((gram.triangularView<Eigen::Lower>().toDenseMatrix() - expected.triangularView<Eigen::Lower>().toDenseMatrix()).norm() <=
        1e-12 * expected.norm());
  CHECK((gram.triangularView<Eigen::StrictlyUpper>().toDenseMatrix() - start.triangularView<Eigen::StrictlyUpper>().toDenseMatrix()).norm() ==
        0.0);  // the upper triangle is left as it was
  Eigen::MatrixXd cross = start;
  calib::addCrossProduct(cross, rows, other);
  CHECK((cross - (start + rows.transpose() * other)).norm() <= 1e-12 * cross.norm());
  Eigen::MatrixXd untouched = start;
  calib::addGram(untouched, Eigen::MatrixXd(0, 37));  // no rows: nothing added
  CHECK(untouched == start);
}

TEST_CASE("dense kernels: the unit lower triangle of an LDLT solves as Eigen's", "[calib][dense]") {
  const Eigen::MatrixXd a = seeded(300, 41, 4);
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(Eigen::MatrixXd(a.transpose() * a + Eigen::MatrixXd::Identity(41, 41)));
  const Eigen::MatrixXd rhs = seeded(41, 128, 5);
  Eigen::MatrixXd y = rhs, expected = rhs;
  calib::solveUnitLowerInPlace(ldlt.matrixLDLT(), y);
  ldlt.matrixL().solveInPlace(expected);
  CHECK((y - expected).norm() <= 1e-10 * expected.norm());
}

TEST_CASE("dense kernels: the Householder R factor of the first rows", "[calib][dense]") {
  const Eigen::MatrixXd a = seeded(500, 23, 6);
  Eigen::MatrixXd work = a;
  calib::householderRInPlace(work, 400);
  const Eigen::MatrixXd R = work.topRows(23);
  CHECK(R.triangularView<Eigen::StrictlyLower>().toDenseMatrix().norm() == 0.0);
  const Eigen::MatrixXd gram = a.topRows(400).transpose() * a.topRows(400);
  CHECK((R.transpose() * R - gram).norm() <= 1e-12 * gram.norm());
  // The same R as Eigen's Householder QR up to the signs of its rows.
  const Eigen::MatrixXd eigen_R = Eigen::HouseholderQR<Eigen::MatrixXd>(a.topRows(400)).matrixQR().topRows(23).triangularView<Eigen::Upper>();
  CHECK((R.cwiseAbs() - eigen_R.cwiseAbs()).norm() <= 1e-10 * R.norm());
  CHECK(work.bottomRows(100) == a.bottomRows(100));  // rows past the first 400 untouched
  // Fewer rows than columns: R is those rows' trapezoid.
  Eigen::MatrixXd wide = seeded(10, 23, 7), wide_work = wide;
  calib::householderRInPlace(wide_work, 10);
  CHECK((wide_work.transpose() * wide_work - wide.transpose() * wide).norm() <= 1e-12 * (wide.transpose() * wide).norm());
}
