// Identification against known truth: logs simulated from the default
// robot's parameters, fitted back.
#include "host_id/identify.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "host_id/input_error.hpp"
#include "host_id/regression.hpp"
#include "host_id/simulate.hpp"

namespace host_id {
namespace {

DeltaLog simulated(std::uint64_t seed, double noise, unsigned bits, bool derivatives,
                   const std::string& trajectory = "fourier", double duration_s = 8.0) {
  SimulateOptions o;
  o.seed = seed;
  o.torque_noise = noise;
  o.encoder_bits = bits;
  o.with_derivatives = derivatives;
  o.trajectory = trajectory;
  o.duration_s = duration_s;
  o.base_frequency_hz = 0.25;
  DeltaLog log = simulate_log(o);
  log.name = "sim-" + std::to_string(seed);
  return log;
}

FitOptions least_squares(ModelOptions m = {}) {
  FitOptions f;
  f.model = m;
  f.method = Method::kLeastSquares;
  return f;
}

double max_relative_error(const FitResult& r, const std::vector<double>& truth) {
  double worst = 0.0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    worst = std::max(worst, std::abs(r.parameters[i].value - truth[i]) / std::abs(truth[i]));
  }
  return worst;
}

TEST(IdentifyTest, LeastSquaresRecoversTruthExactlyFromNoiseFreeStates) {
  const DeltaLog log = simulated(1, 0.0, 0, true);
  delta::LumpedParameters truth = delta::default_lumped_parameters();
  for (const bool per_joint : {false, true}) {
    ModelOptions m;
    m.per_joint = per_joint;
    const FitResult r = fit_log(log, least_squares(m));
    EXPECT_LT(max_relative_error(r, delta_parameter_vector(m, truth)), 1e-6) << per_joint;
    EXPECT_LT(r.cost_Nm2, 1e-20);
  }
  // Per-joint parameters and offsets, with a truth that differs per joint.
  truth.arm_inertia_kg_m2 = {7.0e-3, 7.4e-3, 6.9e-3};
  truth.arm_gravity_moment_Nm = {0.43, 0.45, 0.44};
  truth.torque_offset_Nm = {0.02, -0.03, 0.01};
  SimulateOptions o;
  o.with_derivatives = true;
  o.duration_s = 8.0;
  o.parameters = truth;
  const DeltaLog log2 = simulate_log(o);
  ModelOptions m;
  m.per_joint = true;
  m.offsets = true;
  const FitResult r = fit_log(log2, least_squares(m));
  ASSERT_EQ(r.parameters.size(), 16u);
  EXPECT_LT(max_relative_error(r, delta_parameter_vector(m, truth)), 1e-6);
}

TEST(IdentifyTest, EstimatedDerivativesOnNoiseFreeLogStayWithinOneTenThousandth) {
  // No qd/qdd columns: filtered q, five-point differences, parallel filtering.
  const DeltaLog log = simulated(1, 0.0, 0, false);
  const FitResult r = fit_log(log, least_squares());
  EXPECT_LT(max_relative_error(r, delta_parameter_vector({}, delta::default_lumped_parameters())),
            1e-4);
}

TEST(IdentifyTest, RealisticNoiseGivesParametersWithinAFewPercentAndValidationHolds) {
  // 1.5 % torque noise and 17-bit encoders; fit on one path, validate on a
  // second Fourier path and a pick-and-place path.
  const DeltaLog fit_path = simulated(1, 0.015, 17, false, "fourier", 10.0);
  const FitResult r = fit_log(fit_path, least_squares());
  const auto truth = delta_parameter_vector({}, delta::default_lumped_parameters());
  for (std::size_t i = 0; i < truth.size(); ++i) {
    EXPECT_NEAR(r.parameters[i].value, truth[i], 0.03 * truth[i]) << r.parameters[i].info.name;
    // The reported standard deviation is honest: the error is within 5 sigma.
    EXPECT_LT(std::abs(r.parameters[i].value - truth[i]),
              5.0 * r.parameters[i].std_dev + 1e-3 * truth[i])
        << r.parameters[i].info.name;
  }
  const auto model = make_model({});
  for (const auto& [seed, trajectory] :
       std::vector<std::pair<int, std::string>>{{2, "fourier"}, {3, "pick-and-place"}}) {
    const DeltaLog v =
        simulated(static_cast<std::uint64_t>(seed), 0.015, 17, false, trajectory, 10.0);
    const Prediction p = predict(*model, r.beta, v, FitOptions{}.prepare, 0);
    for (unsigned j = 0; j < 3; ++j) {
      EXPECT_LT(p.rmse_Nm[j], 1.5 * r.fit.rmse_Nm[j]) << trajectory << " joint " << j + 1;
    }
  }
}

TEST(IdentifyTest, PaperModelShowsTheValidationGapThatTheDeltaModelDoesNot) {
  const DeltaLog fit_path = simulated(1, 0.015, 17, false, "fourier", 10.0);
  const DeltaLog pnp = simulated(3, 0.015, 17, false, "pick-and-place", 10.0);
  ModelOptions paper;
  paper.name = "paper14";
  const FitResult rp = fit_log(fit_path, least_squares(paper));
  const FitResult rd = fit_log(fit_path, least_squares());
  ASSERT_EQ(rp.parameters.size(), 14u);
  const Prediction vp = predict(*make_model(paper), rp.beta, pnp, FitOptions{}.prepare, 0);
  const Prediction vd = predict(*make_model({}), rd.beta, pnp, FitOptions{}.prepare, 0);
  for (unsigned j = 0; j < 3; ++j) {
    // Constant lambda cannot follow the forearm forces: a worse fit, and a
    // validation error that grows away from the fitted path.
    EXPECT_GT(rp.fit.rmse_Nm[j], 5.0 * rd.fit.rmse_Nm[j]);
    EXPECT_GT(vp.rmse_Nm[j], 1.5 * rp.fit.rmse_Nm[j]);
    EXPECT_LT(vd.rmse_Nm[j], 1.5 * rd.fit.rmse_Nm[j]);
  }
}

TEST(IdentifyTest, NormalEquationCostEqualsDirectSumOfSquares) {
  const DeltaLog log = simulated(4, 0.02, 17, false);
  const auto model = make_model({});
  const Samples s = prepare_samples(log, PrepareOptions{});
  const Regression reg = build_regression(*model, log.geometry, log.gravity_m_s2, s, log.name);
  const NormalEquationCost fast(reg);
  Eigen::VectorXd beta = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(model->size()));
  for (int trial = 0; trial < 20; ++trial) {
    for (Eigen::Index i = 0; i < beta.size(); ++i) {
      beta(i) = 0.1 * std::sin(1.7 * static_cast<double>(trial * 13 + i)) + 0.05;
    }
    const double direct = direct_cost(reg, beta);
    EXPECT_NEAR(fast(beta), direct, 1e-10 * direct);
  }
}

TEST(IdentifyTest, PsoReachesTheLeastSquaresCostWhenTheOptimumIsInsideTheBounds) {
  const DeltaLog log = simulated(1, 0.015, 17, false);
  for (const auto topology : {PsoTopology::kGlobal, PsoTopology::kRing}) {
    FitOptions f;
    f.pso.topology = topology;
    const FitResult r = fit_log(log, f);
    ASSERT_TRUE(r.pso.has_value());
    EXPECT_TRUE(r.ls_outside_bounds.empty());
    EXPECT_LT((r.cost_Nm2 - r.ls_cost_Nm2) / r.ls_cost_Nm2, 1e-6);
    EXPECT_GE(r.cost_Nm2, r.ls_cost_Nm2 * (1.0 - 1e-12));  // LS is the exact optimum
    for (const auto& p : r.parameters) {
      EXPECT_NEAR(p.value, p.ls_value, 1e-3 * std::abs(p.ls_value) + 1e-9) << p.info.name;
    }
  }
}

TEST(IdentifyTest, PsoIsDeterministicForASeed) {
  const DeltaLog log = simulated(1, 0.015, 0, false, "fourier", 4.0);
  FitOptions f;
  f.pso.iterations = 300;
  f.pso.seed = 42;
  const FitResult a = fit_log(log, f);
  const FitResult b = fit_log(log, f);
  EXPECT_EQ(a.beta, b.beta);
  EXPECT_EQ(a.pso->evaluations, b.pso->evaluations);
  f.pso.seed = 43;
  const FitResult c = fit_log(log, f);
  EXPECT_NE(a.beta, c.beta);
}

TEST(IdentifyTest, ATrajectoryThatDoesNotExciteAParameterIsRejectedByName) {
  // A log in which nothing moves cannot separate inertia from friction.
  DeltaLog log = simulated(1, 0.0, 0, true, "fourier", 2.0);
  for (unsigned j = 0; j < 3; ++j) {
    for (std::size_t k = 0; k < log.size(); ++k) {
      log.q[j][k] = 0.4;
      log.qd[j][k] = 0.0;
      log.qdd[j][k] = 0.0;
    }
  }
  try {
    fit_log(log, least_squares());
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("is not excited at all by this log"), std::string::npos)
        << e.what();
  }
}

TEST(IdentifyTest, GapsSplitTheLogIntoSegmentsThatAreNotBridged) {
  DeltaLog log = simulated(1, 0.0, 0, false, "fourier", 6.0);
  // Remove samples 3000..3099: the reader would report this gap.
  const std::size_t b = 3000, e = 3100;
  log.t.erase(log.t.begin() + b, log.t.begin() + e);
  log.seq.erase(log.seq.begin() + b, log.seq.begin() + e);
  for (unsigned j = 0; j < 3; ++j) {
    log.q[j].erase(log.q[j].begin() + b, log.q[j].begin() + e);
    log.tau[j].erase(log.tau[j].begin() + b, log.tau[j].begin() + e);
  }
  log.gaps.push_back({b, 0, "seq jumps"});
  const FitResult r = fit_log(log, least_squares());
  EXPECT_EQ(r.segments_used, 2u);
  // Each segment loses 150 samples at each end: 5901 - 4 * 150.
  EXPECT_EQ(r.fit.samples, 5901u - 4u * 150u);
  // Had the gap been bridged, the differentiated angles would jump there and
  // ruin the fit; it stays as good as without a gap.
  EXPECT_LT(max_relative_error(r, delta_parameter_vector({}, delta::default_lumped_parameters())),
            1e-3);
}

TEST(IdentifyTest, CutoffAboveNyquistIsRejected) {
  const DeltaLog log = simulated(1, 0.0, 0, false, "fourier", 1.0);
  FitOptions f = least_squares();
  f.prepare.cutoff_hz = 600.0;
  try {
    fit_log(log, f);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("must lie between 0 and the Nyquist frequency 500 Hz"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace host_id
