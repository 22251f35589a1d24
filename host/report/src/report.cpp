#include "host_id/report.hpp"

#include <cmath>
#include <cstdio>
#include <optional>
#include <sstream>

#include "delta/atomic_file.hpp"
#include "delta/input_error.hpp"
#include "delta/json_text.hpp"
#include "delta/read_file.hpp"

namespace host_id {

namespace {

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

// The logged torque's lag behind the motion, and whether it matters.
void text_torque_lag(const FitResult& r, std::ostream& s) {
  if (!r.torque_lag) return;
  const TorqueLag& l = *r.torque_lag;
  s << "  lag       the logged torque lags the motion by " << fmt("%.2f", l.lag_s * 1e3)
    << " ms; shifting the model by it lowers the torque error by "
    << fmt("%.1f", 100.0 * l.error_drop) << " %"
    << (l.error_drop < kTorqueLagDoubt ? ": it costs nothing at this log's bandwidth"
                                       : " (DOUBTFUL below)")
    << "\n";
}

std::string three(const delta::Joint3& v, const char* format) {
  return fmt(format, v[0]) + ", " + fmt(format, v[1]) + ", " + fmt(format, v[2]);
}

// Cogging the residual shows, and the terms' judgement where a fit had them.
void text_cogging(const FitResult& r, std::ostream& s) {
  const bool found = r.cogging && r.cogging->found();
  if (found) {
    s << "  cogging   the residual repeats " << three(r.cogging->periods_per_rev, "%.4g")
      << " times per joint revolution (0: not), amplitude "
      << three(r.cogging->amplitude_Nm, "%.3g") << " N m";
  }
  if (r.cogging_support) {
    const CoggingSupport& c = *r.cogging_support;
    s << (found ? "\n            " : "  cogging   ") << "held-out torque error "
      << fmt("%.4g", c.held_out_with_Nm) << " N m with the cogging terms, "
      << fmt("%.4g", c.held_out_without_Nm) << " N m without (" << kSupportFolds
      << " time blocks): "
      << (c.supported ? "the log supports them" : "they do not lower it by 10 %")
      << (r.options.model.cogging() ? ", fitted" : ", left out") << "\n";
    return;
  }
  if (found) {
    s << ": cogging the model lacks; --model auto takes it in where it lowers the held-out "
         "error, --cogging-periods gives it\n";
  } else if (r.cogging) {
    std::string peaks;
    for (unsigned j = 0; j < 3; ++j) {
      const double ratio = r.cogging->peak_ratio[j];
      peaks += (j == 0 ? "" : ", ") + (ratio > 0.0 ? fmt("%.3g", ratio) : std::string("-"));
    }
    s << "  cogging   none in the residual (its spectrum over each joint's angle peaks at " << peaks
      << " times its median, -: the joint not searched; cogging is a peak of "
      << fmt("%.0f", kCoggingPeakRatio) << " or more that holds " << fmt("%.1f", kLeastCoggingShare)
      << " of the residual's RMS)\n";
  }
}

// The collision detector's thresholds the model carries, or why none.
void text_collision(const FitResult& r, std::ostream& s) {
  if (!r.collision) {
    if (!r.collision_unavailable.empty()) {
      s << "  collision no thresholds for the controller's detector: " << r.collision_unavailable
        << "\n";
    }
    return;
  }
  const delta::CollisionThresholds& t = r.collision->thresholds;
  s << "  collision thresholds for the controller's detector (docs/safety.md), "
    << fmt("%.0f", kCollisionMargin) << "x the residual's peak "
    << fmt("%.3g", r.collision->peak_residual_Nm[0]) << ", "
    << fmt("%.3g", r.collision->peak_residual_Nm[1]) << ", "
    << fmt("%.3g", r.collision->peak_residual_Nm[2]) << " N m:\n";
  for (unsigned j = 0; j < 3; ++j) {
    s << "            joint " << j + 1 << ": " << fmt("%.4g", t.base_Nm[j]) << " N m + "
      << fmt("%.4g", t.per_speed_Nm_s_per_rad[j]) << " N m s/rad |qd| + "
      << fmt("%.4g", t.per_acceleration_Nm_s2_per_rad[j]) << " N m s^2/rad |qdd|\n";
  }
}

// The gearboxes' stiffness found (fit --elastic), with the costs and the
// held-out errors rigid and elastic.
void text_elasticity(const ElasticityResult& e, std::ostream& s) {
  s << "  elastic   gearbox stiffness K = 1 / c ";
  s << (e.from_arm_encoders ? "from the arm's encoders (qa1..qa3)"
                            : "by PSO (variable projection, " + std::to_string(e.evaluations) +
                                  " evaluations, " + fmt("%.1f", e.seconds) + " s)");
  s << ":";
  for (unsigned j = 0; j < 3; ++j) {
    const double c = e.compliance_rad_per_Nm[j];
    s << (j == 0 ? " " : ", ");
    if (c > 0.0) {
      s << fmt("%.0f", 1.0 / c) << " +- " << fmt("%.2g", e.compliance_std[j] / (c * c));
    } else {
      s << "rigid (c 0 +- " << fmt("%.2g", e.compliance_std[j]) << ")";
    }
  }
  s << " N m/rad\n";
  if (!e.from_arm_encoders) {
    s << "            cost " << fmt("%.6e", e.cost_rigid_Nm2) << " rigid, "
      << fmt("%.6e", e.cost_elastic_Nm2) << " elastic (least squares, unbounded)\n";
  }
  if (e.held_out_rigid_Nm > 0.0) {
    s << "            held-out torque error " << fmt("%.4g", e.held_out_elastic_Nm)
      << " N m elastic, " << fmt("%.4g", e.held_out_rigid_Nm) << " N m rigid (" << kSupportFolds
      << " time blocks): "
      << (e.supported ? "the log supports the elastic model, fitted below"
                      : "the rigid model explains the log as well, fitted below")
      << "\n";
  }
}

std::string model_summary(const ModelOptions& m, std::size_t p) {
  std::ostringstream s;
  s << m.name;
  if (m.name == "delta" || m.name == "lumped") {
    s << " (" << (m.name == "delta" ? "higher-fidelity" : "point masses") << ", "
      << (m.per_joint ? "per-joint" : "shared") << " arm inertia and gravity, "
      << (m.offsets ? "with" : "no") << " torque offsets, Coulomb smoothing "
      << m.coulomb_smoothing_rad_s << " rad/s";
    if (m.stribeck_velocity_rad_s > 0.0) {
      s << ", Stribeck velocity " << m.stribeck_velocity_rad_s << " rad/s";
    }
    if (m.load_friction) s << ", load friction";
    if (m.torque_gains) s << ", torque gains";
    if (m.elastic()) {
      s << ", elastic gearboxes K";
      for (unsigned j = 0; j < 3; ++j) {
        const double c = m.gearbox_compliance_rad_per_Nm[j];
        s << (j == 0 ? " " : ", ") << (c > 0.0 ? fmt("%.0f", 1.0 / c) : std::string("rigid"));
      }
      s << " N m/rad";
    }
    if (m.cogging()) {
      s << ", cogging at " << three(m.cogging_periods_per_rev, "%.6g") << " periods per revolution";
    }
    s << ")";
  } else {
    s << " (the paper's regressor, constant lambda)";
  }
  s << ", " << p << " parameters";
  return s.str();
}

const char* topology_name(PsoTopology t) {
  return t == PsoTopology::kGlobal ? "gbest" : "ring";
}

// The truth of what an estimate stands for: its parameter's, or that of its
// base combination; none where a truth is missing.
std::optional<double> parameter_truth_of(const FitResult& r, const ParameterEstimate& e) {
  const auto t = r.truth.find(e.info.name);
  if (t == r.truth.end()) return std::nullopt;
  double value = t->second;
  for (const auto& [name, coefficient] : e.combined_with) {
    const auto d = r.truth.find(name);
    if (d == r.truth.end()) return std::nullopt;
    value += coefficient * d->second;
  }
  return value;
}

// The estimates; with a known truth, each one's truth and error beside it.
std::string parameter_table(const FitResult& r) {
  std::ostringstream s;
  const bool truth = !r.truth.empty();
  s << "  parameter                      value     std dev   rel std"
    << (truth ? "          truth     error" : "") << "   unit\n";
  for (const auto& e : r.parameters) {
    char buf[240];
    if (!e.identifiable()) {
      std::snprintf(buf, sizeof buf, "  %-22s   not identifiable on this log (absorbed above)\n",
                    e.info.name.c_str());
      s << buf;
      continue;
    }
    // A huge spread (1.59e+04) keeps its column.
    const std::string rel = !std::isfinite(e.rel_std_percent) ? "       - "
                            : e.rel_std_percent < 1e4         ? fmt("%8.3f %%", e.rel_std_percent)
                                                              : fmt("%8.2e %%", e.rel_std_percent);
    std::string against;
    if (truth) {
      const std::optional<double> t = parameter_truth_of(r, e);
      against = !t ? std::string(25, ' ')
                   : fmt("%15.6g", *t) + (*t != 0.0 ? fmt("%+8.2f %%", 100.0 * (e.value / *t - 1.0))
                                                    : std::string("       - "));
    }
    std::snprintf(buf, sizeof buf, "  %-22s %14.6g %11.3g  %s%s  %s\n", e.info.name.c_str(),
                  e.value, e.std_dev, rel.c_str(), against.c_str(), e.info.unit.c_str());
    s << buf;
    if (!e.combination.empty()) s << "      (estimates " << e.combination << ")\n";
  }
  if (truth) s << "  (truth: derived from the robot description, docs/model.md)\n";
  if (r.identifiability) {
    s << "  note      " << r.identifiability->message
      << ": the estimate is of the base parameters, the combinations named above\n";
  }
  return s.str();
}

}  // namespace

nlohmann::json json_rmse(const LogRmse& r) {
  nlohmann::json out{{"log", r.log},
                     {"samples", r.samples},
                     {"rmse_measured_Nm", r.rmse_measured_Nm},
                     {"rmse_filtered_Nm", r.rmse_filtered_Nm}};
  if (r.ranges.known) {
    out["ranges"] = {{"q_min_rad", r.ranges.q_min_rad},
                     {"q_max_rad", r.ranges.q_max_rad},
                     {"qd_max_rad_s", r.ranges.qd_max_rad_s},
                     {"qdd_max_rad_s2", r.ranges.qdd_max_rad_s2}};
  }
  return out;
}

std::string text_rmse_table(const std::vector<LogRmse>& rows, const std::string& first_label) {
  std::ostringstream s;
  s << "  torque RMSE [N m]                  joint 1    joint 2    joint 3   samples\n";
  for (const bool measured : {true, false}) {
    s << (measured ? "  against the measured torque (noise included; the paper's Table 2):\n"
                   : "  against the filtered torque (the model's own error):\n");
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const std::string label = i == 0 ? first_label : "validate";
      // The file name; the folder only when it fits.
      std::string name = rows[i].log;
      if (name.size() > 24) name = name.substr(name.find_last_of('/') + 1);
      if (name.size() > 24) name = name.substr(0, 21) + "...";
      const auto& e = measured ? rows[i].rmse_measured_Nm : rows[i].rmse_filtered_Nm;
      char buf[160];
      std::snprintf(buf, sizeof buf, "  %-8s %-24s %10.5f %10.5f %10.5f %9zu\n", label.c_str(),
                    name.c_str(), e[0], e[1], e[2], rows[i].samples);
      s << buf;
    }
  }
  return s.str();
}

std::string text_table2(const std::vector<FitResult>& results) {
  std::ostringstream s;
  s << "Table 2: torque RMSE per joint [N m]     joint 1    joint 2    joint 3\n";
  for (const bool measured : {true, false}) {
    s << (measured ? "  against the measured torque (noise included):\n"
                   : "  against the filtered torque (the model's own error):\n");
    for (const FitResult& r : results) {
      std::vector<LogRmse> rows{r.fit};
      rows.insert(rows.end(), r.validation.begin(), r.validation.end());
      for (std::size_t i = 0; i < rows.size(); ++i) {
        std::string name = rows[i].log;
        name = name.substr(name.find_last_of('/') + 1);
        if (name.size() > 18) name = name.substr(0, 15) + "...";
        const auto& e = measured ? rows[i].rmse_measured_Nm : rows[i].rmse_filtered_Nm;
        char buf[160];
        std::snprintf(buf, sizeof buf, "  %-8s %-8s %-18s %10.5f %10.5f %10.5f\n",
                      r.options.model.name.c_str(), i == 0 ? "fit" : "validate", name.c_str(), e[0],
                      e[1], e[2]);
        s << buf;
      }
    }
  }
  return s.str();
}

namespace {

// What was fitted: the samples and equations used, the gaps, the model.
void text_samples(const FitResult& r, std::ostream& s) {
  s << "host_id fit: " << r.fit.log << "\n";
  s << "  samples   " << r.fit.samples << " of " << r.samples_in_log << " used, in "
    << r.segments_used << " segment(s)";
  if (r.segments_dropped) s << ", " << r.segments_dropped << " too short and dropped";
  s << "\n            " << r.derivatives << "\n";
  if (r.min_speed_rad_s > 0.0) {
    s << "            equations used per joint " << r.equations_used[0] << ", "
      << r.equations_used[1] << ", " << r.equations_used[2] << " of " << r.fit.samples
      << " (left out: |qd| < " << fmt("%g", r.min_speed_rad_s) << " rad/s)\n";
  }
  for (const auto& g : r.gaps)
    s << "  gap       line " << g.line << ": " << g.what << " (not bridged)\n";
  s << "  model     " << model_summary(r.options.model, r.parameters.size()) << "\n";
  if (r.support) {
    const ModelSelection& m = *r.support;
    const VariantScore& fitted = m.variants[variant_index(m, r.options.model)];
    const VariantScore& best = m.variants[m.chosen];
    s << "  support   ";
    if (&best == &fitted) {
      s << fitted.name << ", as fitted: the log supports no other variant (held-out torque error "
        << fmt("%.4g", fitted.held_out_rmse_Nm) << " N m over " << m.folds << " time blocks)";
    } else {
      s << "the log supports " << best.name << ": held-out torque error "
        << fmt("%.4g", best.held_out_rmse_Nm) << " N m against "
        << fmt("%.4g", fitted.held_out_rmse_Nm) << " N m for the " << fitted.name << " fitted ("
        << m.folds << " time blocks)";
    }
    if (!m.alike.empty()) s << "; " << m.alike << " explain it as well";
    if (!r.friction_shape) s << "; friction shape as given (--fit-friction-shape judges it)";
    s << "\n";
  }
}

// How it was fitted: the method, the weights, the friction's shape, the time.
void text_method(const FitResult& r, std::ostream& s) {
  const auto& o = r.options;
  if (r.pso) {
    const auto& p = *r.pso;
    s << "  method    pso: " << o.pso.particles << " particles, " << topology_name(o.pso.topology)
      << " topology, seed " << o.pso.seed << ", " << p.iterations << " of " << o.pso.iterations
      << " iterations (stopped on " << p.stop_reason << "), " << p.restarts_done << " restart(s), "
      << p.evaluations << " cost evaluations\n";
    s << "            " << p.particles_on_bound << " of " << o.pso.particles
      << " particles ended on the edge of the search region\n";
  } else {
    s << "  method    ls: " << (o.solver == LsSolver::kQr ? "QR" : "SVD")
      << (o.weights == LsWeights::kJoint ? ", weighted per joint" : ", ordinary") << "\n";
  }
  if (o.weights == LsWeights::kJoint) {
    s << "  weights   " << fmt("%.3f", r.joint_weights[0]) << " " << fmt("%.3f", r.joint_weights[1])
      << " " << fmt("%.3f", r.joint_weights[2]) << " (1 / residual variance, mean 1)\n";
  }
  if (r.friction_shape) {
    const FrictionShapeResult& f = *r.friction_shape;
    s << "  friction  shape by PSO (variable projection, " << f.evaluations << " evaluations, "
      << fmt("%.1f", f.seconds) << " s): Coulomb smoothing "
      << fmt("%.4g", f.coulomb_smoothing_rad_s) << " +- " << fmt("%.2g", f.coulomb_smoothing_std)
      << " rad/s";
    if (f.stribeck_velocity_rad_s > 0.0) {
      s << ", Stribeck velocity " << fmt("%.4g", f.stribeck_velocity_rad_s) << " +- "
        << fmt("%.2g", f.stribeck_velocity_std) << " rad/s";
    }
    s << "\n            cost " << fmt("%.6e", f.cost_given_Nm2) << " with the given shape, "
      << fmt("%.6e", f.cost_fitted_Nm2) << " fitted (least squares within the bounds)\n";
    if (f.held_out_given_Nm > 0.0) {
      s << "            held-out torque error " << fmt("%.4g", f.held_out_fitted_Nm)
        << " N m with the fitted shape, " << fmt("%.4g", f.held_out_given_Nm)
        << " N m with the given one (" << kSupportFolds << " time blocks): "
        << (f.supported ? "the log supports the fitted shape"
                        : "the given shape explains the log as well")
        << "\n";
    }
  }
  if (r.elasticity) text_elasticity(*r.elasticity, s);
  text_torque_lag(r, s);
  text_cogging(r, s);
  text_collision(r, s);
  s << "  time      " << fmt("%.3f", r.seconds_estimator) << " s estimator, "
    << fmt("%.3f", r.seconds_total) << " s in all\n\n";
}

// The cost, the conditioning and the bounds held.
void text_cost(const FitResult& r, std::ostream& s) {
  s << "\n  cost (mean squared torque error) " << fmt("%.6e", r.cost_Nm2) << " N^2 m^2";
  if (r.pso) {
    s << "\n  least-squares optimum            " << fmt("%.6e", r.ls_cost_Nm2)
      << " N^2 m^2 (pso/ls " << fmt("%.9f", r.ls_cost_Nm2 > 0 ? r.cost_Nm2 / r.ls_cost_Nm2 : 1.0)
      << ")";
  }
  s << "\n  condition number of regressor    " << fmt("%.3g", r.condition_number)
    << " (columns scaled to unit norm: " << fmt("%.3g", r.condition_number_scaled) << ")\n";
  if (!r.active_bounds.empty()) {
    s << "  bounds    held at 0 by its physical bound:";
    for (const auto& e : r.parameters) {
      if (e.at_bound)
        s << " " << e.info.name << " (unbounded " << fmt("%.3g", e.unconstrained_value) << ")";
    }
    s << "\n            the estimate is the optimum within the bounds; least squares and PSO solve "
         "the same bounded problem\n";
  }
}

// The two parameters the log tells apart worst: their correlation.
void text_strongest_correlation(const FitResult& r, std::ostream& s) {
  double strongest = 0;
  Eigen::Index a = -1, b = -1;
  for (Eigen::Index i = 0; i < r.correlation.rows(); ++i) {
    for (Eigen::Index k = i + 1; k < r.correlation.cols(); ++k) {
      const double c = r.correlation(i, k);
      if (std::isfinite(c) && std::abs(c) > std::abs(strongest)) {
        strongest = c;
        a = i;
        b = k;
      }
    }
  }
  if (a < 0) return;
  s << "  correlation  strongest between " << r.parameters[static_cast<std::size_t>(a)].info.name
    << " and " << r.parameters[static_cast<std::size_t>(b)].info.name << ": "
    << fmt("%+.3f", strongest) << " (all of them: --json, \"correlation\")\n";
}

}  // namespace

std::string text_report(const FitResult& r) {
  std::ostringstream s;
  text_samples(r, s);
  text_method(r, s);
  s << parameter_table(r);
  s << "  (std dev with model error: the larger of the estimate's spread over the log's motions "
       "and least squares' own, which allows for residuals correlated over "
    << r.std_dev_lags << " samples; docs/trust.md)\n";
  text_cost(r, s);
  text_strongest_correlation(r, s);
  for (const std::string& d : r.doubts) s << "  DOUBTFUL  " << d << "\n";
  s << "\n";
  std::vector<LogRmse> rows{r.fit};
  rows.insert(rows.end(), r.validation.begin(), r.validation.end());
  s << text_rmse_table(rows, "fit");
  return s.str();
}

namespace {

// Each parameter's estimate, and its details (bounds, uncertainty, truth).
void json_parameters(const FitResult& r, nlohmann::json& values, nlohmann::json& details) {
  using nlohmann::json;
  values = json::object();
  details = json::array();
  for (const auto& e : r.parameters) {
    values[e.info.name] = e.identifiable() ? json(e.value) : json(nullptr);
    details.push_back(
        {{"name", e.info.name},
         {"unit", e.info.unit},
         {"value", e.value},
         {"least_squares_value", e.ls_value},
         {"unconstrained_value", e.unconstrained_value},
         {"at_bound", e.at_bound},
         {"identifiable", e.identifiable()},
         {"base_combination",
          e.combination.empty() || !e.identifiable() ? json(nullptr) : json(e.combination)},
         {"std_dev", e.std_dev},
         {"ls_std_dev", e.ls_std_dev},
         {"rel_std_percent", e.rel_std_percent},
         {"lower_bound", e.lower},
         {"upper_bound", e.upper},
         {"meaning", e.info.meaning}});
    if (const auto t = r.truth.find(e.info.name); t != r.truth.end()) {
      details.back()["truth"] = t->second;
    }
  }
}

nlohmann::json json_elasticity(const FitResult& r) {
  if (!r.elasticity) return nullptr;
  const ElasticityResult& e = *r.elasticity;
  return {{"compliance_rad_per_Nm", e.compliance_rad_per_Nm},
          {"compliance_std_rad_per_Nm", e.compliance_std},
          {"from_arm_encoders", e.from_arm_encoders},
          {"cost_rigid_Nm2", e.cost_rigid_Nm2},
          {"cost_elastic_Nm2", e.cost_elastic_Nm2},
          {"held_out_rigid_Nm", e.held_out_rigid_Nm},
          {"held_out_elastic_Nm", e.held_out_elastic_Nm},
          {"supported", e.supported},
          {"evaluations", e.evaluations},
          {"seconds", e.seconds}};
}

// The collision detector's thresholds (collision_thresholds.hpp), null
// where the controller would not run the model as fitted.
nlohmann::json json_collision(const FitResult& r) {
  if (!r.collision) return nullptr;
  const delta::CollisionThresholds& t = r.collision->thresholds;
  return {{"base_Nm", t.base_Nm},
          {"per_speed_Nm_s_per_rad", t.per_speed_Nm_s_per_rad},
          {"per_acceleration_Nm_s2_per_rad", t.per_acceleration_Nm_s2_per_rad},
          {"peak_residual_Nm", r.collision->peak_residual_Nm},
          {"margin", kCollisionMargin},
          {"filter_ticks", kCollisionFilterTicks}};
}

nlohmann::json json_friction_shape(const FitResult& r) {
  if (!r.friction_shape) return nullptr;
  const FrictionShapeResult& f = *r.friction_shape;
  return {{"coulomb_smoothing_rad_s", f.coulomb_smoothing_rad_s},
          {"coulomb_smoothing_std_rad_s", f.coulomb_smoothing_std},
          {"stribeck_velocity_rad_s", f.stribeck_velocity_rad_s},
          {"stribeck_velocity_std_rad_s", f.stribeck_velocity_std},
          {"cost_given_Nm2", f.cost_given_Nm2},
          {"cost_fitted_Nm2", f.cost_fitted_Nm2},
          {"held_out_given_Nm", f.held_out_given_Nm},
          {"held_out_fitted_Nm", f.held_out_fitted_Nm},
          {"supported", f.supported},
          {"evaluations", f.evaluations},
          {"seconds", f.seconds}};
}

// The parameters' correlations: their names, and the matrix row by row
// (null where a parameter is not identifiable).
nlohmann::json json_correlation(const FitResult& r) {
  nlohmann::json names = nlohmann::json::array();
  for (const auto& e : r.parameters) names.push_back(e.info.name);
  nlohmann::json rows = nlohmann::json::array();
  for (Eigen::Index i = 0; i < r.correlation.rows(); ++i) {
    nlohmann::json row = nlohmann::json::array();
    for (Eigen::Index k = 0; k < r.correlation.cols(); ++k) {
      const double c = r.correlation(i, k);
      row.push_back(std::isfinite(c) ? nlohmann::json(c) : nlohmann::json(nullptr));
    }
    rows.push_back(std::move(row));
  }
  return {{"parameters", names}, {"matrix", rows}};
}

nlohmann::json json_pso(const FitResult& r) {
  if (!r.pso) return nullptr;
  const auto& o = r.options;
  const auto& p = *r.pso;
  return {{"particles", o.pso.particles},
          {"topology", topology_name(o.pso.topology)},
          {"seed", o.pso.seed},
          {"max_iterations", o.pso.iterations},
          {"iterations", p.iterations},
          {"evaluations", p.evaluations},
          {"restarts", p.restarts_done},
          {"stop_reason", p.stop_reason},
          {"particles_on_bound", p.particles_on_bound},
          {"bound_factor", o.bound_factor}};
}

}  // namespace

nlohmann::json json_model_selection(const ModelSelection& s) {
  nlohmann::json variants = nlohmann::json::array();
  for (const VariantScore& v : s.variants) {
    variants.push_back({{"variant", v.name},
                        {"per_joint", v.model.per_joint},
                        {"offsets", v.model.offsets},
                        {"load_friction", v.model.load_friction},
                        {"torque_gains", v.model.torque_gains},
                        {"parameters", v.parameters},
                        {"held_out_rmse_Nm", v.held_out_rmse_Nm}});
  }
  return {{"folds", s.folds},     {"criterion", "held-out torque RMSE over time blocks (k-fold)"},
          {"variants", variants}, {"chosen", s.variants[s.chosen].name},
          {"alike", s.alike},     {"reason", s.reason}};
}

namespace {

nlohmann::json json_model_options(const ModelOptions& m) {
  return {{"name", m.name},
          {"per_joint", m.per_joint},
          {"offsets", m.offsets},
          {"load_friction", m.load_friction},
          {"torque_gains", m.torque_gains},
          {"gearbox_compliance_rad_per_Nm", m.gearbox_compliance_rad_per_Nm},
          {"cogging_periods_per_rev", m.cogging_periods_per_rev},
          {"coulomb_smoothing_rad_s", m.coulomb_smoothing_rad_s},
          {"stribeck_velocity_rad_s", m.stribeck_velocity_rad_s}};
}

nlohmann::json json_cogging(const FitResult& r) {
  nlohmann::json out = nullptr;
  if (r.cogging) {
    out = {{"periods_per_rev", r.cogging->periods_per_rev},
           {"amplitude_Nm", r.cogging->amplitude_Nm},
           {"peak_ratio", r.cogging->peak_ratio}};
  }
  if (r.cogging_support) {
    if (out.is_null()) out = nlohmann::json::object();
    out["held_out_with_Nm"] = r.cogging_support->held_out_with_Nm;
    out["held_out_without_Nm"] = r.cogging_support->held_out_without_Nm;
    out["supported"] = r.cogging_support->supported;
  }
  return out;
}

nlohmann::json json_geometry(const delta::Geometry& g) {
  return {{"upper_arm_length_m", g.upper_arm_length_m},
          {"forearm_length_m", g.forearm_length_m},
          {"base_radius_m", g.base_radius_m},
          {"platform_radius_m", g.platform_radius_m}};
}

nlohmann::json json_preprocessing(const FitResult& r) {
  using nlohmann::json;
  const PrepareOptions& o = r.options.prepare;
  json gaps = json::array();
  for (const auto& g : r.gaps) gaps.push_back({{"line", g.line}, {"what", g.what}});
  return {{"cutoff_hz", o.cutoff_hz},
          {"state_cutoff_hz", o.state_cutoff_hz ? json(*o.state_cutoff_hz) : json("auto")},
          {"state_cutoff_hz_used", r.state_cutoff_hz},
          {"trim_samples", o.trim_samples},
          {"time_steps", o.time_steps == TimeSteps::kNominal    ? "nominal"
                         : o.time_steps == TimeSteps::kAsLogged ? "as-logged"
                                                                : "check"},
          {"min_speed_rad_s", r.min_speed_rad_s},
          {"equations_used", r.equations_used},
          {"derivatives", r.derivatives},
          {"samples_in_log", r.samples_in_log},
          {"segments_used", r.segments_used},
          {"segments_dropped", r.segments_dropped},
          {"gaps", gaps}};
}

nlohmann::json json_least_squares(const FitResult& r) {
  const auto& o = r.options;
  return {{"cost_Nm2", r.ls_cost_Nm2},
          {"solver", o.solver == LsSolver::kQr ? "qr" : "svd"},
          {"weights", o.weights == LsWeights::kJoint ? "joint" : "none"},
          {"joint_weights", r.joint_weights},
          {"condition_number", r.condition_number},
          {"std_dev_correlation_lags", r.std_dev_lags},
          {"condition_number_scaled", r.condition_number_scaled},
          {"active_bounds", r.active_bounds}};
}

}  // namespace

nlohmann::json json_report(const FitResult& r) {
  using nlohmann::json;
  json params, details;
  json_parameters(r, params, details);
  json fit = json_rmse(r.fit);
  fit["cost_Nm2"] = r.cost_Nm2;
  json validation = json::array();
  for (const auto& v : r.validation) validation.push_back(json_rmse(v));
  return {
      {"format", "host_id-result/1"},
      {"model", json_model_options(r.options.model)},
      {"method", r.options.method == Method::kPso ? "pso" : "ls"},
      {"doubts", r.doubts},
      {"model_support", r.support ? json_model_selection(*r.support) : json(nullptr)},
      {"correlation", json_correlation(r)},
      {"geometry", json_geometry(r.geometry)},
      {"preprocessing", json_preprocessing(r)},
      {"parameters", params},
      {"parameter_details", details},
      {"fit", fit},
      {"least_squares", json_least_squares(r)},
      {"validation", validation},
      {"seconds", {{"estimator", r.seconds_estimator}, {"total", r.seconds_total}}},
      {"friction_shape", json_friction_shape(r)},
      {"elasticity", json_elasticity(r)},
      {"cogging", json_cogging(r)},
      {"collision_thresholds", json_collision(r)},
      {"torque_lag", r.torque_lag ? nlohmann::json{{"lag_s", r.torque_lag->lag_s},
                                                   {"error_drop", r.torque_lag->error_drop}}
                                  : nlohmann::json(nullptr)},
      {"pso", json_pso(r)},
  };
}

}  // namespace host_id
