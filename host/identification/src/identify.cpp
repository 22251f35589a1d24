#include "host_id/identify.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <sstream>
#include <string>

#include "delta/input_error.hpp"
#include "host_id/elasticity.hpp"
#include "host_id/friction_shape.hpp"
#include "host_id/model_selection.hpp"
#include "host_id/motion_spread.hpp"
#include "host_id/parallel.hpp"
#include "host_id/regression.hpp"

namespace host_id {

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Each joint's angle span over the log, rad.
std::array<double, 3> angle_spans(const DeltaLog& log) {
  std::array<double, 3> span{};
  for (unsigned j = 0; j < 3; ++j) {
    if (log.q[j].empty()) continue;
    const auto [lo, hi] = std::minmax_element(log.q[j].begin(), log.q[j].end());
    span[j] = *hi - *lo;
  }
  return span;
}

// A joint whose angle spans less than this did not move (a disabled drive,
// a trajectory that leaves it out): its parameters are not in the log.
constexpr double kStillSpanRad = 0.01;

void require_equations_per_joint(const FitResult& r, const std::string& log_name,
                                 const std::array<double, 3>& spans) {
  for (unsigned j = 0; j < 3; ++j) {
    if (r.equations_used[j] != 0) continue;
    std::ostringstream s;
    if (spans[j] < kStillSpanRad) {
      s << log_name << ": joint " << j + 1 << " did not move: its angle spans " << spans[j]
        << " rad over the whole log, so the log holds nothing of its dynamics; was its drive "
           "enabled, and does the excitation move it?";
      throw delta::InputError(s.str());
    }
    s << log_name << ": joint " << j + 1 << " is never faster than the minimum speed of "
      << r.min_speed_rad_s
      << " rad/s, so none of its equations is left to fit; lower --min-speed (0 uses every "
         "sample)";
    throw delta::InputError(s.str());
  }
}

struct Box {
  Eigen::VectorXd lower, upper;
};

// PSO's box from physical priors and the data's scale (the RMS of tau and
// of each column, from the least-squares moments), wide enough to hold the
// bounded least-squares optimum: both solve the same bounded problem.
Box pso_box(const LeastSquaresResult& ls, std::size_t rows,
            const std::vector<ParameterInfo>& parameters, const FitOptions& options) {
  const Eigen::Index p = ls.beta.size();
  const auto n = static_cast<double>(rows);
  const double tau_rms = std::sqrt(ls.tau_t_tau / n);
  Box box{Eigen::VectorXd(p), Eigen::VectorXd(p)};
  for (Eigen::Index c = 0; c < p; ++c) {
    const double col_rms = std::sqrt(ls.psi_t_psi(c, c) / n);
    const double bound = options.bound_factor * tau_rms / col_rms;
    const ParameterInfo& info = parameters[static_cast<unsigned>(c)];
    box.upper(c) = std::max(bound, 2.0 * ls.beta(c));
    box.lower(c) = info.nonnegative ? 0.0 : std::min(-bound, 2.0 * ls.beta(c));
  }
  return box;
}

// PSO on the least-squares cost of `ls` (weighted as it was) within its
// box: r.pso and r.beta (fit_log sums the cost at it directly over the rows).
// The swarm searches coordinates whitened by the least-squares
// information: with u the box's normalised coordinates and A = S H S the
// cost's Hessian there (H = Psi^T Psi, S the spans), A = U^T U and
// u = u0 + U^-1 z make the cost c + |z|^2 / rows plus a linear term, round
// in every direction, however ill-conditioned Psi is (the paper's model's
// columns are nearly collinear, and a swarm in u crawled along the valley
// without reaching the optimum). Its box in z holds the image of the whole
// u box; a point is evaluated where it lands in the u box (each coordinate
// clamped to [0, 1]), so the search is still of the bounded problem.
void run_swarm(const Equations& reg, const LeastSquaresResult& ls,
               const std::vector<ParameterInfo>& parameters, const FitOptions& options,
               FitResult& r, Box& box) {
  box = pso_box(ls, reg.rows(), parameters, options);
  const Eigen::VectorXd span = box.upper - box.lower;
  const QuadraticCost cost = QuadraticCost(ls.psi_t_psi, ls.psi_t_tau, ls.beta,
                                           ls.cost * static_cast<double>(reg.rows()), reg.rows())
                                 .over_box(box.lower, box.upper);
  const Eigen::LLT<Eigen::MatrixXd> llt(span.asDiagonal() * ls.psi_t_psi * span.asDiagonal());
  if (llt.info() != Eigen::Success) {
    // An optimum on the box's walls: the round coordinates' clamping is not
    // aligned with the walls, and the swarm does better in the box's own.
    r.pso = run_pso_normalized([&cost](const double* u) { return cost.at(u); }, box.lower,
                               box.upper, options.pso);
    r.beta = r.pso->best;
    return;
  }
  const Eigen::Index p = span.size();
  const Eigen::VectorXd u0 = (ls.beta - box.lower).cwiseQuotient(span);
  const Eigen::MatrixXd upper_factor = llt.matrixU();
  const Eigen::MatrixXd whiten =
      upper_factor.triangularView<Eigen::Upper>().solve(Eigen::MatrixXd::Identity(p, p));
  Eigen::VectorXd z_lower(p), z_upper(p);
  for (Eigen::Index i = 0; i < p; ++i) {
    z_lower(i) = z_upper(i) = 0.0;
    for (Eigen::Index j = 0; j < p; ++j) {
      const double a = upper_factor(i, j) * -u0(j), b = upper_factor(i, j) * (1.0 - u0(j));
      z_lower(i) += std::min(a, b);
      z_upper(i) += std::max(a, b);
    }
    // Within the region where the cost is at most 10 times the optimum's:
    // |z|^2 / rows <= 10 c*.
    const double reach =
        std::sqrt(10.0 * std::max(ls.cost, 1e-300) * static_cast<double>(reg.rows()));
    z_lower(i) = std::max(z_lower(i), -reach);
    z_upper(i) = std::min(z_upper(i), reach);
    if (!(z_upper(i) > z_lower(i))) z_upper(i) = z_lower(i) + reach;
  }
  const auto in_box = [&](const Eigen::VectorXd& z) {
    return Eigen::VectorXd((u0 + whiten * z).cwiseMax(0.0).cwiseMin(1.0));
  };
  // Outside the u box the cost is that of the nearest point in it plus the
  // distance to it in the round metric, so that the walls do not flatten
  // the landscape near an optimum close to them.
  const double per_row = 1.0 / static_cast<double>(reg.rows());
  r.pso = run_pso(
      [&](const Eigen::VectorXd& z) {
        const Eigen::VectorXd u = u0 + whiten * z;
        const Eigen::VectorXd inside = u.cwiseMax(0.0).cwiseMin(1.0);
        const double outside = (upper_factor * (u - inside)).squaredNorm() * per_row;
        return cost.at(inside.data()) + outside;
      },
      z_lower, z_upper, options.pso);
  r.beta = box.lower + span.cwiseProduct(in_box(r.pso->best));
  r.pso->best = r.beta;
}

// Torques (or angles) of the sign opposite to docs/conventions.md's: the
// bounded fit of -tau, from the same moments, explains the log far better
// than that of tau, which pins parameters at their bounds. Throws.
void check_torque_sign(const LeastSquaresResult& ls, const std::vector<ParameterInfo>& parameters,
                       std::size_t rows, const std::string& log_name) {
  if (ls.active_bounds.empty() || ls.psi_t_psi.size() == 0 || rows == 0) return;
  const Eigen::LLT<Eigen::MatrixXd> llt(ls.psi_t_psi);
  if (llt.info() != Eigen::Success) return;
  std::vector<bool> nonnegative;
  for (const ParameterInfo& p : parameters) nonnegative.push_back(p.nonnegative);
  const Eigen::MatrixXd upper = llt.matrixU();
  const Eigen::VectorXd x =
      bounded_least_squares(upper, llt.matrixL().solve(-ls.psi_t_tau), nonnegative);
  const double flipped = (ls.tau_t_tau + 2.0 * x.dot(ls.psi_t_tau) + x.dot(ls.psi_t_psi * x)) /
                         static_cast<double>(rows);
  if (!(flipped < kSignFlipRatio * ls.cost)) return;
  std::ostringstream m;
  m << log_name << ": the torques look opposite in sign to the model's: fitted to -tau the model "
    << "explains the log " << ls.cost / std::max(flipped, 1e-300) << " times better (cost "
    << flipped << " against " << ls.cost << " N^2 m^2), while fitted to tau "
    << ls.active_bounds.size() << " parameter(s) sit at their bound 0. Check the signs of "
    << "tau1..tau3 and q1..q3 against docs/conventions.md (a positive torque turns its joint "
    << "towards positive angles) and negate the columns that differ";
  throw delta::InputError(m.str());
}

// Parameters whose estimates from the log's spans of time differ more than
// kChangingRatio times as much as over any split of its motions (and more
// than the noise's): the log holds runs that differ (glued together) or a
// drift. Into r.changing, with the largest ratio.
void note_changing_parameters(const MotionSpread& spread, const LeastSquaresResult& ls,
                              const std::vector<ParameterInfo>& parameters, FitResult& r) {
  r.changing.clear();
  r.changing_ratio = 0.0;
  for (Eigen::Index c = 0; c < spread.time_std_dev.size(); ++c) {
    const double t = spread.time_std_dev(c), motion = spread.column_std_dev(c);
    if (!(t > kChangingRatio * motion) || !(t > ls.std_dev(c))) continue;
    r.changing.push_back(parameters[static_cast<std::size_t>(c)].name);
    r.changing_ratio = std::max(r.changing_ratio, t / motion);
  }
}

// Least squares, then PSO on the same cost where asked: r.beta, the costs,
// the conditioning and the box.
LeastSquaresResult estimate_on(const Equations& reg, const std::vector<ParameterInfo>& parameters,
                               const FitOptions& options, std::size_t lags,
                               const std::string& log_name, const JointGrams* grams, FitResult& r,
                               Box& box) {
  const bool pso = options.method == Method::kPso;
  LeastSquaresResult ls = solve_least_squares(reg, parameters, options.solver, options.weights,
                                              log_name, lags, options.threads, grams);
  check_torque_sign(ls, parameters, reg.rows(), log_name);
  const MotionSpread spread = add_model_error(reg, lags, ls, options.threads);
  note_changing_parameters(spread, ls, parameters, r);
  if (pso) run_swarm(reg, ls, parameters, options, r, box);
  r.joint_weights = ls.joint_weights;
  r.condition_number = ls.condition_number;
  r.std_dev_lags = ls.correlation_lags;
  r.condition_number_scaled = ls.condition_number_scaled;
  r.ls_cost_Nm2 = ls.cost;
  for (const std::size_t c : ls.active_bounds) r.active_bounds.push_back(parameters[c].name);
  if (!pso) {
    box = pso_box(ls, reg.rows(), parameters, options);
    r.beta = ls.beta;
    r.cost_Nm2 = ls.cost;
  }
  return ls;
}

// The equations with only the given columns.
Regression columns_of(const Equations& r, const std::vector<std::size_t>& columns) {
  Regression out;
  out.psi.resize(r.psi.rows(), static_cast<Eigen::Index>(columns.size()));
  for (std::size_t k = 0; k < columns.size(); ++k) {
    out.psi.col(static_cast<Eigen::Index>(k)) = r.psi.col(static_cast<Eigen::Index>(columns[k]));
  }
  out.tau = r.tau;
  out.t_s.assign(r.t_s.begin(), r.t_s.end());
  out.joint.assign(r.joint.begin(), r.joint.end());
  out.sample.assign(r.sample.begin(), r.sample.end());
  return out;
}

// A vector over the independent columns, spread over all p with `fill` at
// the dependent ones.
Eigen::VectorXd spread(const Eigen::VectorXd& v, const Identifiability& id, Eigen::Index p,
                       double fill) {
  Eigen::VectorXd out = Eigen::VectorXd::Constant(p, fill);
  for (std::size_t k = 0; k < id.independent.size(); ++k) {
    out(static_cast<Eigen::Index>(id.independent[k])) = v(static_cast<Eigen::Index>(k));
  }
  return out;
}

// As estimate_on; where the log cannot separate every parameter, the
// estimate is of the base parameters (least_squares.hpp): the independent
// columns alone, each value standing for its combination, the dependent
// parameters at 0 with no standard deviation.
LeastSquaresResult estimate(const Equations& reg, const Model& model, const FitOptions& options,
                            std::size_t lags, const std::string& log_name, const JointGrams* grams,
                            FitResult& r, Box& box) {
  try {
    return estimate_on(reg, model.parameters(), options, lags, log_name, grams, r, box);
  } catch (const RankDeficientError& e) {
    const Identifiability& id = e.identifiability();
    if (id.independent.empty()) throw;
    const auto p = static_cast<Eigen::Index>(model.size());
    std::vector<ParameterInfo> kept;
    for (const std::size_t c : id.independent) kept.push_back(model.parameters()[c]);
    const Regression reduced = columns_of(reg, id.independent);
    Box reduced_box;
    r.active_bounds.clear();
    LeastSquaresResult ls =
        estimate_on(Equations(reduced), kept, options, lags, log_name, nullptr, r, reduced_box);
    r.identifiability = id;
    r.beta = spread(r.beta, id, p, 0.0);
    box.lower = spread(reduced_box.lower, id, p, 0.0);
    box.upper = spread(reduced_box.upper, id, p, 0.0);
    ls.beta = spread(ls.beta, id, p, 0.0);
    ls.unconstrained_beta = spread(ls.unconstrained_beta, id, p, 0.0);
    ls.std_dev = spread(ls.std_dev, id, p, std::numeric_limits<double>::quiet_NaN());
    ls.honest_std_dev = spread(ls.honest_std_dev, id, p, std::numeric_limits<double>::quiet_NaN());
    Eigen::MatrixXd correlation =
        Eigen::MatrixXd::Constant(p, p, std::numeric_limits<double>::quiet_NaN());
    for (std::size_t a = 0; a < id.independent.size(); ++a) {
      for (std::size_t b = 0; b < id.independent.size(); ++b) {
        correlation(static_cast<Eigen::Index>(id.independent[a]),
                    static_cast<Eigen::Index>(id.independent[b])) =
            ls.correlation(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b));
      }
    }
    ls.correlation = std::move(correlation);
    for (std::size_t& c : ls.active_bounds) c = id.independent[c];
    return ls;
  }
}

// What the estimate of parameter c stands for where the log cannot separate
// every parameter: "" for a parameter estimated alone, "not identifiable"
// for a dependent one, else "name + k other + ..." (its base combination).
std::string base_combination(const Model& model, const Identifiability& id, std::size_t c,
                             std::vector<std::pair<std::string, double>>& combined_with) {
  const auto& params = model.parameters();
  const auto at = std::find(id.independent.begin(), id.independent.end(), c);
  if (at == id.independent.end()) return "not identifiable";
  const auto row = static_cast<Eigen::Index>(at - id.independent.begin());
  std::ostringstream s;
  s << params[c].name;
  bool any = false;
  for (std::size_t k = 0; k < id.dependent.size(); ++k) {
    const double coefficient = id.coefficient(row, static_cast<Eigen::Index>(k));
    if (std::abs(coefficient) < 1e-9) continue;
    char buf[48];
    std::snprintf(buf, sizeof buf, " %c %.4g ", coefficient < 0 ? '-' : '+', std::abs(coefficient));
    s << buf << params[id.dependent[k]].name;
    combined_with.emplace_back(params[id.dependent[k]].name, coefficient);
    any = true;
  }
  return any ? s.str() : "";
}

std::vector<ParameterEstimate> parameter_estimates(const Model& model, const LeastSquaresResult& ls,
                                                   const Eigen::VectorXd& beta, const Box& box,
                                                   const std::optional<Identifiability>& id) {
  std::vector<ParameterEstimate> out;
  for (Eigen::Index c = 0; c < beta.size(); ++c) {
    ParameterEstimate e;
    e.info = model.parameters()[static_cast<unsigned>(c)];
    e.value = beta(c);
    e.ls_value = ls.beta(c);
    e.unconstrained_value = ls.unconstrained_beta(c);
    e.std_dev = ls.honest_std_dev(c);
    e.ls_std_dev = ls.std_dev(c);
    e.rel_std_percent = ls.beta(c) != 0.0 ? 100.0 * e.std_dev / std::abs(ls.beta(c))
                                          : std::numeric_limits<double>::infinity();
    if (ls.psi_t_psi.rows() == beta.size() && ls.tau_t_tau > 0.0) {
      e.std_torque_share = e.std_dev * std::sqrt(ls.psi_t_psi(c, c) / ls.tau_t_tau);
    }
    e.lower = box.lower(c);
    e.upper = box.upper(c);
    for (const std::size_t a : ls.active_bounds)
      e.at_bound = e.at_bound || a == static_cast<std::size_t>(c);
    if (id) {
      e.combination = base_combination(model, *id, static_cast<std::size_t>(c), e.combined_with);
    }
    out.push_back(e);
  }
  return out;
}

// The model's torque in each row of a preprocessed log. The drive train's
// terms (Model::torque_columns) are written with the measured torque: the
// prediction takes them out and solves for the model's own torque instead.
Eigen::VectorXd predicted_torque(const Model& model, const Regression& reg,
                                 const Eigen::VectorXd& beta) {
  const std::vector<std::size_t> torque_terms = model.torque_columns();
  if (torque_terms.empty()) return reg.psi * beta;
  Eigen::VectorXd rigid = beta;
  for (const std::size_t c : torque_terms) rigid(static_cast<Eigen::Index>(c)) = 0.0;
  Eigen::VectorXd yhat = reg.psi * rigid;
  for (std::size_t row = 0; row < reg.rows(); ++row) {
    const auto i = static_cast<Eigen::Index>(row);
    yhat(i) = model.solve_torque(reg.joint[row], yhat(i), reg.velocity_rad_s[row], beta);
  }
  return yhat;
}

// Measured and predicted torques of a preprocessed log.
Prediction prediction_of(const Model& model, const Regression& reg, const Eigen::VectorXd& beta,
                         const std::string& log_name) {
  Prediction out;
  out.log = log_name;
  out.t_s.assign(reg.t_s.begin(), reg.t_s.end());
  const Eigen::VectorXd yhat = predicted_torque(model, reg, beta);
  const std::size_t n = reg.samples();
  for (unsigned j = 0; j < 3; ++j) {
    out.measured_Nm[j].resize(n);
    out.predicted_Nm[j].resize(n);
    out.velocity_rad_s[j].resize(n);
  }
  ResidualSquares squares;
  for (std::size_t row = 0; row < reg.rows(); ++row) {
    const auto i = static_cast<Eigen::Index>(row);
    out.measured_Nm[reg.joint[row]][reg.sample[row]] = reg.tau(i);
    out.predicted_Nm[reg.joint[row]][reg.sample[row]] = yhat(i);
    out.velocity_rad_s[reg.joint[row]][reg.sample[row]] = reg.velocity_rad_s[row];
    squares.all[reg.joint[row]] += (reg.tau(i) - yhat(i)) * (reg.tau(i) - yhat(i));
  }
  out.rmse_filtered_Nm = rmse_per_joint(reg, squares);
  out.rmse_measured_Nm = reg.measured.rmse(beta);
  return out;
}

}  // namespace

double min_speed_for(const FitOptions& options) {
  if (options.min_speed_rad_s) return *options.min_speed_rad_s;
  return options.model.name == "paper14" ? 0.0 : kDefaultMinSpeedRadS;
}

namespace {

// The options with the gearbox's compliance where the fit asks for it and
// the log supports it (kept in r).
FitOptions options_with_elasticity(const DeltaLog& log, FitOptions options, FitResult& r) {
  if (!options.fit_elasticity) return options;
  r.elasticity = fit_elasticity(log, options);
  if (r.elasticity->supported) {
    options.model.gearbox_compliance_rad_per_Nm = r.elasticity->compliance_rad_per_Nm;
  }
  return options;
}

// The log at the arm's angles for an elastic model (elasticity.hpp): the
// deflection is the model's own torque, with the rigid least squares'
// parameters, over the stiffness.
void move_to_arm_side(DeltaLog& log, const FitOptions& options) {
  if (!options.model.elastic()) return;
  ModelOptions rigid_options = options.model;
  rigid_options.gearbox_compliance_rad_per_Nm = {};
  const auto rigid = make_model(rigid_options);
  PrepareOptions prepare = options.prepare;
  prepare.slow_rows_last_below_rad_s = min_speed_for(options);
  const Preprocessed pre = preprocess(*rigid, log, prepare, options.threads);
  const Equations fast(pre.regression, pre.fast_rows);
  const Eigen::VectorXd beta = fast.psi.colPivHouseholderQr().solve(fast.tau);
  log = arm_side_for_prediction(*make_model(options.model), beta, log, options.prepare);
}

// The options of the fit: the given ones, with the friction's shape fitted
// first on the log where they ask for it (kept in r).
FitOptions options_with_friction_shape(const DeltaLog& log, const FitOptions& given, FitResult& r) {
  FitOptions options = given;
  if (options.fit_friction_shape) {
    r.friction_shape = fit_friction_shape(log, options);
    options.model.coulomb_smoothing_rad_s = r.friction_shape->coulomb_smoothing_rad_s;
    if (options.model.stribeck_velocity_rad_s > 0.0) {
      options.model.stribeck_velocity_rad_s = r.friction_shape->stribeck_velocity_rad_s;
    }
  }
  return options;
}

// What preprocessing did with the log, for the report.
void note_preprocessing(const Preprocessed& pre, const DeltaLog& log, FitResult& r) {
  r.samples_in_log = pre.report.samples_in_log;
  r.derivatives = pre.report.derivatives;
  r.state_cutoff_hz = pre.report.state_cutoff_hz;
  r.gaps = log.gaps;
  r.geometry = log.geometry;
  r.segments_used = pre.report.segments_used;
  r.segments_dropped = pre.report.segments_dropped;
}

// The fit's residuals on its own log: the PSO's cost (checked to be at its
// optimum), the RMSE of the filtered and of the measured torques.
void note_fit_residuals(const Regression& all_rows, const Equations& reg,
                        const std::string& log_name, unsigned threads, FitResult& r) {
  r.fit.log = log_name;
  r.fit.samples = all_rows.samples();
  const ResidualSquares squares = residual_squares(all_rows, reg.rows(), r.beta, threads);
  if (r.pso) {
    r.cost_Nm2 = squares.cost(r.joint_weights, reg.rows());
    require_pso_at_optimum(r, log_name);
  }
  r.fit.rmse_filtered_Nm = rmse_per_joint(all_rows, squares);
  r.fit.rmse_measured_Nm = all_rows.measured.rmse(r.beta);
  for (unsigned j = 0; j < 3; ++j) {
    const std::size_t n = all_rows.measured.rows[j];
    r.fit.rms_torque_Nm[j] =
        n > 0 ? std::sqrt(all_rows.measured.tau_sq[j] / static_cast<double>(n)) : 0.0;
  }
}

// The collision detector's thresholds from the fit's residual on its own
// log, where the controller runs the model as fitted.
void note_collision_thresholds(const Prediction& fitted, FitResult& r) {
  r.collision_unavailable = collision_thresholds_unavailable(r.options.model);
  if (r.collision_unavailable.empty() && !r.fit.ranges.known) {
    r.collision_unavailable = "the log's motion ranges are unknown";
  }
  if (r.collision_unavailable.empty()) r.collision = collision_thresholds_from(fitted, r.fit);
}

// The logged torque's lag behind the motion (r.torque_lag), a doubt where
// it matters.
void note_torque_lag(FitResult& r) {
  if (!r.torque_lag || r.torque_lag->error_drop < kTorqueLagDoubt) return;
  std::ostringstream m;
  m << "the logged torque lags the motion by " << r.torque_lag->lag_s * 1e3
    << " ms (the drive's current filter, or its torque reported late): shifting the model's "
    << "torque by it lowers the torque error by " << 100.0 * r.torque_lag->error_drop
    << " %; the fit's inertias and viscous friction absorb the rest of it. Log the drive's torque "
       "unfiltered "
    << "(or its filter shorter), or time-shift the torque columns before fitting";
  r.doubts.push_back(m.str());
}

// The controller's prediction of the fit log, where the model has terms
// the controller does not run (cogging): without them.
Prediction controller_prediction(const Model& model, const Regression& all_rows,
                                 const std::string& log_name, const FitResult& r) {
  Eigen::VectorXd beta = r.beta;
  for (const std::size_t c : model.cogging_columns()) beta(static_cast<Eigen::Index>(c)) = 0.0;
  return prediction_of(model, all_rows, beta, log_name);
}

// What the fit's own log's prediction tells: the collision thresholds, the
// torque's lag, and cogging the model lacks (searched where `angles` has
// the log's angles). The lag and the rest are found side by side.
void note_fit_prediction(const Model& model, const Regression& all_rows, const Prediction& fitted,
                         const AngleTrack& angles, double cutoff_hz, unsigned threads,
                         FitResult& r) {
  run_both(
      threads,
      [&] {
        if (model.cogging_columns().empty()) {
          note_collision_thresholds(fitted, r);
        } else {
          note_collision_thresholds(controller_prediction(model, all_rows, fitted.log, r), r);
        }
        if (!angles.t_s.empty()) r.cogging = find_cogging(fitted, angles, cutoff_hz);
      },
      [&] { r.torque_lag = torque_lag(fitted); });
  note_torque_lag(r);
}

// What the fit tells of its own log: the Stribeck signature and the log's
// prediction (side by side), the doubts, the residuals, and what the
// prediction tells; the prediction kept where asked.
void note_fitted_log(const Model& model, const Regression& all_rows, const Equations& reg,
                     const std::string& log_name, const AngleTrack& angles,
                     const FitOptions& options, bool keep_predictions, FitResult& r) {
  Prediction fitted;
  run_both(
      options.threads,
      [&] {
        if (options.model.name != "paper14" && !(options.model.stribeck_velocity_rad_s > 0.0)) {
          r.stribeck =
              stribeck_signature(all_rows, reg.rows(), options.model.coulomb_smoothing_rad_s,
                                 nyquist_step(r.std_dev_lags));
        }
      },
      [&] { fitted = prediction_of(model, all_rows, r.beta, log_name); });
  r.doubts = doubts_of(r);
  note_fit_residuals(all_rows, reg, log_name, options.threads, r);
  note_fit_prediction(model, all_rows, fitted, angles, options.prepare.cutoff_hz, options.threads,
                      r);
  if (keep_predictions) {
    r.predictions.push_back(std::move(fitted));
    r.predictions.back().role = "fit";
  }
}

// A model with cogging terms: its held-out error with and without them.
void note_cogging_support(const Model& model, const Regression& all_rows, std::size_t fast_rows,
                          unsigned threads, FitResult& r) {
  const std::vector<std::size_t> columns = model.cogging_columns();
  if (columns.empty() || all_rows.samples() < 20 * kSupportFolds) return;
  CoggingSupport s;
  s.held_out_with_Nm = held_out_rmse(model, all_rows, fast_rows, kSupportFolds, threads);
  s.held_out_without_Nm =
      held_out_rmse(model, all_rows, fast_rows, kSupportFolds, threads, columns);
  s.supported = s.held_out_with_Nm < s.held_out_without_Nm * (1.0 - kDriveTrainMargin);
  r.cogging_support = s;
}

// The fitted parameters' RMSE on each validation log, and their
// predictions where kept.
void validate_fit(const Model& model, const FitOptions& options,
                  const std::vector<const DeltaLog*>& validation, bool keep_predictions,
                  FitResult& r) {
  for (const DeltaLog* v : validation) {
    Prediction p = predict(model, r.beta, *v, options.prepare, options.threads);
    r.validation.push_back(p.rmse());
    p.role = "validation";
    if (keep_predictions) r.predictions.push_back(std::move(p));
  }
}

}  // namespace

FitResult fit_log(DeltaLog log, const FitOptions& given_options,
                  const std::vector<const DeltaLog*>& validation, bool keep_predictions) {
  const auto t0 = std::chrono::steady_clock::now();
  FitResult r;
  const FitOptions options =
      options_with_elasticity(log, options_with_friction_shape(log, given_options, r), r);
  move_to_arm_side(log, options);
  r.options = options;
  const auto model = make_model(options.model);
  r.min_speed_rad_s = min_speed_for(options);
  // The slow equations after the others: the estimate takes the others.
  PrepareOptions prepare = options.prepare;
  prepare.slow_rows_last_below_rad_s = r.min_speed_rad_s;
  const std::array<double, 3> spans = angle_spans(log);
  // Not behind an elastic gearbox: the model's angles are the arm's, and
  // the cogging's are the motor's, tens of mrad apart on a soft one.
  const bool search_cogging = options.search_cogging && options.model.name != "paper14" &&
                              !options.model.cogging() && !options.model.elastic();
  const AngleTrack angles =
      search_cogging ? angle_track(log, options.prepare.cutoff_hz) : AngleTrack{};
  // From here on the log is only its name and gaps.
  Preprocessed pre = preprocess_releasing(*model, log, prepare, options.threads);
  Regression& all_rows = pre.regression;
  note_preprocessing(pre, log, r);
  r.fit.ranges = pre.report.ranges;
  const Equations reg(all_rows, pre.fast_rows);
  r.equations_used = reg.rows_per_joint();
  require_equations_per_joint(r, log.name, spans);
  // The support's pass over the equations also sums their Gram matrices.
  std::optional<JointGrams> grams;
  if (options.model.name != "paper14" && all_rows.samples() >= 20 * kSupportFolds) {
    grams.emplace();
    r.support = judge_support(*model, options.model, all_rows, pre.fast_rows, kSupportFolds,
                              options.threads, &*grams);
  }
  note_cogging_support(*model, all_rows, pre.fast_rows, options.threads, r);

  const auto te = std::chrono::steady_clock::now();
  Box box;
  const LeastSquaresResult ls =
      estimate(reg, *model, options,
               correlation_lags_for(pre.report.sample_rate_hz, options.prepare.cutoff_hz), log.name,
               grams ? &*grams : nullptr, r, box);
  r.seconds_estimator = seconds_since(te);
  r.parameters = parameter_estimates(*model, ls, r.beta, box, r.identifiability);
  r.correlation = ls.correlation;
  note_fitted_log(*model, all_rows, reg, log.name, angles, options, keep_predictions, r);
  validate_fit(*model, options, validation, keep_predictions, r);
  r.seconds_total = seconds_since(t0);
  return r;
}

void require_pso_at_optimum(const FitResult& r, const std::string& log_name) {
  const double gap = (r.cost_Nm2 - r.ls_cost_Nm2) / r.ls_cost_Nm2;
  if (!(gap > kPsoOptimumTolerance)) return;
  std::ostringstream m;
  m << log_name << ": PSO stopped at a cost " << gap << " (relative) above the optimum of the same "
    << "bounded problem (" << r.cost_Nm2 << " against " << r.ls_cost_Nm2
    << " N^2 m^2, least squares): its parameters are not the fit, so nothing is reported; use "
    << "--method ls (the exact optimum), or give the swarm more room (--iterations, "
    << "--particles, --restarts)";
  throw PsoShortOfOptimumError(m.str());
}

Prediction predict(const Model& model, const Eigen::VectorXd& beta, const DeltaLog& log,
                   const PrepareOptions& prepare, unsigned threads) {
  if (model.options().elastic()) {
    const DeltaLog arm = arm_side_for_prediction(model, beta, log, prepare);
    const Preprocessed pre = preprocess(model, arm, prepare, threads);
    Prediction p = prediction_of(model, pre.regression, beta, log.name);
    p.ranges = pre.report.ranges;
    return p;
  }
  const Preprocessed pre = preprocess(model, log, prepare, threads);
  Prediction p = prediction_of(model, pre.regression, beta, log.name);
  p.ranges = pre.report.ranges;
  return p;
}

}  // namespace host_id
