#include "host_id/friction_shape.hpp"

#include <chrono>
#include <cmath>

#include "delta/input_error.hpp"
#include "host_id/least_squares.hpp"
#include "host_id/regression.hpp"

namespace host_id {

namespace {

// The shape as natural logarithms: ln w, and ln vs where there is a term.
ModelOptions with_shape(ModelOptions m, const Eigen::VectorXd& ln_shape) {
  m.coulomb_smoothing_rad_s = std::exp(ln_shape(0));
  if (ln_shape.size() > 1) m.stribeck_velocity_rad_s = std::exp(ln_shape(1));
  return m;
}

// The fit's equations under a model: preprocessed, the fast rows first.
struct ShapeRegression {
  std::unique_ptr<Model> model;
  Regression all;
  std::size_t fast_rows{0};
  double sample_rate_hz{0};
};

ShapeRegression regression_for(const DeltaLog& log, const FitOptions& options,
                               const ModelOptions& m) {
  ShapeRegression s;
  s.model = make_model(m);
  PrepareOptions prepare = options.prepare;
  prepare.slow_rows_last_below_rad_s = min_speed_for(options);
  Preprocessed pre = preprocess(*s.model, log, prepare, options.threads);
  s.sample_rate_hz = pre.report.sample_rate_hz;
  s.all = std::move(pre.regression);
  s.fast_rows = pre.fast_rows;
  return s;
}

double profiled_cost(const DeltaLog& log, const FitOptions& options, const ModelOptions& m) {
  const ShapeRegression s = regression_for(log, options, m);
  return bounded_least_squares_cost(Equations(s.all, s.fast_rows), s.model->parameters(), log.name);
}

// Standard deviations of the log shape parameters: the Gauss-Newton
// covariance of the whole problem, the residual's derivative in each shape
// parameter (central differences) appended to the regressor as a column.
Eigen::VectorXd ln_shape_std(const DeltaLog& log, const FitOptions& options,
                             const Eigen::VectorXd& ln_shape) {
  const ModelOptions best = with_shape(options.model, ln_shape);
  ShapeRegression s = regression_for(log, options, best);
  const std::size_t lags = correlation_lags_for(s.sample_rate_hz, options.prepare.cutoff_hz);
  const Equations eq(s.all, s.fast_rows);
  const LeastSquaresResult ls =
      solve_least_squares(eq, s.model->parameters(), LsSolver::kQr, LsWeights::kNone, log.name);
  const Eigen::Index p = s.all.psi.cols();
  const Eigen::Index k = ln_shape.size();
  std::vector<ParameterInfo> infos = s.model->parameters();
  s.all.psi.conservative_resize_columns(p + k);
  constexpr double kStep = 0.01;  // in ln units: 1 %
  for (Eigen::Index i = 0; i < k; ++i) {
    Eigen::VectorXd up = ln_shape, down = ln_shape;
    up(i) += kStep;
    down(i) -= kStep;
    const ShapeRegression a = regression_for(log, options, with_shape(options.model, up));
    const ShapeRegression b = regression_for(log, options, with_shape(options.model, down));
    s.all.psi.col(p + i) = (a.all.psi - b.all.psi) * ls.beta / (2.0 * kStep);
    infos.push_back({i == 0 ? "ln_coulomb_smoothing" : "ln_stribeck_velocity", "-", false, ""});
  }
  const LeastSquaresResult aug = solve_least_squares(
      Equations(s.all, s.fast_rows), infos, LsSolver::kQr, LsWeights::kNone, log.name, lags);
  return aug.std_dev.tail(k);
}

}  // namespace

FrictionShapeResult fit_friction_shape(const DeltaLog& log, const FitOptions& options) {
  if (options.model.name == "paper14") {
    throw delta::InputError("--fit-friction-shape applies to --model delta and lumped only");
  }
  const auto t0 = std::chrono::steady_clock::now();
  const bool stribeck = options.model.stribeck_velocity_rad_s > 0.0;
  const Eigen::Index k = stribeck ? 2 : 1;
  Eigen::VectorXd lower(k), upper(k);
  lower(0) = std::log(kSmoothingMinRadS);
  upper(0) = std::log(kSmoothingMaxRadS);
  if (stribeck) {
    lower(1) = std::log(kStribeckMinRadS);
    upper(1) = std::log(kStribeckMaxRadS);
  }
  FrictionShapeResult r;
  r.cost_given_Nm2 = profiled_cost(log, options, options.model);
  PsoOptions pso;
  pso.particles = 8;
  pso.iterations = 40;
  pso.stall_iterations = 8;
  pso.stall_tolerance = 1e-9;
  pso.restarts = 0;
  pso.seed = options.pso.seed;
  const PsoResult best = run_pso(
      [&](const Eigen::VectorXd& ln_shape) {
        return profiled_cost(log, options, with_shape(options.model, ln_shape));
      },
      lower, upper, pso);
  r.evaluations = best.evaluations + 1;
  r.cost_fitted_Nm2 = best.best_cost;
  const Eigen::VectorXd std_ln = ln_shape_std(log, options, best.best);
  r.coulomb_smoothing_rad_s = std::exp(best.best(0));
  r.coulomb_smoothing_std = r.coulomb_smoothing_rad_s * std_ln(0);
  if (stribeck) {
    r.stribeck_velocity_rad_s = std::exp(best.best(1));
    r.stribeck_velocity_std = r.stribeck_velocity_rad_s * std_ln(1);
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace host_id
