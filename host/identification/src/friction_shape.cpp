#include "host_id/friction_shape.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>

#include "delta/input_error.hpp"
#include "host_id/least_squares.hpp"
#include "host_id/model_selection.hpp"
#include "host_id/preprocess.hpp"
#include "host_id/regression.hpp"

namespace host_id {

namespace {

// The shape as natural logarithms: ln w, and ln vs where there is a term.
ModelOptions with_shape(ModelOptions m, const Eigen::VectorXd& ln_shape) {
  m.coulomb_smoothing_rad_s = std::exp(ln_shape(0));
  if (ln_shape.size() > 1) m.stribeck_velocity_rad_s = std::exp(ln_shape(1));
  return m;
}

// The log preprocessed for the given model's shape, the fast rows first:
// each shape tried after it recomputes only the columns the shape changes.
ShapePreprocess preprocess_for_shapes(const DeltaLog& log, const FitOptions& options) {
  PrepareOptions prepare = options.prepare;
  prepare.slow_rows_last_below_rad_s = min_speed_for(options);
  return ShapePreprocess(*make_model(options.model), log, prepare, options.threads);
}

// The bounded least-squares cost of the log's fast rows under model m.
double profiled_cost(ShapePreprocess& pre, const ModelOptions& m, const std::string& log_name) {
  const std::unique_ptr<Model> model = make_model(m);
  const Preprocessed& p = pre.with_shape(*model);
  return bounded_least_squares_cost(Equations(p.regression, p.fast_rows), model->parameters(),
                                    log_name);
}

// The columns that carry the friction's shape in some joint's rows.
std::vector<Eigen::Index> shape_columns(const Model& model) {
  std::vector<Eigen::Index> out;
  std::array<std::size_t, Model::kMaxShapeTerms> columns{};
  std::array<double, Model::kMaxShapeTerms> values{};
  for (unsigned j = 0; j < 3; ++j) {
    const std::size_t n = model.shape_terms(j, 0.0, columns.data(), values.data());
    for (std::size_t t = 0; t < n; ++t) out.push_back(static_cast<Eigen::Index>(columns[t]));
  }
  std::sort(out.begin(), out.end());
  return out;
}

// Those columns of psi.
Eigen::MatrixXd columns_of(const Eigen::MatrixXd& psi, const std::vector<Eigen::Index>& columns) {
  Eigen::MatrixXd out(psi.rows(), static_cast<Eigen::Index>(columns.size()));
  for (std::size_t k = 0; k < columns.size(); ++k) {
    out.col(static_cast<Eigen::Index>(k)) = psi.col(columns[k]);
  }
  return out;
}

// Standard deviations of the log shape parameters: the Gauss-Newton
// covariance of the whole problem, the residual's derivative in each shape
// parameter (central differences) appended to the regressor as a column.
// Only the shape's columns differ between the two shapes of a difference.
Eigen::VectorXd ln_shape_std(ShapePreprocess& pre, const DeltaLog& log, const FitOptions& options,
                             const Eigen::VectorXd& ln_shape) {
  const std::unique_ptr<Model> model = make_model(with_shape(options.model, ln_shape));
  const Preprocessed& best = pre.with_shape(*model);
  Regression all = best.regression;
  const std::size_t fast_rows = best.fast_rows;
  const std::size_t lags =
      correlation_lags_for(best.report.sample_rate_hz, options.prepare.cutoff_hz);
  const LeastSquaresResult ls = solve_least_squares(Equations(all, fast_rows), model->parameters(),
                                                    LsSolver::kQr, LsWeights::kNone, log.name);
  const Eigen::Index p = all.psi.cols();
  const Eigen::Index k = ln_shape.size();
  const std::vector<Eigen::Index> shape = shape_columns(*model);
  Eigen::VectorXd shape_beta(static_cast<Eigen::Index>(shape.size()));
  for (std::size_t c = 0; c < shape.size(); ++c) {
    shape_beta(static_cast<Eigen::Index>(c)) = ls.beta(shape[c]);
  }
  std::vector<ParameterInfo> infos = model->parameters();
  all.psi.conservativeResize(Eigen::NoChange, p + k);
  constexpr double kStep = 0.01;  // in ln units: 1 %
  for (Eigen::Index i = 0; i < k; ++i) {
    Eigen::VectorXd up = ln_shape, down = ln_shape;
    up(i) += kStep;
    down(i) -= kStep;
    const Eigen::MatrixXd above = columns_of(
        pre.with_shape(*make_model(with_shape(options.model, up))).regression.psi, shape);
    const Eigen::MatrixXd below = columns_of(
        pre.with_shape(*make_model(with_shape(options.model, down))).regression.psi, shape);
    all.psi.col(p + i) = (above - below) * shape_beta / (2.0 * kStep);
    infos.push_back({i == 0 ? "ln_coulomb_smoothing" : "ln_stribeck_velocity", "-", false, ""});
  }
  const LeastSquaresResult aug = solve_least_squares(
      Equations(all, fast_rows), infos, LsSolver::kQr, LsWeights::kNone, log.name, lags);
  return aug.std_dev.tail(k);
}

// Whether the log supports the shape found: held-out error over time
// blocks with the given shape and with the fitted one.
void judge_shape(ShapePreprocess& pre, const FitOptions& options, const ModelOptions& fitted,
                 FrictionShapeResult& r) {
  const auto held_out = [&](const ModelOptions& m) {
    const std::unique_ptr<Model> model = make_model(m);
    const Preprocessed& p = pre.with_shape(*model);
    if (p.regression.samples() < 20 * kSupportFolds) return 0.0;
    return held_out_rmse(*model, p.regression, p.fast_rows, kSupportFolds, options.threads);
  };
  r.held_out_given_Nm = held_out(options.model);
  r.held_out_fitted_Nm = held_out(fitted);
  r.supported = r.held_out_fitted_Nm < r.held_out_given_Nm * (1.0 - kSelectionMargin);
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
  ShapePreprocess pre = preprocess_for_shapes(log, options);
  r.cost_given_Nm2 = profiled_cost(pre, options.model, log.name);
  PsoOptions pso;
  pso.particles = 8;
  pso.iterations = 40;
  pso.stall_iterations = 8;
  pso.stall_tolerance = 1e-9;
  pso.restarts = 0;
  pso.seed = options.pso.seed;
  const PsoResult best = run_pso(
      [&](const Eigen::VectorXd& ln_shape) {
        return profiled_cost(pre, with_shape(options.model, ln_shape), log.name);
      },
      lower, upper, pso);
  r.evaluations = best.evaluations + 1;
  r.cost_fitted_Nm2 = best.best_cost;
  const Eigen::VectorXd std_ln = ln_shape_std(pre, log, options, best.best);
  r.coulomb_smoothing_rad_s = std::exp(best.best(0));
  r.coulomb_smoothing_std = r.coulomb_smoothing_rad_s * std_ln(0);
  if (stribeck) {
    r.stribeck_velocity_rad_s = std::exp(best.best(1));
    r.stribeck_velocity_std = r.stribeck_velocity_rad_s * std_ln(1);
  }
  judge_shape(pre, options, with_shape(options.model, best.best), r);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace host_id
