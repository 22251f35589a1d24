// Tests of PSO on a fit's cost: it reaches the least-squares optimum.
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

TEST(PsoFitTest, PsoReachesTheLeastSquaresCostWhenTheOptimumIsInsideTheBounds) {
  const DeltaLog log = simulated(1, 0.015, 17, false);
  for (const auto topology : {PsoTopology::kGlobal, PsoTopology::kRing}) {
    FitOptions f;
    f.pso.topology = topology;
    const FitResult r = fit_log(log, f);
    ASSERT_TRUE(r.pso.has_value());
    EXPECT_TRUE(r.active_bounds.empty());
    EXPECT_LT((r.cost_Nm2 - r.ls_cost_Nm2) / r.ls_cost_Nm2, 1e-6);
    EXPECT_GE(r.cost_Nm2, r.ls_cost_Nm2 * (1.0 - 1e-12));  // LS is the exact optimum
    for (const auto& p : r.parameters) {
      EXPECT_NEAR(p.value, p.ls_value, 1e-3 * std::abs(p.ls_value) + 1e-9) << p.info.name;
    }
  }
}

// The default swarm stops at its first stall: the cost is a convex
// quadratic over a box, so the stall is at its one minimum. Restarting from
// there gains nothing above the stall tolerance, and costs every restart's
// stall window in iterations.
TEST(PsoFitTest, TheDefaultSwarmNeedsNoRestartOnTheConvexCost) {
  const DeltaLog log = simulated(2, 0.015, 17, false);
  for (const std::uint64_t seed : {1u, 2u, 3u}) {
    FitOptions f;
    f.pso.seed = seed;
    const FitResult once = fit_log(log, f);
    ASSERT_TRUE(once.pso.has_value());
    EXPECT_EQ(once.pso->restarts_done, 0u);
    EXPECT_EQ(once.pso->stop_reason, "stall");
    EXPECT_LT(std::abs(once.cost_Nm2 / once.ls_cost_Nm2 - 1.0), 1e-12) << "seed " << seed;
    f.pso.restarts = 2;
    const FitResult twice = fit_log(log, f);
    EXPECT_EQ(twice.pso->restarts_done, 2u);
    EXPECT_EQ(twice.pso->iterations, once.pso->iterations + 2 * f.pso.stall_iterations);
    EXPECT_GT(twice.cost_Nm2, once.cost_Nm2 * (1.0 - 1e-12)) << "seed " << seed;
  }
}

// Where the unconstrained optimum breaks a physical bound (the lumped model
// on the multibody robot drives viscous_friction_3 below 0), least squares
// returns the bounded optimum, names the active bound, and PSO reaches the
// same cost to 1e-6.
TEST(PsoFitTest, LeastSquaresAndPsoAgreeOnTheBoundedOptimum) {
  const DeltaLog log = multibody_log(delta::default_robot_description());
  FitOptions f;
  f.model = model_named("lumped");
  const FitResult r = fit_log(log, f);
  ASSERT_TRUE(r.pso.has_value());
  ASSERT_EQ(r.active_bounds, std::vector<std::string>{"viscous_friction_3"});
  EXPECT_LT(std::abs(r.cost_Nm2 / r.ls_cost_Nm2 - 1.0), 1e-6);
  for (const auto& e : r.parameters) {
    if (e.info.nonnegative) {
      EXPECT_GE(e.ls_value, 0.0) << e.info.name;
    }
    if (e.info.name == "viscous_friction_3") {
      EXPECT_TRUE(e.at_bound);
      EXPECT_EQ(e.ls_value, 0.0);
      EXPECT_LT(e.unconstrained_value, 0.0);
      EXPECT_LT(e.value, 1e-4);
    }
  }
}

TEST(PsoFitTest, PsoIsDeterministicForASeed) {
  const DeltaLog log = simulated(1, 0.015, 0, false, "fourier", 4.0);
  FitOptions f;
  f.pso.seed = 42;
  const FitResult a = fit_log(log, f);
  const FitResult b = fit_log(log, f);
  EXPECT_EQ(a.beta, b.beta);
  EXPECT_EQ(a.pso->evaluations, b.pso->evaluations);
  f.pso.seed = 43;
  const FitResult c = fit_log(log, f);
  EXPECT_NE(a.beta, c.beta);
}

// A swarm that stops short of the optimum (here: far too few iterations)
// is not reported as a fit: the error names the gap and the remedies.
TEST(PsoFitTest, ASwarmShortOfTheOptimumIsRefused) {
  const DeltaLog log = simulated(1, 0.015, 0, false, "fourier", 4.0);
  FitOptions f;
  f.pso.iterations = 30;
  try {
    (void)fit_log(log, f);
    FAIL() << "a swarm of 30 iterations was reported as the fit";
  } catch (const PsoShortOfOptimumError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind(log.name + ": PSO stopped at a cost ", 0), 0u) << what;
    EXPECT_NE(what.find("above the optimum of the same bounded problem"), std::string::npos);
    EXPECT_NE(what.find("use --method ls (the exact optimum)"), std::string::npos);
  }
}

}  // namespace
}  // namespace host_id
