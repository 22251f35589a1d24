#include "host_id/payload.hpp"

#include <cmath>

#include "delta/input_error.hpp"
#include "host_id/least_squares.hpp"
#include "host_id/motion_spread.hpp"

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
  const std::size_t lags = correlation_lags_for(pre.report.sample_rate_hz, prepare.cutoff_hz);
  const Equations rows(payload);
  LeastSquaresResult ls =
      solve_least_squares(rows, info, LsSolver::kQr, LsWeights::kNone, log.name, lags, threads);
  add_model_error(rows, lags, ls, threads);
  PayloadResult out;
  out.mass_kg = ls.beta(0);
  out.std_dev_kg = ls.honest_std_dev(0);
  out.ls_std_dev_kg = ls.std_dev(0);
  out.equations = static_cast<std::size_t>(payload.tau.size());
  out.rmse_base_Nm = rmse(all, base_residual);
  out.rmse_payload_Nm = rmse(all, base_residual - payload.psi * ls.beta);
  out.derivatives = pre.report.derivatives;
  return out;
}

namespace {

// One log's equations for the torque scale: [tau_j in column j | -Psi],
// the right side m phi (or 0 without the payload).
struct ScaleRows {
  Eigen::MatrixXd psi;
  Eigen::VectorXd rhs;
  std::vector<unsigned char> joint;
  std::vector<std::size_t> sample;
  std::vector<double> t_s;
  double sample_rate_hz{0};
};

ScaleRows scale_rows(const Model& model, const DeltaLog& log, double payload_mass_kg,
                     const PrepareOptions& prepare, double min_speed_rad_s, unsigned threads) {
  PrepareOptions p = prepare;
  p.slow_rows_last_below_rad_s = min_speed_rad_s;
  const Preprocessed pre = preprocess(model, log, p, threads);
  const Equations e(pre.regression, pre.fast_rows);
  const Eigen::Index rows = e.psi.rows(), params = e.psi.cols();
  ScaleRows s;
  s.psi = Eigen::MatrixXd::Zero(rows, 3 + params);
  s.psi.rightCols(params) = -e.psi;
  const Eigen::VectorXd phi = e.psi(Eigen::all, platform_columns(model)).rowwise().sum();
  s.rhs = payload_mass_kg * phi;
  for (Eigen::Index r = 0; r < rows; ++r) {
    s.psi(r, e.joint[static_cast<std::size_t>(r)]) = e.tau(r);
  }
  s.joint.assign(e.joint.begin(), e.joint.end());
  s.sample.assign(e.sample.begin(), e.sample.end());
  s.t_s.assign(e.t_s.begin(), e.t_s.end());
  s.sample_rate_hz = pre.report.sample_rate_hz;
  return s;
}

// Both logs' rows in one regression; the loaded log's samples after the
// unloaded one's.
Regression both_logs(const ScaleRows& a, const ScaleRows& b) {
  Regression all;
  all.psi.resize(a.psi.rows() + b.psi.rows(), a.psi.cols());
  all.psi << a.psi, b.psi;
  all.tau.resize(a.rhs.size() + b.rhs.size());
  all.tau << a.rhs, b.rhs;
  all.joint = a.joint;
  all.joint.insert(all.joint.end(), b.joint.begin(), b.joint.end());
  all.sample = a.sample;
  for (const std::size_t k : b.sample) all.sample.push_back(k + a.t_s.size());
  all.t_s = a.t_s;
  const double shift = a.t_s.empty() ? 0.0 : a.t_s.back() + 1.0;
  for (const double t : b.t_s) all.t_s.push_back(t + shift);
  return all;
}

// The scale problem's unknowns: each joint's inverse torque scale, then
// the model's parameters, all unbounded.
std::vector<ParameterInfo> scale_parameters(const Model& model) {
  std::vector<ParameterInfo> info;
  for (int j = 1; j <= 3; ++j) {
    info.push_back({"inverse_torque_scale_" + std::to_string(j), "-", false,
                    "true torque per logged torque of joint " + std::to_string(j)});
  }
  for (const ParameterInfo& p : model.parameters()) {
    ParameterInfo free = p;
    free.nonnegative = false;  // the scale's problem is solved unbounded
    info.push_back(free);
  }
  return info;
}

// Each joint's torque scale (logged per true torque) and its standard
// deviation, from the inverse scales the least squares found.
void take_torque_scales(const LeastSquaresResult& ls, TorqueScaleResult& out) {
  for (unsigned j = 0; j < 3; ++j) {
    const double w = ls.beta(j);
    if (!(w > 0.0)) {
      throw delta::InputError(
          "--calibrate-torque: joint " + std::to_string(j + 1) +
          "'s torque scale came out negative or infinite: the logs cannot tell it (does the "
          "payload move with the platform, and do both logs excite the joint?)");
    }
    out.scale[j] = 1.0 / w;
    out.scale_std[j] = ls.honest_std_dev(j) / (w * w);
    out.scale_ls_std[j] = ls.std_dev(j) / (w * w);
  }
}

}  // namespace

TorqueScaleResult fit_torque_scale(const Model& model, const DeltaLog& unloaded,
                                   const DeltaLog& loaded, double payload_mass_kg,
                                   const PrepareOptions& prepare, double min_speed_rad_s,
                                   unsigned threads) {
  if (platform_columns(model).empty()) {
    throw delta::InputError(
        "--calibrate-torque: the model has no platform mass for the payload (paper14); use "
        "--model delta or lumped");
  }
  if (!(payload_mass_kg > 0.0)) {
    throw delta::InputError("--payload-mass must be the payload's mass in kg, above 0");
  }
  const ScaleRows a = scale_rows(model, unloaded, 0.0, prepare, min_speed_rad_s, threads);
  const ScaleRows b = scale_rows(model, loaded, payload_mass_kg, prepare, min_speed_rad_s, threads);
  const Regression all = both_logs(a, b);
  const std::vector<ParameterInfo> info = scale_parameters(model);
  const std::size_t lags = correlation_lags_for(a.sample_rate_hz, prepare.cutoff_hz);
  LeastSquaresResult ls = solve_least_squares(Equations(all), info, LsSolver::kQr, LsWeights::kNone,
                                              unloaded.name + " + " + loaded.name, lags, threads);
  add_model_error(Equations(all), lags, ls, threads);
  TorqueScaleResult out;
  take_torque_scales(ls, out);
  const Eigen::Index p = static_cast<Eigen::Index>(model.size());
  out.beta = ls.beta.tail(p);
  out.beta_std = ls.honest_std_dev.tail(p);
  out.equations = all.rows();
  const Eigen::VectorXd residual = all.tau - all.psi * ls.beta;
  out.rmse_Nm = rmse(Equations(all), residual);
  return out;
}

Eigen::VectorXd with_payload(const Model& model, const Eigen::VectorXd& beta, double mass_kg) {
  Eigen::VectorXd out = beta;
  for (const Eigen::Index c : platform_columns(model)) out(c) += mass_kg;
  return out;
}

}  // namespace host_id
