// Tests of the regression's costs: O(p^2) against the direct sum, weights, residual squares.
#include "host_id/regression.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>

#include "delta/input_error.hpp"
#include "fit_fixtures.hpp"
#include "held_joint_log.hpp"
#include "host_id/identify.hpp"
#include "host_id/least_squares.hpp"
#include "host_id/preprocess.hpp"
#include "host_id/regression.hpp"
#include "host_id/simulate.hpp"

namespace host_id {
namespace {

using namespace test;

// `cost` equals the direct sum of squares to 1e-12 at beta0 and at 40
// points about it, beta0 scaled by 1 + sign scale sin/cos(f (trial k + i))
// for relative steps from 1e-9 to 0.1.
void expect_direct_cost_about(const QuadraticCost& cost, const Regression& reg,
                              const Eigen::VectorXd& beta0, double f, int k, bool cosine) {
  EXPECT_NEAR(cost(beta0), direct_cost(reg, beta0), 1e-12 * direct_cost(reg, beta0));
  for (const double scale : {1e-9, 1e-6, 1e-3, 1e-1}) {
    for (int trial = 0; trial < 10; ++trial) {
      Eigen::VectorXd beta = beta0;
      for (Eigen::Index i = 0; i < beta.size(); ++i) {
        const double x = f * static_cast<double>(trial * k + i);
        beta(i) *= cosine ? 1.0 - scale * std::cos(x) : 1.0 + scale * std::sin(x);
      }
      const double direct = direct_cost(reg, beta);
      EXPECT_NEAR(cost(beta), direct, 1e-12 * direct) << "relative step " << scale;
    }
  }
}

// Over a box's normalised coordinates (what PSO evaluates), the same at
// the point u that stands for beta.
void expect_direct_cost_over_a_box(const QuadraticCost& from_moments, const Regression& reg,
                                   const Eigen::VectorXd& beta0) {
  const Eigen::VectorXd upper =
      10.0 * beta0.cwiseAbs() + Eigen::VectorXd::Constant(beta0.size(), 1e-3);
  const Eigen::VectorXd lower = -0.5 * upper;
  const QuadraticCost in_box = from_moments.over_box(lower, upper);
  for (const double scale : {0.0, 1e-9, 1e-6, 1e-3, 1e-1}) {
    for (int trial = 0; trial < 10; ++trial) {
      Eigen::VectorXd beta = beta0;
      for (Eigen::Index i = 0; i < beta.size(); ++i) {
        beta(i) *= 1.0 + scale * std::sin(0.9 * static_cast<double>(trial * 11 + i));
      }
      const Eigen::VectorXd u = (beta - lower).cwiseQuotient(upper - lower);
      const double direct = direct_cost(reg, lower + u.cwiseProduct(upper - lower));
      EXPECT_NEAR(in_box.at(u.data()), direct, 1e-12 * direct) << "relative step " << scale;
    }
  }
}

// Far from the optimum too: `fast` (about the optimum) to 1e-12, and the
// cost expanded about zero to 1e-10.
void expect_direct_cost_far_away(const QuadraticCost& fast, const Regression& reg, Eigen::Index p) {
  const QuadraticCost about_zero(reg, Eigen::VectorXd::Zero(p));
  Eigen::VectorXd beta = Eigen::VectorXd::Zero(p);
  for (int trial = 0; trial < 20; ++trial) {
    for (Eigen::Index i = 0; i < beta.size(); ++i) {
      beta(i) = 0.1 * std::sin(1.7 * static_cast<double>(trial * 13 + i)) + 0.05;
    }
    const double direct = direct_cost(reg, beta);
    EXPECT_NEAR(fast(beta), direct, 1e-12 * direct);
    EXPECT_NEAR(about_zero(beta), direct, 1e-10 * direct);
  }
}

// PSO compares costs to 1e-12 (its stall tolerance), so the O(p^2) cost
// must equal the direct sum of squares that well at and near the optimum,
// where the expansion about zero lost about 5e-9 to cancellation.
TEST(RegressionTest, QuadraticCostEqualsTheDirectSumAtAndNearTheOptimum) {
  const DeltaLog log = simulated(4, 0.02, 17, false);
  const auto model = make_model({});
  const Regression reg = preprocess(*model, log, PrepareOptions{}).regression;
  const LeastSquaresResult ls =
      solve_least_squares(reg, *model, LsSolver::kQr, LsWeights::kNone, log.name, 0);
  const QuadraticCost fast(reg, ls.beta);
  expect_direct_cost_about(fast, reg, ls.beta, 1.7, 13, false);
  // From the moments the solve formed (what the fit uses: no pass over the
  // rows), the same.
  const QuadraticCost from_moments(ls.psi_t_psi, ls.psi_t_tau, ls.beta,
                                   ls.cost * static_cast<double>(reg.rows()), reg.rows());
  expect_direct_cost_about(from_moments, reg, ls.beta, 2.3, 7, true);
  expect_direct_cost_over_a_box(from_moments, reg, ls.beta);
  expect_direct_cost_far_away(fast, reg, ls.beta.size());
}

// The quadratic form is unrolled for the models' usual sizes and a loop
// otherwise, and pairs a column's products: odd and even sizes of both
// kinds (a random regressor, about a point off its optimum) give the direct
// sum, and so does the same cost over a box.
TEST(RegressionTest, QuadraticCostOfEverySizeEqualsTheDirectSum) {
  for (const Eigen::Index p : {1, 2, 5, 9, 12, 13, 14, 15, 18, 21}) {
    Regression reg;
    const Eigen::Index rows = 3 * (40 + p);
    reg.psi = Eigen::MatrixXd::Random(rows, p);
    reg.tau = Eigen::VectorXd::Random(rows);
    reg.joint.assign(static_cast<std::size_t>(rows), 0);
    reg.sample.assign(static_cast<std::size_t>(rows), 0);
    const Eigen::VectorXd beta0 = 0.3 * Eigen::VectorXd::Random(p);
    const QuadraticCost cost(reg, beta0);
    const Eigen::VectorXd lower = Eigen::VectorXd::Constant(p, -2.0);
    const Eigen::VectorXd upper = Eigen::VectorXd::LinSpaced(p, 1.0, 3.0);
    const QuadraticCost in_box = cost.over_box(lower, upper);
    for (int trial = 0; trial < 5; ++trial) {
      const Eigen::VectorXd beta = Eigen::VectorXd::Random(p);
      const double direct = direct_cost(reg, beta);
      EXPECT_NEAR(cost(beta), direct, 1e-12 * direct) << "p = " << p;
      const Eigen::VectorXd u = (beta - lower).cwiseQuotient(upper - lower);
      EXPECT_NEAR(in_box.at(u.data()), direct, 1e-12 * direct) << "p = " << p;
    }
  }
}

// The weighted cost without a weighted copy of the rows: the cost of the
// rows scaled by the square roots of the weights.
TEST(RegressionTest, WeightedDirectCostIsTheCostOfTheWeightedRows) {
  const DeltaLog log = simulated(2, 0.01, 17, false);
  const auto model = make_model({});
  const Regression reg = preprocess(*model, log, PrepareOptions{}).regression;
  const LeastSquaresResult ls =
      solve_least_squares(reg, *model, LsSolver::kQr, LsWeights::kNone, log.name);
  const std::array<double, 3> w{0.5, 1.75, 0.75};
  const Regression scaled = weighted(reg, w);
  const Eigen::VectorXd beta = 1.1 * ls.beta;
  const double expected = direct_cost(scaled, beta);
  EXPECT_NEAR(direct_cost(reg, beta, w), expected, 1e-13 * expected);
  EXPECT_GT(std::abs(direct_cost(reg, beta) - expected), 1e-3 * expected);
  EXPECT_NEAR(direct_cost(reg, beta, {1.0, 1.0, 1.0}), direct_cost(reg, beta),
              1e-14 * direct_cost(reg, beta));
}

// The squared residuals per joint, over the first rows and over all, from
// one pass in chunks: against a row-by-row sum, and the same bits on one
// thread or two (the 8 s log's 24 003 rows are two chunks).
TEST(RegressionTest, ResidualSquaresPerJointEqualTheRowByRowSums) {
  const DeltaLog log = simulated(2, 0.01, 17, false);
  const auto model = make_model({});
  const Regression reg = preprocess(*model, log, PrepareOptions{}).regression;
  ASSERT_GT(reg.rows(), 16384u);
  const LeastSquaresResult ls =
      solve_least_squares(reg, *model, LsSolver::kQr, LsWeights::kNone, log.name);
  const Eigen::VectorXd beta = 1.1 * ls.beta;
  const std::size_t first_rows = reg.rows() / 3 + 7;
  std::array<double, 3> first{}, all{};
  for (std::size_t row = 0; row < reg.rows(); ++row) {
    const auto i = static_cast<Eigen::Index>(row);
    const double e = reg.tau(i) - reg.psi.row(i).dot(beta);
    all[reg.joint[row]] += e * e;
    if (row < first_rows) first[reg.joint[row]] += e * e;
  }
  const ResidualSquares one = residual_squares(reg, first_rows, beta, 1);
  const ResidualSquares two = residual_squares(reg, first_rows, beta, 2);
  for (unsigned j = 0; j < 3; ++j) {
    EXPECT_NEAR(one.first[j], first[j], 1e-12 * first[j]) << j;
    EXPECT_NEAR(one.all[j], all[j], 1e-12 * all[j]) << j;
    EXPECT_LT(one.first[j], 0.5 * one.all[j]) << j;
    EXPECT_EQ(one.first[j], two.first[j]) << j;
    EXPECT_EQ(one.all[j], two.all[j]) << j;
  }
  const std::array<double, 3> w{0.5, 1.75, 0.75};
  EXPECT_NEAR(
      one.cost(w, first_rows),
      (w[0] * first[0] + w[1] * first[1] + w[2] * first[2]) / static_cast<double>(first_rows),
      1e-12 * one.cost(w, first_rows));
  const std::array<std::size_t, 3> n = reg.rows_per_joint();
  const std::array<double, 3> rmse = rmse_per_joint(reg, one);
  for (unsigned j = 0; j < 3; ++j) {
    EXPECT_NEAR(rmse[j], std::sqrt(all[j] / static_cast<double>(n[j])), 1e-12 * rmse[j]) << j;
  }
}

}  // namespace
}  // namespace host_id
