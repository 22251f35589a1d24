#include "host_id/series_matrix.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <utility>

namespace host_id {
namespace {

Eigen::MatrixXd counting(Eigen::Index rows, Eigen::Index cols) {
  Eigen::MatrixXd m(rows, cols);
  for (Eigen::Index c = 0; c < cols; ++c) {
    for (Eigen::Index r = 0; r < rows; ++r) m(r, c) = static_cast<double>(1000 * c + r);
  }
  return m;
}

// It is an Eigen matrix: assigned from an expression, read by products.
TEST(SeriesMatrixTest, WorksAsAnEigenMatrix) {
  SeriesMatrix m;
  EXPECT_EQ(m.size(), 0);
  m = counting(5, 3);
  ASSERT_EQ(m.rows(), 5);
  ASSERT_EQ(m.cols(), 3);
  EXPECT_TRUE(m == counting(5, 3));
  const Eigen::Vector3d x(1.0, -2.0, 0.5);
  EXPECT_TRUE((m * x).isApprox(counting(5, 3) * x));
  m.col(1) *= 2.0;
  EXPECT_EQ(m(4, 1), 2.0 * 1004.0);
  m = m.transpose() * 1.0;  // an expression that reads the matrix itself
  EXPECT_EQ(m.rows(), 3);
  EXPECT_EQ(m(1, 4), 2.0 * 1004.0);
}

// A long matrix (megabytes, from the kernel's blocks) as well as a short one.
TEST(SeriesMatrixTest, ALongMatrixHoldsItsValues) {
  SeriesMatrix m(300000, 4);  // 9.6 MB
  m = counting(300000, 4);
  EXPECT_EQ(m(299999, 3), 3000.0 + 299999.0);
  m.resize(2, 2);
  m.setConstant(1.5);
  EXPECT_EQ(m.sum(), 6.0);
}

TEST(SeriesMatrixTest, CopiesAndMovesOwnTheirStorage) {
  SeriesMatrix a;
  a = counting(4, 2);
  SeriesMatrix b = a;
  EXPECT_NE(b.data(), a.data());
  b(0, 0) = -1.0;
  EXPECT_EQ(a(0, 0), 0.0);
  const double* storage = b.data();
  SeriesMatrix c = std::move(b);
  EXPECT_EQ(c.data(), storage);
  EXPECT_EQ(c(0, 0), -1.0);
  EXPECT_EQ(b.size(), 0);  // moved from: empty
  a = std::move(c);
  EXPECT_EQ(a.data(), storage);
  const SeriesMatrix& same = a;
  a = same;  // assigned to itself, it keeps its values
  EXPECT_EQ(a(0, 0), -1.0);
}

TEST(SeriesMatrixTest, NewColumnsAtTheRightKeepTheOthers) {
  SeriesMatrix m;
  m = counting(6, 2);
  m.conservative_resize_columns(4);
  ASSERT_EQ(m.cols(), 4);
  EXPECT_TRUE(m.leftCols(2) == counting(6, 2));
  m.col(3).setConstant(7.0);
  m.conservative_resize_columns(1);
  EXPECT_TRUE(m == counting(6, 1));
}

}  // namespace
}  // namespace host_id
