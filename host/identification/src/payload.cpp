#include "host_id/payload.hpp"

#include <cmath>

#include "delta/input_error.hpp"
#include "host_id/least_squares.hpp"

namespace host_id {

namespace {

// The platform's mass columns: inertial and weight (delta), or the one
// platform mass (lumped).
std::vector<Eigen::Index> platform_columns(const Model& model) {
  std::vector<Eigen::Index> columns;
  const auto& p = model.parameters();
  for (std::size_t c = 0; c < p.size(); ++c) {
    if (p[c].name == "platform_mass" || p[c].name == "platform_inertial_mass" ||
        p[c].name == "platform_weight_mass") {
      columns.push_back(static_cast<Eigen::Index>(c));
    }
  }
  return columns;
}

std::array<double, 3> rmse(const Equations& reg, const Eigen::VectorXd& residual) {
  std::array<double, 3> sum{}, n{};
  for (Eigen::Index r = 0; r < residual.size(); ++r) {
    const unsigned j = reg.joint[static_cast<std::size_t>(r)];
    sum[j] += residual(r) * residual(r);
    n[j] += 1.0;
  }
  for (unsigned j = 0; j < 3; ++j) sum[j] = n[j] > 0 ? std::sqrt(sum[j] / n[j]) : 0.0;
  return sum;
}

}  // namespace

PayloadResult fit_payload(const Model& model, const Eigen::VectorXd& beta, const DeltaLog& log,
                          const PrepareOptions& prepare, double min_speed_rad_s, unsigned threads) {
  const std::vector<Eigen::Index> columns = platform_columns(model);
  if (columns.empty()) {
    throw delta::InputError(
        "--base: the base fit's model has no platform mass for a payload to "
        "add to (paper14); fit the base with --model delta or lumped");
  }
  PrepareOptions p = prepare;
  p.slow_rows_last_below_rad_s = min_speed_rad_s;
  const Preprocessed pre = preprocess(model, log, p, threads);
  const Equations all(pre.regression, pre.fast_rows);
  // One column: the payload adds its mass to each platform column.
  Regression payload;
  payload.psi = all.psi(Eigen::all, columns).rowwise().sum();
  const Eigen::VectorXd base_residual = all.tau - all.psi * beta;
  payload.tau = base_residual;
  payload.t_s.assign(all.t_s.begin(), all.t_s.end());
  payload.joint.assign(all.joint.begin(), all.joint.end());
  payload.sample.assign(all.sample.begin(), all.sample.end());
  const std::vector<ParameterInfo> info{{"payload_mass", "kg", false, "the payload's mass"}};
  const LeastSquaresResult ls = solve_least_squares(
      Equations(payload), info, LsSolver::kQr, LsWeights::kNone, log.name,
      correlation_lags_for(pre.report.sample_rate_hz, prepare.cutoff_hz), threads);
  PayloadResult out;
  out.mass_kg = ls.beta(0);
  out.std_dev_kg = ls.std_dev(0);
  out.equations = static_cast<std::size_t>(payload.tau.size());
  out.rmse_base_Nm = rmse(all, base_residual);
  out.rmse_payload_Nm = rmse(all, base_residual - payload.psi * ls.beta);
  out.derivatives = pre.report.derivatives;
  return out;
}

Eigen::VectorXd with_payload(const Model& model, const Eigen::VectorXd& beta, double mass_kg) {
  Eigen::VectorXd out = beta;
  for (const Eigen::Index c : platform_columns(model)) out(c) += mass_kg;
  return out;
}

}  // namespace host_id
