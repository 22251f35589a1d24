// Tests of preprocess: from a log to its regression, against the plain definitions.
#include "host_id/preprocess.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <map>

#include "delta/input_error.hpp"
#include "delta/splitmix.hpp"
#include "fit_fixtures.hpp"
#include "held_joint_log.hpp"
#include "host_id/identify.hpp"
#include "host_id/least_squares.hpp"
#include "host_id/predict.hpp"
#include "host_id/preprocess.hpp"
#include "host_id/regression.hpp"
#include "host_id/simulate.hpp"

namespace host_id {
namespace {

using namespace test;

TEST(PreprocessTest, EstimatedDerivativesOnNoiseFreeLogStayWithinOneTenThousandth) {
  // No qd/qdd columns: filtered q, five-point differences, parallel filtering.
  const DeltaLog log = simulated(1, 0.0, 0, false);
  const FitResult r = fit_log(log, least_squares());
  EXPECT_LT(max_relative_error(r, parameter_vector({}, delta::default_lumped_parameters())), 1e-4);
}

// The regressor is built and filtered on several threads for long logs:
// the same regression, bit for bit, as on one.
TEST(PreprocessTest, PreprocessingOnSeveralThreadsGivesTheSameRegression) {
  // 45 001 samples: two workers (one per 20 000 samples, up to the threads given).
  const DeltaLog log = simulated(3, 0.01, 17, false, "fourier", 45.0);
  const auto model = make_model({});
  const Regression one = preprocess(*model, log, PrepareOptions{}, 1).regression;
  const Regression three = preprocess(*model, log, PrepareOptions{}, 3).regression;
  ASSERT_EQ(one.rows(), three.rows());
  EXPECT_TRUE(one.psi == three.psi);
  EXPECT_TRUE(one.tau == three.tau);
  EXPECT_EQ(one.velocity_rad_s, three.velocity_rad_s);
  // And the unfiltered rows' moments (the RMSE against the measured torque).
  for (unsigned j = 0; j < 3; ++j) {
    EXPECT_EQ(one.measured.rows[j], three.measured.rows[j]);
    EXPECT_TRUE(one.measured.psi_t_psi[j] == three.measured.psi_t_psi[j]) << j;
    EXPECT_TRUE(one.measured.psi_t_tau[j] == three.measured.psi_t_tau[j]) << j;
    EXPECT_EQ(one.measured.tau_sq[j], three.measured.tau_sq[j]) << j;
  }
  // So is the solve (135 003 rows: the Gram matrix and the covariance on two
  // threads), to the last bit.
  const LeastSquaresResult ls1 =
      solve_least_squares(one, *model, LsSolver::kQr, LsWeights::kNone, log.name, 100, 1);
  const LeastSquaresResult ls3 =
      solve_least_squares(one, *model, LsSolver::kQr, LsWeights::kNone, log.name, 100, 3);
  EXPECT_TRUE(ls1.beta == ls3.beta);
  EXPECT_TRUE(ls1.std_dev == ls3.std_dev);
  EXPECT_TRUE(ls1.psi_t_psi == ls3.psi_t_psi);
}

// What a fit uses: the same regression, with the log's samples freed on the
// way (the log keeps its name, geometry and gaps).
TEST(PreprocessTest, PreprocessingThatReleasesTheLogGivesTheSameRegression) {
  DeltaLog log = simulated(3, 0.01, 17, false, "fourier", 5.0);
  log.gaps.push_back({2000, 7, "a test gap"});
  const auto model = make_model({});
  const Preprocessed kept = preprocess(*model, log, PrepareOptions{});
  const Preprocessed released = preprocess_releasing(*model, log, PrepareOptions{});
  EXPECT_TRUE(kept.regression.psi == released.regression.psi);
  EXPECT_TRUE(kept.regression.tau == released.regression.tau);
  EXPECT_EQ(kept.regression.t_s, released.regression.t_s);
  EXPECT_EQ(kept.report.samples_in_log, released.report.samples_in_log);
  EXPECT_EQ(released.report.samples_in_log, 5001u);
  EXPECT_EQ(log.size(), 0u);
  EXPECT_TRUE(log.tau[0].empty());
  EXPECT_EQ(log.gaps.size(), 1u);
  EXPECT_FALSE(log.name.empty());
}

// A log preprocessed once for the friction's shape gives, for another
// shape, bit for bit what preprocessing with that shape gives: every value
// of psi and tau, the fast rows and each joint's nonzero columns; on a log
// with a gap (two segments) and on one with logged derivatives (nothing
// filtered), with one shape term (Coulomb) and two (with Stribeck), on one
// thread and on two.
TEST(PreprocessTest, AnotherFrictionShapeGivesWhatPreprocessingWithItGives) {
  DeltaLog with_gap = simulated(4, 0.01, 17, false, "fourier", 24.0);
  with_gap.gaps.push_back({9000, 0, "a test gap"});
  const DeltaLog with_derivatives = simulated(5, 0.01, 0, true);
  PrepareOptions prepare;
  prepare.slow_rows_last_below_rad_s = 0.05;
  for (const DeltaLog* log : {static_cast<const DeltaLog*>(&with_gap), &with_derivatives}) {
    for (const std::string name : {"delta", "lumped"}) {
      for (const double stribeck : {0.0, 0.2}) {
        for (const unsigned threads : {1u, 2u}) {
          SCOPED_TRACE(log->name + " " + name + " stribeck " + std::to_string(stribeck) +
                       " threads " + std::to_string(threads));
          ModelOptions first = model_named(name);
          first.stribeck_velocity_rad_s = stribeck;
          ModelOptions other = first;
          other.coulomb_smoothing_rad_s = 0.035;
          if (stribeck > 0.0) other.stribeck_velocity_rad_s = 0.07;
          // A Stribeck velocity so small that the term underflows to zero
          // at every sample: its columns leave the joints' nonzero columns,
          // and come back with the next shape.
          ModelOptions vanishing = first;
          if (stribeck > 0.0) vanishing.stribeck_velocity_rad_s = 1e-6;
          ShapePreprocess shapes(*make_model(first), *log, prepare, threads);
          for (const ModelOptions& m : {other, vanishing, first}) {
            const auto model = make_model(m);
            const Preprocessed& got = shapes.with_shape(*model);
            const Preprocessed want = preprocess(*model, *log, prepare, threads);
            EXPECT_TRUE(got.regression.psi == want.regression.psi);
            EXPECT_TRUE(got.regression.tau == want.regression.tau);
            EXPECT_EQ(got.fast_rows, want.fast_rows);
            EXPECT_EQ(got.regression.joint_columns, want.regression.joint_columns);
            EXPECT_EQ(got.regression.measured.rows[0], 0u) << "moments of another shape";
          }
        }
      }
    }
  }
}

// Preprocessing asked for the slow rows last builds, filters and labels
// every row in its place: bit for bit the time-ordered regression with its
// rows reordered, on one thread and on two, on a log with a gap (two
// segments, each with its trimmed ends).
TEST(PreprocessTest, SlowRowsLastAreBuiltInTheirPlaceAsTheTimeOrderedOnesReordered) {
  DeltaLog log = simulated(4, 0.01, 17, false, "fourier", 24.0);  // 2 workers from 20 000 samples
  log.gaps.push_back({9000, 0, "a test gap"});
  const auto model = make_model({});
  const Regression in_time = preprocess(*model, log, PrepareOptions{}, 1).regression;
  const std::vector<Eigen::Index> order = fast_then_slow(in_time, 0.1);
  PrepareOptions slow_last;
  slow_last.slow_rows_last_below_rad_s = 0.1;
  for (const unsigned threads : {1u, 2u}) {
    SCOPED_TRACE(threads);
    const Preprocessed pre = preprocess(*model, log, slow_last, threads);
    const Regression& r = pre.regression;
    ASSERT_EQ(r.rows(), in_time.rows());
    std::size_t fast = 0;
    for (std::size_t row = 0; row < in_time.rows(); ++row) {
      fast += std::abs(in_time.velocity_rad_s[row]) >= 0.1 ? 1u : 0u;
    }
    EXPECT_EQ(pre.fast_rows, fast);
    EXPECT_GT(fast, r.rows() / 2);
    EXPECT_LT(fast, r.rows());
    EXPECT_EQ(r.t_s, in_time.t_s);
    for (std::size_t row = 0; row < r.rows(); ++row) {
      const Eigen::Index from = order[row];
      const auto i = static_cast<Eigen::Index>(row);
      const auto k = static_cast<std::size_t>(from);
      ASSERT_EQ(r.joint[row], in_time.joint[k]) << row;
      ASSERT_EQ(r.sample[row], in_time.sample[k]) << row;
      ASSERT_EQ(r.velocity_rad_s[row], in_time.velocity_rad_s[k]) << row;
      ASSERT_EQ(r.tau(i), in_time.tau(from)) << row;
      ASSERT_EQ(r.psi.row(i), in_time.psi.row(from)) << row;
    }
    // The unfiltered moments are over every row alike.
    EXPECT_EQ(r.measured.rows, in_time.measured.rows);
  }
  // Without a threshold, the rows are in time order.
  EXPECT_EQ(preprocess(*model, log, PrepareOptions{}, 2).fast_rows, in_time.rows());
}

TEST(PreprocessTest, GapsSplitTheLogIntoSegmentsThatAreNotBridged) {
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
  EXPECT_LT(max_relative_error(r, parameter_vector({}, delta::default_lumped_parameters())), 1e-3);
}

TEST(PreprocessTest, CutoffAboveNyquistIsRejected) {
  const DeltaLog log = simulated(1, 0.0, 0, false, "fourier", 1.0);
  FitOptions f = least_squares();
  f.prepare.cutoff_hz = 600.0;
  try {
    fit_log(log, f);
    FAIL();
  } catch (const delta::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("must lie between 0 and the Nyquist frequency 500 Hz"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace host_id

// Timestamps that jitter (docs/preprocessing.md, "Timestamps"): a log
// sampled evenly at 1 kHz whose timestamps are off by up to +-0.2 ms, as a
// host-side logger stamps them. Differentiated on those times the fit is
// wrong (the test measures how wrong); so `check` refuses the log naming
// the spread and the options, and `nominal` differentiates at the median
// step and gets the clean log's fit back.
namespace host_id {
namespace {

TEST(TimeStepsTest, JitteredTimestampsAreRefusedAndTheNominalPeriodFitsThemRight) {
  using namespace test;
  const DeltaLog clean = simulated(11, 0.0, 17, false, "fourier", 8.0);
  DeltaLog jittered = clean;
  delta::SplitMix64 rng(5);
  for (std::size_t i = 1; i + 1 < jittered.size(); ++i) {
    jittered.t[i] += 2e-4 * (2.0 * rng.uniform() - 1.0);
  }
  const TimeStepSpread spread = time_step_spread(jittered);
  EXPECT_NEAR(spread.median_s, 1e-3, 2e-5);
  EXPECT_GT(spread.spread, kTimeStepError);
  EXPECT_LT(time_step_spread(clean).spread, 1e-9);

  FitOptions o = least_squares(model_named("lumped"));
  try {
    (void)fit_log(jittered, o);
    ADD_FAILURE() << "a log with jittered timestamps was fitted silently";
  } catch (const delta::InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(": the time steps spread by "), std::string::npos) << what;
    EXPECT_NE(what.find("use --time-steps nominal"), std::string::npos) << what;
  }
  const FitResult reference = fit_log(clean, o);
  o.prepare.time_steps = TimeSteps::kAsLogged;
  const FitResult as_logged = fit_log(jittered, o);
  o.prepare.time_steps = TimeSteps::kNominal;
  const FitResult nominal = fit_log(jittered, o);
  const auto error = [&reference](const FitResult& r) {
    double worst = 0;
    for (std::size_t k = 0; k < r.parameters.size(); ++k) {
      const double ref = reference.parameters[k].value;
      worst = std::max(worst, std::abs(r.parameters[k].value - ref) / std::abs(ref));
    }
    return worst;
  };
  std::cout << "[ jitter ] largest parameter error against the clean log's fit: as logged "
            << error(as_logged) << ", nominal " << error(nominal) << "\n";
  EXPECT_GT(error(as_logged), 0.05) << "the wrong fit the check prevents";
  EXPECT_LT(error(nominal), 1e-9);  // measured 1e-14
}

// An hour-long log's spread is taken from 65536 evenly spaced steps, its
// largest departure from all of them: the same verdicts as the whole.
TEST(TimeStepsTest, ALongLogsSpreadComesFromASampleOfItsSteps) {
  DeltaLog log;
  log.name = "long";
  const std::size_t n = 400000;
  log.t.resize(n);
  delta::SplitMix64 rng(8);
  for (std::size_t i = 0; i < n; ++i) log.t[i] = 1e-3 * static_cast<double>(i);
  EXPECT_LT(time_step_spread(log).spread, 1e-9);
  for (std::size_t i = 1; i + 1 < n; ++i) log.t[i] += 2e-4 * (2.0 * rng.uniform() - 1.0);
  log.t[n / 2 + 1] = log.t[n / 2] + 1.9e-3;  // one far step, which only the full pass sees
  const TimeStepSpread s = time_step_spread(log);
  EXPECT_NEAR(s.median_s, 1e-3, 1e-5);
  EXPECT_GT(s.spread, kTimeStepError);
  EXPECT_LT(s.spread, 0.3);
  EXPECT_GT(s.largest, 0.85);
}

TEST(TimeStepsTest, ASmallSpreadIsAWarningAndLoggedDerivativesAreNotChecked) {
  using namespace test;
  DeltaLog log = simulated(12, 0.0, 17, false, "fourier", 4.0);
  delta::SplitMix64 rng(6);
  for (std::size_t i = 1; i + 1 < log.size(); ++i) log.t[i] += 3e-5 * (2.0 * rng.uniform() - 1.0);
  const std::string w = check_time_steps(log, TimeSteps::kCheck);
  EXPECT_NE(w.find("if the samples were taken evenly, --time-steps nominal is more accurate"),
            std::string::npos)
      << w;
  EXPECT_EQ(check_time_steps(log, TimeSteps::kAsLogged), "");
  DeltaLog with_derivatives = simulated(12, 0.0, 17, true, "fourier", 4.0);
  for (std::size_t i = 1; i + 1 < with_derivatives.size(); ++i) {
    with_derivatives.t[i] += 3e-4 * (2.0 * rng.uniform() - 1.0);
  }
  EXPECT_EQ(check_time_steps(with_derivatives, TimeSteps::kCheck), "");
}

// A fast pick-and-place on the multibody robot (0.25 s segments: up to 73
// rad/s^2) from the log's own 17-bit states against from the exact states:
// the model fitted on a Fourier log predicts each, and both are scored
// against the exact torque. The bar is 1.2x; with q filtered at 20 Hz
// whatever the log (before the cut-off came from the log's content) it
// was 1.3-1.8x.
std::array<double, 3> rmse_against(const PredictedLog& p, const DeltaLog& exact) {
  std::map<long, std::size_t> at;  // exact's sample by its time in ms
  for (std::size_t i = 0; i < exact.size(); ++i) at[std::lround(exact.t[i] * 1000.0)] = i;
  std::array<double, 3> sum{};
  for (std::size_t k = 0; k < p.log.size(); ++k) {
    const std::size_t i = at.at(std::lround(p.log.t[k] * 1000.0));
    for (unsigned j = 0; j < 3; ++j) {
      sum[j] += std::pow(p.log.extra_columns[j].second[k] - exact.tau[j][i], 2);
    }
  }
  for (double& v : sum) v = std::sqrt(v / static_cast<double>(p.log.size()));
  return sum;
}

TEST(StatesTest, FastPickAndPlacePredictionsFromTheLogsOwnStatesNearlyMatchExactStates) {
  const delta::RobotDescription robot = delta::default_robot_description();
  const FitResult fit = fit_log(multibody_log(robot), least_squares(model_named("delta")));
  const auto model = make_model(fit.options.model);
  SimulateOptions o;
  o.plant = SimulatedPlant::kMujoco;
  o.robot = robot;
  o.trajectory = "pick-and-place";
  o.segment_duration_s = 0.25;
  o.seed = 5;
  o.with_derivatives = true;
  const DeltaLog exact = simulate_log(o);
  o.with_derivatives = false;
  o.torque_noise = 0.015;
  o.encoder_bits = 17;
  const DeltaLog measured = simulate_log(o);
  const PredictedLog from_exact = predict_log(*model, fit.beta, exact, fit.options.prepare, "");
  const auto exact_rmse = rmse_against(from_exact, exact);
  PrepareOptions fixed = fit.options.prepare;
  fixed.state_cutoff_hz = fit.options.prepare.cutoff_hz;
  double worst_fixed = 0.0;
  for (const PrepareOptions& prepare : {fit.options.prepare, fixed}) {
    const PredictedLog p = predict_log(*model, fit.beta, measured, prepare, "");
    const auto rmse = rmse_against(p, exact);
    std::cout << p.report.derivatives << "\n";
    for (unsigned j = 0; j < 3; ++j) {
      const double ratio = rmse[j] / exact_rmse[j];
      std::cout << "  joint " << j + 1 << ": " << rmse[j] << " N m from the log's states, "
                << exact_rmse[j] << " from the exact ones (" << ratio << "x)\n";
      if (prepare.state_cutoff_hz) {
        worst_fixed = std::max(worst_fixed, ratio);
      } else {
        EXPECT_LE(ratio, 1.2) << "joint " << j + 1;
      }
    }
  }
  EXPECT_GT(worst_fixed, 1.25);  // the test tells the two apart
}

}  // namespace
}  // namespace host_id
