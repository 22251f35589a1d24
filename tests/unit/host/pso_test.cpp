#include "host_id/pso.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace host_id {
namespace {

TEST(PsoTest, FindsTheMinimumOfAnIllConditionedQuadratic) {
  Eigen::VectorXd target(4);
  target << 0.3, -1.2, 4.0, 0.01;
  Eigen::VectorXd scale(4);
  scale << 1.0, 10.0, 0.1, 100.0;
  const auto cost = [&](const Eigen::VectorXd& x) {
    return (x - target).cwiseProduct(scale).squaredNorm() + 2.5;
  };
  PsoOptions o;
  o.iterations = 5000;
  const PsoResult r =
      run_pso(cost, Eigen::VectorXd::Constant(4, -5.0), Eigen::VectorXd::Constant(4, 5.0), o);
  EXPECT_NEAR(r.best_cost, 2.5, 1e-12);
  for (Eigen::Index i = 0; i < 4; ++i) EXPECT_NEAR(r.best(i), target(i), 1e-5);
  EXPECT_EQ(r.evaluations, o.particles * (r.iterations + 1) + o.particles * r.restarts_done);
}

// A cost given over the normalised coordinates is the same search: the
// same seed gives the same swarm, point for point, as the cost at beta.
TEST(PsoTest, ACostOverNormalisedCoordinatesGivesTheSameSwarm) {
  const Eigen::VectorXd lower = Eigen::Vector3d(-1.0, 0.0, 2.0);
  const Eigen::VectorXd upper = Eigen::Vector3d(1.0, 4.0, 2.5);
  const auto at_beta = [](const Eigen::VectorXd& b) {
    return std::pow(b(0) - 0.2, 2) + 3.0 * std::pow(b(1) - 1.0, 2) + std::pow(b(2) - 2.1, 4);
  };
  const auto at_u = [&](const double* u) {
    const Eigen::Map<const Eigen::Vector3d> point(u);
    return at_beta(lower + point.cwiseProduct(upper - lower));
  };
  PsoOptions o;
  o.iterations = 300;
  const PsoResult a = run_pso(at_beta, lower, upper, o);
  const PsoResult b = run_pso_normalized(at_u, lower, upper, o);
  EXPECT_EQ(a.best, b.best);
  EXPECT_EQ(a.best_cost, b.best_cost);
  EXPECT_EQ(a.evaluations, b.evaluations);
  EXPECT_NEAR(b.best(0), 0.2, 1e-4);
  EXPECT_NEAR(b.best(1), 1.0, 1e-4);
}

TEST(PsoTest, AnOptimumOutsideTheBoxEndsOnTheBound) {
  // min (x + 1)^2 + (y - 2)^2 over [0, 1]^2 is at (0, 1).
  const auto cost = [](const Eigen::VectorXd& x) {
    return std::pow(x(0) + 1.0, 2) + std::pow(x(1) - 2.0, 2);
  };
  PsoOptions o;
  o.iterations = 2000;
  const PsoResult r = run_pso(cost, Eigen::VectorXd::Zero(2), Eigen::VectorXd::Ones(2), o);
  EXPECT_DOUBLE_EQ(r.best(0), 0.0);
  EXPECT_DOUBLE_EQ(r.best(1), 1.0);
  EXPECT_GT(r.particles_on_bound, 0u);
}

TEST(PsoTest, StopsOnStallAndRestartsFirst) {
  const auto flat = [](const Eigen::VectorXd&) { return 1.0; };
  PsoOptions o;
  o.iterations = 100000;
  o.stall_iterations = 50;
  o.restarts = 3;
  const PsoResult r = run_pso(flat, Eigen::VectorXd::Zero(3), Eigen::VectorXd::Ones(3), o);
  EXPECT_EQ(r.stop_reason, "stall");
  EXPECT_EQ(r.restarts_done, 3u);
  EXPECT_LT(r.iterations, 300u);
}

TEST(PsoTest, ReportsProgress) {
  const auto cost = [](const Eigen::VectorXd& x) { return x.squaredNorm(); };
  PsoOptions o;
  o.iterations = 500;
  o.stall_iterations = 100000;
  std::size_t calls = 0, last = 0;
  o.progress = [&](std::size_t it, std::size_t max, double) {
    ++calls;
    last = it;
    EXPECT_EQ(max, 500u);
  };
  run_pso(cost, Eigen::VectorXd::Constant(2, -1.0), Eigen::VectorXd::Ones(2), o);
  EXPECT_EQ(calls, 6u);  // every 100 iterations, and once at the end
  EXPECT_EQ(last, 500u);
}

}  // namespace
}  // namespace host_id
