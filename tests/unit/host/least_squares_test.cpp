// Tests of least squares: the solve, its bounds, weights and covariance, and what a log cannot
// identify.
#include "host_id/least_squares.hpp"

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

// The solve factors a well-conditioned regressor through its Gram matrix
// (one pass) and refines once; it must give what Householder QR of the
// whole regressor gives. A regressor conditioned beyond the Gram limit
// (two columns nearly alike: scaled condition number about 2e5, where the
// Gram matrix alone would lose about 1e-6) takes Householder: the same
// agreement.
TEST(LeastSquaresTest, LeastSquaresEqualsHouseholderQrWhateverTheConditioning) {
  const DeltaLog log = simulated(2, 0.015, 17, false);
  const auto model = make_model({});
  Regression reg = preprocess(*model, log, PrepareOptions{}).regression;
  const auto reference = [](const Regression& r) {
    return Eigen::VectorXd(r.psi.householderQr().solve(r.tau));
  };
  const auto expect_same = [](const Eigen::VectorXd& got, const Eigen::VectorXd& want,
                              double tolerance) {
    for (Eigen::Index c = 0; c < want.size(); ++c) {
      EXPECT_NEAR(got(c), want(c), tolerance * want.cwiseAbs().maxCoeff()) << c;
    }
  };
  const LeastSquaresResult well =
      solve_least_squares(reg, *model, LsSolver::kQr, LsWeights::kNone, log.name, 0);
  ASSERT_LT(well.condition_number_scaled, 1e3);
  expect_same(well.unconstrained_beta, reference(reg), 1e-12);

  // Column 2 (arm_gravity_sin) becomes column 1 plus a trace of itself.
  const Eigen::VectorXd sin_column = reg.psi.col(2);
  reg.psi.col(2) = reg.psi.col(1) + 2e-5 * sin_column;
  std::vector<ParameterInfo> free_parameters = model->parameters();
  for (ParameterInfo& info : free_parameters) info.nonnegative = false;
  const LeastSquaresResult ill =
      solve_least_squares(reg, free_parameters, LsSolver::kQr, LsWeights::kNone, log.name, 0);
  ASSERT_GT(ill.condition_number_scaled, 1e4);
  expect_same(ill.unconstrained_beta, reference(reg), 1e-9);
}

// The bounded optimum by the active-set method against every choice of
// active set (the convex problem's optimum is the feasible one with the
// least cost), and its KKT conditions, on random full-rank problems.
TEST(LeastSquaresTest, BoundedLeastSquaresFindsTheOptimumWithinTheBounds) {
  const Eigen::Index p = 7;
  const std::vector<bool> nonnegative{true, false, true, true, false, true, true};
  int with_active = 0;
  for (int trial = 0; trial < 200; ++trial) {
    std::srand(static_cast<unsigned>(trial + 1));
    Eigen::MatrixXd r = Eigen::MatrixXd::Random(p, p).triangularView<Eigen::Upper>();
    r.diagonal() = r.diagonal().cwiseAbs().array() + 0.3;
    const Eigen::VectorXd b = Eigen::VectorXd::Random(p) * 3.0;
    const Eigen::VectorXd x = bounded_least_squares(r, b, nonnegative);
    const auto cost = [&](const Eigen::VectorXd& v) { return (r * v - b).squaredNorm(); };
    // Brute force: each subset of the bounded parameters held at 0.
    double best = std::numeric_limits<double>::infinity();
    for (unsigned mask = 0; mask < 32; ++mask) {
      Eigen::MatrixXd a = r;
      std::vector<Eigen::Index> held;
      unsigned bit = 0;
      for (Eigen::Index c = 0; c < p; ++c) {
        if (!nonnegative[static_cast<std::size_t>(c)]) continue;
        if (mask & (1u << bit++)) held.push_back(c);
      }
      for (const Eigen::Index c : held) a.col(c).setZero();
      Eigen::VectorXd v = a.completeOrthogonalDecomposition().solve(b);
      for (const Eigen::Index c : held) v(c) = 0.0;
      bool feasible = true;
      for (Eigen::Index c = 0; c < p; ++c) {
        feasible = feasible && !(nonnegative[static_cast<std::size_t>(c)] && v(c) < -1e-12);
      }
      if (feasible) best = std::min(best, cost(v));
    }
    EXPECT_NEAR(cost(x), best, 1e-10 * (1.0 + best)) << "trial " << trial;
    const Eigen::VectorXd gradient = r.transpose() * (r * x - b);
    bool any_active = false;
    for (Eigen::Index c = 0; c < p; ++c) {
      if (nonnegative[static_cast<std::size_t>(c)]) {
        EXPECT_GE(x(c), 0.0);
        if (x(c) == 0.0) {
          any_active = true;
          EXPECT_GE(gradient(c), -1e-9) << "trial " << trial;  // pushing against the bound
          continue;
        }
      }
      EXPECT_NEAR(gradient(c), 0.0, 1e-9) << "trial " << trial;
    }
    with_active += any_active ? 1 : 0;
  }
  EXPECT_GT(with_active, 100);  // the test exercises the bounds
}

// Joint weights scale each joint's rows as the solve reads them: the same
// estimate, cost, spread and moments as an ordinary solve of a weighted copy
// of the rows, on the Gram path and on Householder's (two columns made
// nearly parallel put the conditioning over the Gram path's limit).
TEST(LeastSquaresTest, JointWeightsGiveTheOrdinarySolveOfTheWeightedRows) {
  const auto model = make_model({});
  const auto expect_close = [](const Eigen::VectorXd& a, const Eigen::VectorXd& b, double rel) {
    ASSERT_EQ(a.size(), b.size());
    for (Eigen::Index c = 0; c < a.size(); ++c) EXPECT_NEAR(a(c), b(c), rel * std::abs(b(c))) << c;
  };
  const DeltaLog fourier = simulated(5, 0.02, 17, false);
  const Regression plain = preprocess(*model, fourier, PrepareOptions{}).regression;
  Regression ill = plain;
  ill.psi.col(2) =
      ill.psi.col(1) * (ill.psi.col(2).norm() / ill.psi.col(1).norm()) + 1e-4 * ill.psi.col(2);
  for (const Regression* reg : std::array<const Regression*, 2>{&plain, &ill}) {
    const LeastSquaresResult w =
        solve_least_squares(*reg, *model, LsSolver::kQr, LsWeights::kJoint, fourier.name, 20, 2);
    EXPECT_NE(w.joint_weights, (std::array<double, 3>{1.0, 1.0, 1.0}));
    SCOPED_TRACE(reg == &ill ? "near-parallel columns" : "as simulated");
    const Regression copy = weighted(*reg, w.joint_weights);
    const LeastSquaresResult o =
        solve_least_squares(copy, *model, LsSolver::kQr, LsWeights::kNone, fourier.name, 20, 2);
    EXPECT_EQ(o.condition_number_scaled > 1e3, reg == &ill);
    expect_close(w.beta, o.beta, 1e-9);
    expect_close(w.unconstrained_beta, o.unconstrained_beta, 1e-9);
    // The spread goes through (Psi^T Psi)^-1 twice: the residuals' rounding
    // grows with the square of the condition number (about 1e5 here).
    expect_close(w.std_dev, o.std_dev, reg == &ill ? 1e-5 : 1e-9);
    EXPECT_NEAR(w.cost, o.cost, 1e-12 * o.cost);
    EXPECT_NEAR(w.condition_number_scaled, o.condition_number_scaled,
                1e-9 * o.condition_number_scaled);
    EXPECT_TRUE(w.psi_t_psi.isApprox(o.psi_t_psi, 1e-13));
  }
}

// The passes of least squares over the rows (the Gram matrix, the
// refinement's residual, the residual at the estimate, the covariance) are
// shared out in chunks of fixed length and their sums added in order: on
// two threads (a 45 s log, about 135 000 rows: two workers) the estimate,
// its cost and its standard deviations are the same bits as on one.
TEST(LeastSquaresTest, LeastSquaresGivesTheSameBitsOnOneThreadAndOnTwo) {
  const DeltaLog log = simulated(6, 0.015, 17, false, "fourier", 45.0);
  const auto model = make_model({});
  const Regression reg = preprocess(*model, log, PrepareOptions{}).regression;
  ASSERT_GT(reg.rows(), 120000u);
  for (const LsWeights weights : {LsWeights::kNone, LsWeights::kJoint}) {
    const LeastSquaresResult one =
        solve_least_squares(reg, *model, LsSolver::kQr, weights, log.name, 20, 1);
    const LeastSquaresResult two =
        solve_least_squares(reg, *model, LsSolver::kQr, weights, log.name, 20, 2);
    EXPECT_TRUE(one.beta == two.beta) << one.beta.transpose() << "\n" << two.beta.transpose();
    EXPECT_EQ(one.cost, two.cost);
    EXPECT_EQ(one.unconstrained_cost, two.unconstrained_cost);
    EXPECT_TRUE(one.std_dev == two.std_dev);
    EXPECT_TRUE(one.psi_t_psi == two.psi_t_psi);
  }
}

// The covariance with correlated residuals against the textbook double sum
//   S = sum over rows a, b of the same joint with |k_a - k_b| <= L of
//       (1 - |k_a - k_b| / (L + 1)) psi_a e_a e_b psi_b^T,
// with some equations left out; L = 0 is the same code's other branch. The
// log is long enough (20 001 samples) for the running box sums to be
// re-summed on the way, and for each joint's boxes to come in two chunks
// (16 384 each: the second starts from the rows before it).
TEST(LeastSquaresTest, CorrelatedResidualCovarianceEqualsTheDoubleSum) {
  const DeltaLog log = simulated(3, 0.02, 17, false, "fourier", 20.0);
  const auto model = make_model({});
  PrepareOptions slow_last;
  slow_last.slow_rows_last_below_rad_s = 0.1;
  const Preprocessed pre = preprocess(*model, log, slow_last);
  const Regression& all = pre.regression;
  const Equations reg(all, pre.fast_rows);
  ASSERT_LT(reg.rows(), 3 * reg.samples());
  const auto rows = static_cast<Eigen::Index>(reg.rows());
  const Eigen::Index p = reg.psi.cols();
  for (const std::size_t lags : {std::size_t{0}, std::size_t{7}}) {
    SCOPED_TRACE(lags);
    const LeastSquaresResult ls =
        solve_least_squares(reg, *model, LsSolver::kQr, LsWeights::kNone, log.name, lags);
    EXPECT_EQ(ls.correlation_lags, lags);
    // The covariance is the least-squares estimator's: residuals at the
    // unconstrained optimum (on this log a bound is active).
    EXPECT_FALSE(ls.active_bounds.empty());
    const Eigen::VectorXd e = reg.tau - reg.psi * ls.unconstrained_beta;
    Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(p, p);
    const auto window = static_cast<Eigen::Index>(3 * (lags + 1));  // rows are in sample order
    for (Eigen::Index a = 0; a < rows; ++a) {
      for (Eigen::Index b = std::max<Eigen::Index>(0, a - window);
           b < std::min(rows, a + window + 1); ++b) {
        const auto ua = static_cast<std::size_t>(a), ub = static_cast<std::size_t>(b);
        if (reg.joint[ua] != reg.joint[ub]) continue;
        const std::size_t d = reg.sample[ua] > reg.sample[ub] ? reg.sample[ua] - reg.sample[ub]
                                                              : reg.sample[ub] - reg.sample[ua];
        if (d > lags) continue;
        const double w = 1.0 - static_cast<double>(d) / static_cast<double>(lags + 1);
        sum += w * e(a) * e(b) * reg.psi.row(a).transpose() * reg.psi.row(b);
      }
    }
    const Eigen::MatrixXd inv = (reg.psi.transpose() * reg.psi).inverse();
    const double dof = static_cast<double>(rows) / static_cast<double>(rows - p);
    const Eigen::MatrixXd cov = dof * inv * sum * inv;
    const Eigen::VectorXd expected = cov.diagonal().cwiseSqrt();
    for (Eigen::Index c = 0; c < p; ++c)
      EXPECT_NEAR(ls.std_dev(c), expected(c), 1e-6 * expected(c)) << c;
    // The correlations are the same covariance's.
    ASSERT_EQ(ls.correlation.rows(), p);
    for (Eigen::Index a = 0; a < p; ++a) {
      for (Eigen::Index b = 0; b < p; ++b) {
        EXPECT_NEAR(ls.correlation(a, b), cov(a, b) / (expected(a) * expected(b)), 1e-6)
            << a << "," << b;
      }
    }
  }
}

// Preprocessing names the columns that are not zero in each joint's rows
// (the default model's joint j has no other joint's friction), and the
// covariance works on those alone: the same standard deviations as over
// every column, where the regression does not say.
TEST(LeastSquaresTest, TheCovarianceTakesEachJointsOwnColumnsWithTheSameResult) {
  const DeltaLog log = simulated(3, 0.02, 17, false, "fourier", 20.0);
  const auto model = make_model({});
  const Preprocessed pre = preprocess(*model, log, PrepareOptions{});
  const Regression& with = pre.regression;
  const Eigen::Index p = with.psi.cols();
  for (unsigned j = 0; j < 3; ++j) {
    SCOPED_TRACE(j);
    const auto& used = with.joint_columns[j];
    EXPECT_EQ(used.size(), 8u) << "6 shared columns, this joint's viscous and Coulomb friction";
    for (Eigen::Index c = 0; c < p; ++c) {
      const bool listed = std::find(used.begin(), used.end(), c) != used.end();
      bool zero_throughout = true;
      for (std::size_t row = 0; row < with.rows(); ++row) {
        if (with.joint[row] == j && with.psi(static_cast<Eigen::Index>(row), c) != 0.0) {
          zero_throughout = false;
        }
      }
      EXPECT_EQ(listed, !zero_throughout) << "column " << c;
    }
  }
  Regression without = with;
  for (auto& columns : without.joint_columns) columns.clear();
  const auto fit = [&](const Regression& r) {
    return solve_least_squares(r, *model, LsSolver::kQr, LsWeights::kNone, log.name, 100);
  };
  const LeastSquaresResult a = fit(with), b = fit(without);
  for (Eigen::Index c = 0; c < p; ++c) {
    EXPECT_NEAR(a.std_dev(c), b.std_dev(c), 1e-13 * b.std_dev(c)) << c;
  }
  // A column added afterwards (the friction-shape uncertainty adds its
  // derivatives) is not zero in any joint's rows: the lists, made for p
  // columns, are then left aside, and every column is taken.
  Regression grown = with;
  grown.psi.conservativeResize(Eigen::NoChange, p + 1);
  grown.psi.col(p) = with.psi.col(0).cwiseProduct(with.tau);
  Regression grown_without = grown;
  for (auto& columns : grown_without.joint_columns) columns.clear();
  std::vector<ParameterInfo> infos = model->parameters();
  infos.push_back({"added", "-", false, ""});
  const auto fit_grown = [&](const Regression& r) {
    return solve_least_squares(Equations(r), infos, LsSolver::kQr, LsWeights::kNone, log.name, 100);
  };
  const LeastSquaresResult c = fit_grown(grown), d = fit_grown(grown_without);
  for (Eigen::Index k = 0; k <= p; ++k) {
    EXPECT_NEAR(c.std_dev(k), d.std_dev(k), 1e-13 * d.std_dev(k)) << k;
  }
}

TEST(LeastSquaresTest, AStaticLogIdentifiesOnlyWhatItExcitesAndSaysSo) {
  // A log in which nothing moves cannot separate inertia from friction.
  DeltaLog log = simulated(1, 0.0, 0, true, "fourier", 2.0);
  for (unsigned j = 0; j < 3; ++j) {
    for (std::size_t k = 0; k < log.size(); ++k) {
      log.q[j][k] = 0.4;
      log.qd[j][k] = 0.0;
      log.qdd[j][k] = 0.0;
    }
  }
  // By default the slow equations are left out: none is left, and the
  // joint is said not to have moved.
  try {
    fit_log(log, least_squares());
    FAIL() << "expected delta::InputError";
  } catch (const delta::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("sim-1: joint 1 did not move"), std::string::npos)
        << e.what();
  }
  // With every sample, only the static terms remain, as base parameters;
  // nothing the log does not excite gets a value.
  FitOptions every_sample = least_squares(model_named("lumped"));
  every_sample.min_speed_rad_s = 0.0;
  const FitResult r = fit_log(log, every_sample);
  ASSERT_TRUE(r.identifiability.has_value());
  EXPECT_NE(r.identifiability->message.find("does not excite 'arm_inertia'"), std::string::npos)
      << r.identifiability->message;
  for (const auto& e : r.parameters) {
    const bool excited = e.info.name == "arm_gravity_moment" || e.info.name == "platform_mass";
    if (!excited) {
      EXPECT_FALSE(e.identifiable()) << e.info.name;
    }
  }
  EXPECT_EQ(r.identifiability->independent.size(), 1u);  // one pose: gravity and weight mix
}

// A log in which joint 3 never moves: its inertia and friction are not
// excited, and its gravity moment and torque offset act alike (both
// constant). The fit estimates the base parameters: each value equals its
// named combination of the truth, and the torque is predicted exactly.
TEST(LeastSquaresTest, BaseParametersWhereAJointNeverMoves) {
  delta::LumpedParameters truth = delta::default_lumped_parameters();
  truth.torque_offset_Nm = {0.01, -0.02, 0.03};
  const DeltaLog log = testlogs::log_with_joint3_held(6.0, 0.35, truth);
  ModelOptions m = model_named("lumped");
  m.per_joint = true;
  m.offsets = true;
  FitOptions f = least_squares(m);
  f.min_speed_rad_s = 0.0;
  const FitResult r = fit_log(log, f);
  ASSERT_TRUE(r.identifiability.has_value());
  std::vector<std::string> dependent;
  for (const auto& e : r.parameters) {
    if (!e.identifiable()) dependent.push_back(e.info.name);
  }
  // Which of the gravity moment and the offset stands for the pair is the
  // pivoting's choice; the other three are not excited at all.
  ASSERT_EQ(dependent.size(), 4u);
  const auto has = [&](const std::string& n) {
    return std::find(dependent.begin(), dependent.end(), n) != dependent.end();
  };
  EXPECT_TRUE(has("arm_inertia_3") && has("viscous_friction_3") && has("coulomb_friction_3"));
  EXPECT_NE(has("torque_offset_3"), has("arm_gravity_moment_3"));
  EXPECT_LT(r.cost_Nm2, 1e-20);
  const std::vector<double> t = parameter_vector(m, truth);
  std::map<std::string, double> truth_of;
  for (std::size_t i = 0; i < t.size(); ++i) truth_of[r.parameters[i].info.name] = t[i];
  int combined = 0;
  for (const auto& e : r.parameters) {
    if (!e.identifiable()) continue;
    double expected = truth_of[e.info.name];
    for (const auto& [name, coefficient] : e.combined_with)
      expected += coefficient * truth_of[name];
    combined += e.combined_with.empty() ? 0 : 1;
    EXPECT_NEAR(e.value, expected, 1e-8 * (std::abs(expected) + 1e-3)) << e.combination;
  }
  EXPECT_EQ(combined, 1);  // the gravity moment and offset of joint 3
}

}  // namespace
}  // namespace host_id
