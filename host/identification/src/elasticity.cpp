#include "host_id/elasticity.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "delta/input_error.hpp"
#include "host_id/least_squares.hpp"
#include "host_id/model_selection.hpp"
#include "host_id/motion_spread.hpp"
#include "host_id/predict.hpp"
#include "host_id/preprocess.hpp"
#include "host_id/pso.hpp"
#include "host_id/signal.hpp"

namespace host_id {

namespace {

constexpr const char* kArmColumns[3] = {"qa1", "qa2", "qa3"};

void refuse_logged_derivatives(const DeltaLog& log) {
  if (log.has_qd || log.has_qdd) {
    throw delta::InputError(log.name +
                            ": an elastic model needs the arm's angle differentiated by the fit, "
                            "and the log's qd and qdd columns are the motor's: leave them out");
  }
}

const Series* extra_column(const DeltaLog& log, const char* name) {
  for (const auto& [n, series] : log.extra_columns) {
    if (n == name) return &series;
  }
  return nullptr;
}

}  // namespace

void to_arm_side(DeltaLog& log, const delta::Joint3& compliance_rad_per_Nm, const Series3& tau_Nm) {
  refuse_logged_derivatives(log);
  for (unsigned j = 0; j < 3; ++j) {
    const double c = compliance_rad_per_Nm[j];
    for (std::size_t k = 0; k < log.q[j].size(); ++k) log.q[j][k] -= c * tau_Nm[j][k];
  }
}

bool has_arm_encoders(const DeltaLog& log) {
  return std::all_of(std::begin(kArmColumns), std::end(kArmColumns),
                     [&](const char* name) { return extra_column(log, name) != nullptr; });
}

void to_logged_arm_side(DeltaLog& log) {
  refuse_logged_derivatives(log);
  for (unsigned j = 0; j < 3; ++j) log.q[j] = *extra_column(log, kArmColumns[j]);
}

namespace {

// The model's torque at every sample of the log: the kept samples' own,
// and each other sample the nearest kept one's.
Series3 torque_everywhere(const PredictedLog& p, std::size_t samples) {
  Series3 out;
  for (unsigned j = 0; j < 3; ++j) {
    out[j].assign(samples, 0.0);
    const Series& model_tau = p.log.extra_columns[j].second;
    std::size_t next = 0;  // the next kept sample
    for (std::size_t k = 0; k < samples; ++k) {
      while (next + 1 < p.log_index.size() && p.log_index[next] < k) ++next;
      // The nearer of the kept samples around k.
      std::size_t at = next;
      if (next > 0 && k - p.log_index[next - 1] <
                          (p.log_index[next] > k ? p.log_index[next] - k : k - p.log_index[next])) {
        at = next - 1;
      }
      out[j][k] = p.log_index.empty() ? 0.0 : model_tau[at];
    }
  }
  return out;
}

// The parameters with what the gear does not carry left out: the joint's
// friction, load friction and cogging act on the motor's side of the
// gearbox (docs/robot-description.md), and a torque offset is the
// measurement's, as the arm encoders' regression takes them out.
Eigen::VectorXd gear_side(const Model& model, Eigen::VectorXd beta) {
  for (std::size_t c = 0; c < model.size(); ++c) {
    const std::string& name = model.parameters()[c].name;
    for (const char* motor_side : {"viscous_friction", "coulomb_friction", "stribeck_friction",
                                   "load_friction", "cogging_", "torque_offset"}) {
      if (name.rfind(motor_side, 0) == 0) beta(static_cast<Eigen::Index>(c)) = 0.0;
    }
  }
  return beta;
}

}  // namespace

Series3 deflection_torque(const Model& model, const Eigen::VectorXd& beta, const DeltaLog& log,
                          const PrepareOptions& prepare) {
  const PredictedLog p = predict_log_as_is(model, gear_side(model, beta), log, prepare, "");
  Series3 tau = torque_everywhere(p, log.size());
  const double rate = p.report.sample_rate_hz;
  if (rate > 2.0 * prepare.cutoff_hz) {
    const auto filter = butterworth4_lowpass(prepare.cutoff_hz, rate);
    const auto pad = static_cast<std::size_t>(3.0 * rate / prepare.cutoff_hz);
    for (Series& s : tau) filtfilt_in_place(filter, s, pad);
  }
  return tau;
}

DeltaLog arm_side_for_prediction(const Model& model, const Eigen::VectorXd& beta,
                                 const DeltaLog& log, const PrepareOptions& prepare) {
  DeltaLog arm = log;
  if (has_arm_encoders(log)) {
    to_logged_arm_side(arm);
    return arm;
  }
  const delta::Joint3 c = model.options().gearbox_compliance_rad_per_Nm;
  Series3 tau_hat;
  for (auto& s : tau_hat) s.assign(log.size(), 0.0);
  for (int pass = 0; pass < kArmSidePasses; ++pass) {
    DeltaLog trial = log;
    to_arm_side(trial, c, tau_hat);
    tau_hat = deflection_torque(model, beta, trial, prepare);
  }
  to_arm_side(arm, c, tau_hat);
  return arm;
}

namespace {

// The log preprocessed at the motor's angles and, for each joint k, at
// q_k − c0 τ_k: the regressor's derivative in joint k's compliance, D_k =
// (Psi(c0 e_k) − Psi(0)) / c0, taken as linear (the deflections are a few
// mrad). The rows in time order, the fit's fast ones marked.
struct ComplianceColumns {
  static constexpr double kStep = 1.0 / 2000.0;  // rad/(N m): c0
  Regression base;                               // Psi(0), tau, labels
  std::array<Eigen::MatrixXd, 3> d;              // D_k
  std::vector<Eigen::Index> fast;                // the rows a fit uses
  PrepareOptions prepare;                        // the state cut-off fixed
  double sample_rate_hz{0};
  Eigen::VectorXd rigid_beta;  // the rigid least squares (unbounded)
  Series3 tau_hat;             // its torque at every sample: the deflection's
};

ComplianceColumns compliance_columns(const Model& model, const DeltaLog& log,
                                     const FitOptions& options) {
  ComplianceColumns out;
  out.prepare = options.prepare;
  out.prepare.slow_rows_last_below_rad_s = 0.0;
  Preprocessed base = preprocess(model, log, out.prepare, options.threads);
  // Every angle filtered alike: the cut-off the motor's angles chose.
  if (base.report.state_cutoff_hz > 0.0) {
    out.prepare.state_cutoff_hz = base.report.state_cutoff_hz;
  }
  const double min_speed = min_speed_for(options);
  for (std::size_t row = 0; row < base.regression.rows(); ++row) {
    if (std::abs(base.regression.velocity_rad_s[row]) >= min_speed) {
      out.fast.push_back(static_cast<Eigen::Index>(row));
    }
  }
  // The deflection's torque: the rigid fit's own, not the measured one,
  // whose noise the deflection's second derivative would then explain.
  out.rigid_beta = base.regression.psi(out.fast, Eigen::all)
                       .colPivHouseholderQr()
                       .solve(base.regression.tau(out.fast));
  out.tau_hat = deflection_torque(model, out.rigid_beta, log, out.prepare);
  for (unsigned k = 0; k < 3; ++k) {
    DeltaLog moved = log;
    delta::Joint3 c{};
    c[k] = ComplianceColumns::kStep;
    to_arm_side(moved, c, out.tau_hat);
    const Preprocessed p = preprocess(model, moved, out.prepare, options.threads);
    if (p.regression.rows() != base.regression.rows()) {
      throw std::logic_error("fit_elasticity: the moved log kept other samples");
    }
    out.d[k] = (p.regression.psi - base.regression.psi) / ComplianceColumns::kStep;
  }
  out.sample_rate_hz = base.report.sample_rate_hz;
  out.base = std::move(base.regression);
  return out;
}

// The least-squares cost of the fast rows as a function of the three
// compliances, from the moments of [Psi(0) D_1 D_2 D_3 | tau]: each
// candidate costs a p x p solve, not a pass over the rows.
class ProfiledCost {
 public:
  explicit ProfiledCost(const ComplianceColumns& cc) : p_(cc.base.psi.cols()) {
    Eigen::MatrixXd z(static_cast<Eigen::Index>(cc.fast.size()), 4 * p_);
    z.leftCols(p_) = cc.base.psi(cc.fast, Eigen::all);
    for (std::size_t k = 0; k < 3; ++k) {
      z.middleCols((static_cast<Eigen::Index>(k) + 1) * p_, p_) = cc.d[k](cc.fast, Eigen::all);
    }
    const Eigen::VectorXd tau = cc.base.tau(cc.fast);
    gram_ = z.transpose() * z;
    z_tau_ = z.transpose() * tau;
    tau_tau_ = tau.squaredNorm();
    rows_ = static_cast<double>(cc.fast.size());
  }
  double operator()(const Eigen::VectorXd& c) const {
    Eigen::MatrixXd s = Eigen::MatrixXd::Zero(p_, 4 * p_);
    s.leftCols(p_).setIdentity();
    for (Eigen::Index k = 0; k < 3; ++k) {
      s.middleCols((k + 1) * p_, p_) = c(k) * Eigen::MatrixXd::Identity(p_, p_);
    }
    Eigen::MatrixXd g = s * gram_ * s.transpose();
    const Eigen::VectorXd b = s * z_tau_;
    // A column the log cannot tell apart from the others is held by a
    // ridge far below any column's scale.
    g.diagonal().array() += 1e-12 * g.diagonal().mean();
    const Eigen::VectorXd beta = g.ldlt().solve(b);
    return (tau_tau_ - b.dot(beta)) / rows_;
  }

 private:
  Eigen::Index p_;
  Eigen::MatrixXd gram_;
  Eigen::VectorXd z_tau_;
  double tau_tau_{0}, rows_{1};
};

// The compliances' standard deviations: the Gauss-Newton covariance of
// the whole problem at c, the residual's derivative in each compliance
// (D_k beta) appended to the regressor.
delta::Joint3 compliance_std(const ComplianceColumns& cc, const Model& model,
                             const delta::Joint3& c, const std::string& log_name,
                             const FitOptions& options) {
  Regression aug;
  Eigen::MatrixXd psi = cc.base.psi(cc.fast, Eigen::all);
  for (unsigned k = 0; k < 3; ++k) psi += c[k] * cc.d[k](cc.fast, Eigen::all);
  aug.tau = cc.base.tau(cc.fast);
  const Eigen::VectorXd beta = psi.colPivHouseholderQr().solve(aug.tau);
  const Eigen::Index p = psi.cols();
  aug.psi.resize(psi.rows(), p + 3);
  aug.psi.leftCols(p) = psi;
  std::vector<ParameterInfo> infos = model.parameters();
  for (unsigned k = 0; k < 3; ++k) {
    aug.psi.col(p + k) = cc.d[k](cc.fast, Eigen::all) * beta;
    infos.push_back({"gearbox_compliance_" + std::to_string(k + 1), "rad/(N m)", false, ""});
  }
  aug.t_s = cc.base.t_s;
  for (const Eigen::Index row : cc.fast) {
    aug.joint.push_back(cc.base.joint[static_cast<std::size_t>(row)]);
    aug.sample.push_back(cc.base.sample[static_cast<std::size_t>(row)]);
  }
  const std::size_t lags = correlation_lags_for(cc.sample_rate_hz, options.prepare.cutoff_hz);
  LeastSquaresResult full = solve_least_squares(Equations(aug), infos, LsSolver::kQr,
                                                LsWeights::kNone, log_name, lags, options.threads);
  // With model error: the spread over the log's motions where it is the
  // larger (trust.md), as every other parameter's.
  add_model_error(Equations(aug), lags, full, options.threads);
  return {full.honest_std_dev(p), full.honest_std_dev(p + 1), full.honest_std_dev(p + 2)};
}

// The held-out torque error of the rigid model and of the elastic one at
// c (the fit's rows, kSupportFolds time blocks); 0 for too short a log.
void judge_elasticity(const Model& model, const DeltaLog& log, const FitOptions& options,
                      const PrepareOptions& prepare, const Series3& tau_hat, ElasticityResult& r) {
  PrepareOptions held = prepare;
  held.slow_rows_last_below_rad_s = min_speed_for(options);
  const auto held_out = [&](const DeltaLog& l) {
    const Preprocessed p = preprocess(model, l, held, options.threads);
    if (p.regression.samples() < 20 * kSupportFolds) return 0.0;
    return held_out_rmse(model, p.regression, p.fast_rows, kSupportFolds, options.threads);
  };
  DeltaLog arm = log;
  if (r.from_arm_encoders) {
    to_logged_arm_side(arm);
  } else {
    to_arm_side(arm, r.compliance_rad_per_Nm, tau_hat);
  }
  r.held_out_rigid_Nm = held_out(log);
  r.held_out_elastic_Nm = held_out(arm);
  // A searched stiffness is a term made of torque, and takes the drive
  // train's margin; the arm's own encoders take the usual one.
  const double margin = r.from_arm_encoders ? kSelectionMargin : kDriveTrainMargin;
  r.supported =
      r.held_out_elastic_Nm > 0.0 && r.held_out_elastic_Nm < r.held_out_rigid_Nm * (1.0 - margin);
}

// The standard deviation of the first coefficient of y = x b with model
// error: least squares' own, or the spread over the log's motions where
// larger (motion_spread.hpp, as every fitted parameter's; trust.md).
double motion_spread_std(const Eigen::MatrixXd& x, const Eigen::VectorXd& y,
                         const PreparedStates& prepared, const DeltaLog& log,
                         const FitOptions& options) {
  Regression r;
  r.psi = x;
  r.tau = y;
  for (std::size_t i = 0; i < prepared.states.size(); ++i) {
    r.t_s.push_back(log.t[prepared.log_index[i]]);
    r.joint.push_back(0);
    r.sample.push_back(i);
  }
  // Named for messages only: the first is the compliance.
  std::vector<ParameterInfo> infos(static_cast<std::size_t>(x.cols()));
  infos[0].name = "gearbox_compliance";
  const std::size_t lags =
      correlation_lags_for(prepared.report.sample_rate_hz, options.prepare.cutoff_hz);
  LeastSquaresResult ls = solve_least_squares(Equations(r), infos, LsSolver::kQr, LsWeights::kNone,
                                              log.name, lags, options.threads);
  add_model_error(Equations(r), lags, ls, options.threads);
  return ls.honest_std_dev(0);
}

// The standard deviation of the first coefficient of y = x b from its
// spread over kSupportFolds consecutive time blocks, each fitted alone
// (std / sqrt(blocks)): the residual is correlated over many samples and
// holds what the line lacks, so least squares' own sigma (0.3-0.6 % of c
// on our robot, where c is off by up to 4 %) would promise too much.
double block_spread(const Eigen::MatrixXd& x, const Eigen::VectorXd& y) {
  const Eigen::Index n = x.rows(), blocks = kSupportFolds;
  if (n < 20 * blocks) return std::numeric_limits<double>::infinity();
  std::vector<double> c;
  for (Eigen::Index b = 0; b < blocks; ++b) {
    const Eigen::Index first = b * n / blocks, last = (b + 1) * n / blocks;
    c.push_back(x.middleRows(first, last - first)
                    .colPivHouseholderQr()
                    .solve(y.segment(first, last - first))(0));
  }
  double mean = 0, ss = 0;
  for (const double v : c) mean += v / static_cast<double>(blocks);
  for (const double v : c) ss += (v - mean) * (v - mean);
  return std::sqrt(ss / static_cast<double>(blocks - 1)) / std::sqrt(static_cast<double>(blocks));
}

// The runs of consecutive samples among a fit's kept ones: [first, last)
// in the kept samples' numbering.
std::vector<std::pair<Eigen::Index, Eigen::Index>> runs_of(const std::vector<std::size_t>& at) {
  std::vector<std::pair<Eigen::Index, Eigen::Index>> runs;
  std::size_t first = 0;
  while (first < at.size()) {
    std::size_t last = first + 1;
    while (last < at.size() && at[last] == at[last - 1] + 1) ++last;
    runs.emplace_back(static_cast<Eigen::Index>(first), static_cast<Eigen::Index>(last));
    first = last;
  }
  return runs;
}

// The columns of x (but the last) and y filtered as a fit filters its
// regressor and torque ("parallel filtering": the zero-phase low-pass at
// its cut-off) over each run, so that the deflection and the drive's
// torque hold the band of the motor side's terms, which come from the
// filtered states; then the last column, the deflection's rate, from the
// filtered deflection by central differences within each run.
void filter_and_rate(Eigen::MatrixXd& x, Eigen::VectorXd& y, const PreparedStates& prepared,
                     const PrepareOptions& prepare) {
  const double rate = prepared.report.sample_rate_hz;
  const bool filter_on = rate > 2.0 * prepare.cutoff_hz;  // else the samples are the band
  const auto filter =
      filter_on ? butterworth4_lowpass(prepare.cutoff_hz, rate) : std::array<Biquad, 2>{};
  const auto pad = static_cast<std::size_t>(3.0 * rate / prepare.cutoff_hz);
  const Eigen::Index rate_column = x.cols() - 1;
  for (const auto& [first, last] : runs_of(prepared.log_index)) {
    const Eigen::Index len = last - first;
    std::vector<double> v(static_cast<std::size_t>(len));
    const auto filtered = [&](auto series) {
      std::copy(series.begin(), series.end(), v.begin());
      filtfilt_in_place(filter, v, pad);
      std::copy(v.begin(), v.end(), series.begin());
    };
    for (Eigen::Index c = 0; filter_on && c < rate_column; ++c)
      filtered(x.col(c).segment(first, len));
    if (filter_on) filtered(y.segment(first, len));
    for (Eigen::Index i = first; i < last; ++i) {
      const Eigen::Index a = std::max(first, i - 1), b = std::min(last - 1, i + 1);
      x(i, rate_column) = b > a ? (y(b) - y(a)) * rate / static_cast<double>(b - a) : 0.0;
    }
  }
}

// With the arm's encoders logged: each joint's deflection θ_m − q_a is c
// times the gear's spring torque, which is the drive's less what the motor
// side takes (its rotor's inertia, its friction, the load friction) and
// less the gearbox's damper, D (θ̇_m − q̇_a):
//   θ_m − q_a = c τ − c J θ̈_m − c f_v θ̇_m − c f_c tanh(θ̇_m / w)
//               − c μ |τ| tanh(θ̇_m / w) + offset − c D (θ̇_m − q̇_a),
// linear in c and the products, over the samples a fit keeps (θ̇_m, θ̈_m
// filtered and differentiated as a fit's; the rest filtered alike).
// Without the motor side's terms c comes out 6-28 % low on our elastic
// robot; without the damper's, 3-10 % off on softer gearboxes at 1 Hz,
// with sigmas that held the truth in 25 of 30 joints. D itself is not
// reported: the drive's current filter delays its torque, which the same
// term takes as damping (K times the delay: 0.15 N m s/rad at 300 N m/rad
// and 0.5 ms), so it is not the gearbox's alone.
void compliance_from_arm_encoders(const DeltaLog& log, const FitOptions& options,
                                  ElasticityResult& r) {
  const PreparedStates prepared = prepare_states(log, options.prepare);
  const auto n = static_cast<Eigen::Index>(prepared.states.size());
  const double w = options.model.coulomb_smoothing_rad_s;
  for (unsigned j = 0; j < 3; ++j) {
    const Series& arm = *extra_column(log, kArmColumns[j]);
    Eigen::MatrixXd x(n, 7);
    Eigen::VectorXd y(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      const std::size_t k = prepared.log_index[static_cast<std::size_t>(i)];
      const delta::JointState& st = prepared.states[static_cast<std::size_t>(i)];
      const double tau = log.tau[j][k], sign = std::tanh(st.qd_rad_s[j] / w);
      x.row(i) << tau, st.qdd_rad_s2[j], st.qd_rad_s[j], sign, std::abs(tau) * sign, 1.0, 0.0;
      y(i) = log.q[j][k] - arm[k];
    }
    filter_and_rate(x, y, prepared, options.prepare);
    const Eigen::VectorXd fit = x.colPivHouseholderQr().solve(y);
    r.compliance_rad_per_Nm[j] = std::max(0.0, fit(0));
    r.compliance_std[j] =
        std::max(block_spread(x, y), motion_spread_std(x, y, prepared, log, options));
  }
}

}  // namespace

ElasticityResult fit_elasticity(const DeltaLog& log, const FitOptions& options) {
  if (options.model.name == "paper14") {
    throw delta::InputError("--elastic applies to --model delta and lumped only");
  }
  refuse_logged_derivatives(log);
  const auto t0 = std::chrono::steady_clock::now();
  ModelOptions rigid = options.model;
  rigid.gearbox_compliance_rad_per_Nm = {};
  const std::unique_ptr<Model> model = make_model(rigid);
  ElasticityResult r;
  PrepareOptions prepare = options.prepare;
  Series3 tau_hat;
  if (has_arm_encoders(log)) {
    r.from_arm_encoders = true;
    compliance_from_arm_encoders(log, options, r);
  } else {
    const ComplianceColumns cc = compliance_columns(*model, log, options);
    prepare.state_cutoff_hz = cc.prepare.state_cutoff_hz;
    tau_hat = cc.tau_hat;
    const ProfiledCost cost(cc);
    PsoOptions pso;
    pso.particles = 12;
    pso.iterations = 80;
    pso.stall_iterations = 10;
    pso.stall_tolerance = 1e-9;
    pso.seed = options.pso.seed;
    const PsoResult best = run_pso(cost, Eigen::VectorXd::Zero(3),
                                   Eigen::VectorXd::Constant(3, kComplianceMaxRadPerNm), pso);
    r.evaluations = best.evaluations + 1;
    r.cost_rigid_Nm2 = cost(Eigen::VectorXd::Zero(3));
    r.cost_elastic_Nm2 = best.best_cost;
    r.compliance_rad_per_Nm = {best.best(0), best.best(1), best.best(2)};
    r.compliance_std = compliance_std(cc, *model, r.compliance_rad_per_Nm, log.name, options);
  }
  judge_elasticity(*model, log, options, prepare, tau_hat, r);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace host_id
