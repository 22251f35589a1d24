#include "host_id/identify.hpp"

#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "delta/input_error.hpp"
#include "host_id/regression.hpp"

namespace host_id {

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

double min_speed_for(const FitOptions& options) {
  if (options.min_speed_rad_s) return *options.min_speed_rad_s;
  return options.model.name == "paper14" ? 0.0 : kDefaultMinSpeedRadS;
}

FitResult fit_log(const DeltaLog& log, const FitOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  FitResult r;
  r.options = options;
  const auto model = make_model(options.model);
  const Samples samples = prepare_samples(log, options.prepare);
  r.samples_in_log = samples.samples_in_log;
  r.derivatives = samples.derivatives;
  r.gaps = log.gaps;
  r.segments_used = samples.segments_used;
  r.segments_dropped = samples.segments_dropped;
  const Regression all_rows =
      build_regression(*model, log.geometry, log.gravity_m_s2, samples, log.name, options.threads);
  r.min_speed_rad_s = min_speed_for(options);
  const Regression fast_rows =
      r.min_speed_rad_s > 0.0 ? without_slow_rows(all_rows, r.min_speed_rad_s) : Regression{};
  const Regression& reg = r.min_speed_rad_s > 0.0 ? fast_rows : all_rows;
  r.equations_used = reg.rows_per_joint();
  for (unsigned j = 0; j < 3; ++j) {
    if (r.equations_used[j] == 0) {
      std::ostringstream s;
      s << log.name << ": joint " << j + 1 << " is never faster than the minimum speed of "
        << r.min_speed_rad_s
        << " rad/s, so none of its equations is left to fit; lower --min-speed (0 uses every "
           "sample)";
      throw delta::InputError(s.str());
    }
  }

  const auto te = std::chrono::steady_clock::now();
  const LeastSquaresResult ls =
      solve_least_squares(reg, *model, options.solver, options.weights, log.name,
                          correlation_lags_for(samples.sample_rate_hz, options.prepare.cutoff_hz));
  r.joint_weights = ls.joint_weights;
  r.condition_number = ls.condition_number;
  r.std_dev_lags = ls.correlation_lags;
  r.condition_number_scaled = ls.condition_number_scaled;
  const Regression weighted_reg =
      options.weights == LsWeights::kNone ? Regression{} : weighted(reg, ls.joint_weights);
  const Regression& cost_reg = options.weights == LsWeights::kNone ? reg : weighted_reg;
  r.ls_cost_Nm2 = ls.cost;

  // Bounds from physical priors and the data's scale.
  const Eigen::Index p = reg.psi.cols();
  const double tau_rms =
      std::sqrt(cost_reg.tau.squaredNorm() / static_cast<double>(cost_reg.tau.size()));
  Eigen::VectorXd lower(p), upper(p);
  for (Eigen::Index c = 0; c < p; ++c) {
    const double col_rms =
        std::sqrt(cost_reg.psi.col(c).squaredNorm() / static_cast<double>(cost_reg.psi.rows()));
    const double bound = options.bound_factor * tau_rms / col_rms;
    upper(c) = bound;
    lower(c) = model->parameters()[static_cast<unsigned>(c)].nonnegative ? 0.0 : -bound;
    if (ls.beta(c) < lower(c) || ls.beta(c) > upper(c)) {
      r.ls_outside_bounds.push_back(model->parameters()[static_cast<unsigned>(c)].name);
    }
  }

  if (options.method == Method::kPso) {
    const QuadraticCost cost(cost_reg, ls.beta);
    r.pso =
        run_pso([&cost](const Eigen::VectorXd& b) { return cost(b); }, lower, upper, options.pso);
    r.beta = r.pso->best;
    r.cost_Nm2 = direct_cost(cost_reg, r.beta);
  } else {
    r.beta = ls.beta;
    r.cost_Nm2 = ls.cost;
  }
  r.seconds_estimator = seconds_since(te);

  for (Eigen::Index c = 0; c < p; ++c) {
    ParameterEstimate e;
    e.info = model->parameters()[static_cast<unsigned>(c)];
    e.value = r.beta(c);
    e.ls_value = ls.beta(c);
    e.std_dev = ls.std_dev(c);
    e.rel_std_percent = ls.beta(c) != 0.0 ? 100.0 * ls.std_dev(c) / std::abs(ls.beta(c))
                                          : std::numeric_limits<double>::infinity();
    e.lower = lower(c);
    e.upper = upper(c);
    r.parameters.push_back(e);
  }
  r.fit.log = log.name;
  r.fit.samples = all_rows.samples();
  r.fit.rmse_Nm = rmse_per_joint(all_rows, r.beta);
  r.seconds_total = seconds_since(t0);
  return r;
}

Prediction predict(const Model& model, const Eigen::VectorXd& beta, const DeltaLog& log,
                   const PrepareOptions& prepare, unsigned threads) {
  const Samples samples = prepare_samples(log, prepare);
  const Regression reg =
      build_regression(model, log.geometry, log.gravity_m_s2, samples, log.name, threads);
  Prediction out;
  out.log = log.name;
  out.t_s = reg.t_s;
  const Eigen::VectorXd yhat = reg.psi * beta;
  const std::size_t n = reg.samples();
  for (unsigned j = 0; j < 3; ++j) {
    out.measured_Nm[j].resize(n);
    out.predicted_Nm[j].resize(n);
  }
  for (std::size_t k = 0; k < n; ++k) {
    for (unsigned j = 0; j < 3; ++j) {
      const auto row = static_cast<Eigen::Index>(3 * k + j);
      out.measured_Nm[j][k] = reg.tau(row);
      out.predicted_Nm[j][k] = yhat(row);
    }
  }
  out.rmse_Nm = rmse_per_joint(reg, beta);
  return out;
}

}  // namespace host_id
