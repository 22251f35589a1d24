// host_id fit LOG.csv: estimate the parameters, validate, report, save, plot.
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <sstream>

#include "commands/command.hpp"
#include "commands/progress.hpp"
#include "delta/atomic_file.hpp"
#include "delta/read_file.hpp"
#include "host_id/delta_log.hpp"
#include "host_id/fit_auto.hpp"
#include "host_id/geometry_check.hpp"
#include "host_id/identify.hpp"
#include "host_id/joint_signs.hpp"
#include "host_id/model_support.hpp"
#include "host_id/payload.hpp"
#include "host_id/report.hpp"
#include "host_id/svg_plot.hpp"
#include "host_id/truth.hpp"

namespace host_id {

namespace {

std::vector<const DeltaLog*> pointers(const std::vector<DeltaLog>& logs) {
  std::vector<const DeltaLog*> out;
  for (const DeltaLog& l : logs) out.push_back(&l);
  return out;
}

// What the command line gives, before it becomes FitOptions.
struct FitArguments {
  std::string log;
  FitOptions fit;
  std::string method{"pso"};
  std::string topology{"gbest"};
  std::string solver{"qr"};
  std::string weights{"none"};
  std::size_t trim{0};
  double min_speed_rad_s{0};
  std::vector<std::string> models{"auto"};  // the first is the primary model
  std::vector<std::string> validate;
  std::string out_path;
  std::string plot_path;
  std::string truth_path;
  bool json{false};
  bool quiet{false};
  bool allow_other_geometry{false};
  std::string time_steps{"check"};
  std::string state_cutoff{"auto"};
  std::optional<ModelSelection> selection;           // with --model auto
  std::string base_path;                             // --base: a payload on this fit
  std::string calibrate_path;                        // --calibrate-torque: the loaded log
  double payload_mass_kg{0};                         // --payload-mass, with --calibrate-torque
  std::vector<double> gearbox_stiffness_Nm_per_rad;  // --gearbox-stiffness: 1 or 3 values
  std::vector<double> cogging_periods;               // --cogging-periods: 1 or 3 values
  CLI::Option* model_given{nullptr};
  CLI::Option* trim_given{nullptr};
  CLI::Option* min_speed_given{nullptr};
};

std::vector<std::string> model_names_and_auto() {
  std::vector<std::string> names = model_names();
  names.emplace_back("auto");
  return names;
}

// The gearboxes' stiffness: searched (--elastic) or given (--gearbox-stiffness).
void add_gearbox_options(CLI::App& c, FitArguments& a) {
  c.add_flag("--elastic", a.fit.fit_elasticity,
             "delta, lumped: search each joint's gearbox stiffness (encoders on the motor) by "
             "PSO, the other parameters solved exactly for each candidate, and take it where the "
             "held-out error says so; where the log has qa1..qa3 (arm-side encoders), those "
             "(docs/model.md, 'Elastic gearboxes')")
      ->group("model");
  c.add_option("--gearbox-stiffness", a.gearbox_stiffness_Nm_per_rad,
               "delta, lumped: the gearboxes' torsional stiffness in N m/rad at the joint, from "
               "their datasheets (one for all joints, or K1,K2,K3): the model is fitted at the "
               "arms' angles and carries it, and the controller compensates the deflection "
               "(docs/model.md, 'Elastic gearboxes')")
      ->delimiter(',')
      ->expected(1, 3)
      ->check(CLI::PositiveNumber)
      ->excludes("--elastic")
      ->group("model");
  c.add_option("--cogging-periods", a.cogging_periods,
               "delta, lumped: a cogging term per joint, a sin(n q) + b cos(n q), with n its "
               "periods per joint revolution (the motor's cogging periods per revolution times "
               "the gear ratio; one for all joints, or N1,N2,N3; 0: none at that joint). "
               "--model auto finds n in the residual itself (docs/model.md, 'Cogging')")
      ->delimiter(',')
      ->expected(1, 3)
      ->check(CLI::Range(0.0, kMaxCoggingPeriodsPerRev))
      ->group("model");
}

void add_model_options(CLI::App& c, FitArguments& a) {
  a.model_given =
      c.add_option("--model", a.models,
                   "delta: the higher-fidelity model (arm centre of mass off its line, inertial "
                   "and weight platform masses, forearm coupling); lumped: point masses at elbow "
                   "and platform; both with lambda solved per sample; paper14: the paper's 14 "
                   "coefficients; auto (the default; delta where --per-joint or --offsets is "
                   "given): the delta model with shared or per-joint arms, with or without "
                   "torque offsets, as held-out error on time blocks of the log decides "
                   "(docs/model-selection.md, 'Choosing the model'). Given more than once, each "
                   "model is fitted and Table 2 covers them all; the first is the one --out and "
                   "--plot save")
          ->check(CLI::IsMember(model_names_and_auto()))
          ->capture_default_str()
          ->group("model");
  c.add_flag("--per-joint", a.fit.model.per_joint,
             "delta, lumped: arm inertia and gravity moments per joint")
      ->group("model");
  c.add_flag("--offsets", a.fit.model.offsets, "delta, lumped: a torque offset per joint")
      ->group("model");
  c.add_flag("--load-friction", a.fit.model.load_friction,
             "delta, lumped: gear friction that grows with the torque the gear carries, "
             "mu |tau| tanh(qd/W), one coefficient per joint (docs/model.md, 'The drive train')")
      ->group("model");
  c.add_flag("--torque-gains", a.fit.model.torque_gains,
             "delta, lumped: joints 2 and 3's torque constants relative to joint 1's, for "
             "motors whose constants differ (docs/model.md, 'The drive train')")
      ->group("model");
  c.add_option("--coulomb-smoothing", a.fit.model.coulomb_smoothing_rad_s,
               "Coulomb sign smoothed as tanh(qd/W), rad/s")
      ->check(kPositive)
      ->capture_default_str()
      ->group("model");
  add_gearbox_options(c, a);
  c.add_flag("--fit-friction-shape", a.fit.fit_friction_shape,
             "search the Coulomb smoothing (and, with --stribeck-velocity, the Stribeck "
             "velocity) by PSO, the other parameters solved exactly for each candidate; the "
             "report gives the cost with the given shape beside the fitted one")
      ->group("model");
  c.add_option("--stribeck-velocity", a.fit.model.stribeck_velocity_rad_s,
               "delta, lumped: add a Stribeck term per joint, exp(-(qd/V)^2) tanh(qd/W), with "
               "this velocity in rad/s (0: none)")
      ->check(kNonNegative)
      ->capture_default_str()
      ->group("model");
}

void add_estimator_options(CLI::App& c, FitArguments& a) {
  const char* g = "estimator";
  PsoOptions& p = a.fit.pso;
  c.add_option("--method", a.method, "particle swarm or least squares")
      ->check(CLI::IsMember({"pso", "ls"}))
      ->capture_default_str()
      ->group(g);
  c.add_option("--particles", p.particles, "swarm size")
      ->check(CLI::Range(2, 100000))
      ->capture_default_str()
      ->group(g);
  c.add_option("--iterations", p.iterations, "maximum iterations (as in the paper)")
      ->check(CLI::Range(1, 100000000))
      ->capture_default_str()
      ->group(g);
  c.add_option("--topology", a.topology, "swarm topology")
      ->check(CLI::IsMember({"gbest", "ring"}))
      ->capture_default_str()
      ->group(g);
  c.add_option("--seed", p.seed, "random seed; same seed, same result")
      ->capture_default_str()
      ->group(g);
  c.add_option("--stall-iterations", p.stall_iterations,
               "stop or restart after N iterations without improvement")
      ->check(CLI::Range(1, 100000000))
      ->capture_default_str()
      ->group(g);
  c.add_option("--restarts", p.restarts,
               "restarts on stall before stopping (the cost is convex: none by default)")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str()
      ->group(g);
  c.add_option("--bound-factor", a.fit.bound_factor, "PSO box: |beta_j| <= K rms(tau)/rms(Psi_j)")
      ->check(kPositive)
      ->capture_default_str()
      ->group(g);
  c.add_option("--solver", a.solver, "least-squares solver")
      ->check(CLI::IsMember({"qr", "svd"}))
      ->capture_default_str()
      ->group(g);
  c.add_option("--weights", a.weights, "ordinary, or weighted by each joint's residual variance")
      ->check(CLI::IsMember({"none", "joint"}))
      ->capture_default_str()
      ->group(g);
  c.add_option("--threads", a.fit.threads,
               "threads for building the regressor and for least squares (0: all cores)")
      ->check(CLI::Range(0, 256))
      ->capture_default_str()
      ->group(g);
}

void add_sample_options(CLI::App& c, FitArguments& a) {
  c.add_option("--cutoff-hz", a.fit.prepare.cutoff_hz,
               "low-pass cut-off for tau and the regressor (parallel filtering) when the log has "
               "no qd/qdd columns")
      ->check(kPositive)
      ->capture_default_str()
      ->group("samples");
  c.add_option("--state-cutoff-hz", a.state_cutoff,
               "low-pass cut-off for q before it is differentiated: 'auto' chooses it from each "
               "log's own spectrum and noise floor, or a number in Hz")
      ->check(CLI::IsMember({"auto"}) | kPositive)
      ->capture_default_str()
      ->group("samples");
  a.trim_given = c.add_option("--trim", a.trim,
                              "samples dropped at each segment end (default: "
                              "auto)")
                     ->check(CLI::Range(0, 1000000))
                     ->group("samples");
  add_time_steps_option(c, a.time_steps)->capture_default_str()->group("samples");
  a.min_speed_given =
      c.add_option("--min-speed", a.min_speed_rad_s,
                   "leave out a joint's equation where its |qd| < W rad/s (delta: 0.05, paper14: "
                   "0 = every sample)")
          ->check(kNonNegative)
          ->group("samples");
}

void add_output_options(CLI::App& c, FitArguments& a) {
  c.add_option("--validate", a.validate, "torque RMSE on another log (repeatable)")
      ->allow_extra_args(false)
      ->group("output");
  c.add_option("-o,--out", a.out_path, "save the result as JSON (atomically)")
      ->check(kOutputPath)
      ->group("output");
  c.add_flag("--json", a.json, "print the whole report as JSON instead of text")->group("output");
  c.add_option("--truth", a.truth_path,
               "a robot description (docs/robot-description.md): print each parameter's truth "
               "and error beside it")
      ->group("output");
  c.add_option("--plot", a.plot_path, "measured vs predicted torque and the residuals")
      ->check(kSvgPath)
      ->check(kOutputPath)
      ->group("output");
  c.add_flag("--quiet", a.quiet, "no progress bar")->group("output");
  c.add_option("--base", a.base_path,
               "RESULT.json of the robot without the payload: estimate only the payload's mass "
               "on LOG.csv, everything else held (docs/payload.md, 'A payload'); --out "
               "then saves the base result with the payload added to the platform")
      ->check(CLI::ExistingFile)
      ->group("output");
  c.add_option("--calibrate-torque", a.calibrate_path,
               "LOADED.csv: the same robot with a payload of known mass (--payload-mass): each "
               "joint's torque scale (logged torque per true torque: motor constant x gear x "
               "efficiency as configured against the truth), from LOG.csv (without the payload) "
               "and this log together (docs/payload.md, 'A payload')")
      ->check(CLI::ExistingFile)
      ->group("output");
  c.add_option("--payload-mass", a.payload_mass_kg, "kg: the payload of --calibrate-torque")
      ->check(kPositive)
      ->group("output");
  c.add_flag("--allow-other-geometry", a.allow_other_geometry,
             "go on (with a warning) where a --validate log or the --truth robot has another "
             "geometry than the fitted log")
      ->group("output");
}

// --gearbox-stiffness as compliances 1/K (all 0 without it).
delta::Joint3 given_compliance(const FitArguments& a) {
  const std::vector<double>& k = a.gearbox_stiffness_Nm_per_rad;
  if (k.empty()) return {};
  if (k.size() == 2) {
    throw UsageError("--gearbox-stiffness: give one stiffness for all joints or three, K1,K2,K3");
  }
  for (const double stiffness : k) {
    if (!(stiffness > 64.0)) {
      throw UsageError("--gearbox-stiffness: " + std::to_string(stiffness) +
                       " N m/rad is softer than the controller runs (above 64 N m/rad; gearboxes "
                       "are thousands): give the joint's stiffness in N m/rad");
    }
  }
  return k.size() == 1 ? delta::Joint3{1 / k[0], 1 / k[0], 1 / k[0]}
                       : delta::Joint3{1 / k[0], 1 / k[1], 1 / k[2]};
}

// The options the strings and the optional values stand for.
FitOptions fit_options(const FitArguments& a) {
  FitOptions f = a.fit;
  f.model.name = a.models.front();
  f.method = a.method == "pso" ? Method::kPso : Method::kLeastSquares;
  f.pso.topology = a.topology == "gbest" ? PsoTopology::kGlobal : PsoTopology::kRing;
  f.solver = a.solver == "qr" ? LsSolver::kQr : LsSolver::kSvd;
  f.weights = a.weights == "none" ? LsWeights::kNone : LsWeights::kJoint;
  f.prepare.trim_samples = a.trim_given->count() ? static_cast<long>(a.trim) : -1;
  f.prepare.time_steps = time_steps_named(a.time_steps);
  if (a.state_cutoff != "auto") f.prepare.state_cutoff_hz = std::stod(a.state_cutoff);
  if (a.min_speed_given->count()) f.min_speed_rad_s = a.min_speed_rad_s;
  f.model.gearbox_compliance_rad_per_Nm = given_compliance(a);
  const std::vector<double>& n = a.cogging_periods;
  f.search_cogging = n.empty();
  if (n.size() == 2) {
    throw UsageError("--cogging-periods: give one n for all joints or three, N1,N2,N3");
  }
  if (!n.empty()) {
    f.model.cogging_periods_per_rev =
        n.size() == 1 ? delta::Joint3{n[0], n[0], n[0]} : delta::Joint3{n[0], n[1], n[2]};
  }
  return f;
}

// The options of a further model of a multi-model run: the primary's, with
// those that apply to delta and lumped only left out of paper14 (its
// report's model line says what it was fitted with).
FitOptions options_for_model(FitOptions f, const std::string& name) {
  f.model.name = name;
  if (name == "paper14") {
    f.model.per_joint = false;
    f.model.offsets = false;
    f.model.load_friction = false;
    f.model.torque_gains = false;
    f.model.gearbox_compliance_rad_per_Nm = {};
    f.model.cogging_periods_per_rev = {};
    f.fit_elasticity = false;
    f.model.stribeck_velocity_rad_s = 0.0;
    f.fit_friction_shape = false;
  }
  return f;
}

std::string text_selection(const ModelSelection& s) {
  std::ostringstream t;
  t << "host_id fit: --model auto: held-out torque RMSE over " << s.folds
    << " time blocks of the log (each fitted on the others)\n";
  for (std::size_t i = 0; i < s.variants.size(); ++i) {
    const VariantScore& v = s.variants[i];
    char line[160];
    std::snprintf(line, sizeof line, "  %-32s %2zu parameters  %.6f N m%s\n", v.name.c_str(),
                  v.parameters, v.held_out_rmse_Nm, i == s.chosen ? "  <- chosen" : "");
    t << line;
  }
  t << "  chosen    " << s.reason << "\n\n";
  return t.str();
}

// The first result is the primary model's: --out and --plot save it, and
// the JSON is its report, with the others under "other_models". --model
// auto's choice is in its "model_support", as every fit's judgement is.
void write_outputs(const FitArguments& a, const std::vector<FitResult>& results,
                   std::ostream& out) {
  const FitResult& r = results.front();
  nlohmann::json j = json_report(r);
  if (results.size() > 1) {
    j["other_models"] = nlohmann::json::array();
    for (std::size_t i = 1; i < results.size(); ++i) {
      j["other_models"].push_back(json_report(results[i]));
    }
  }
  {
    // Both or neither, even when interrupted.
    const std::string json_text = a.out_path.empty() ? "" : j.dump(2) + "\n";
    const std::string plot_text =
        a.plot_path.empty()
            ? ""
            : svg_torque_plot(r.predictions, "host_id fit, model " + r.options.model.name);
    delta::write_files_atomically({{&a.out_path, json_text}, {&a.plot_path, plot_text}});
  }
  if (a.json) {
    out << j.dump(2) << "\n";
    return;
  }
  if (a.selection) out << text_selection(*a.selection);
  for (std::size_t i = 0; i < results.size(); ++i) {
    if (i > 0) out << "\n";
    out << text_report(results[i]);
  }
  if (results.size() > 1) out << "\n" << text_table2(results);
  if (!a.out_path.empty()) out << "  saved     " << a.out_path << "\n";
  if (!a.plot_path.empty()) out << "  plot      " << a.plot_path << "\n";
}

// fit LOADED.csv --base RESULT.json: the payload's mass alone.
int run_payload(const FitArguments& a, std::ostream& out, std::ostream& err) {
  const SavedResult saved = read_saved_result(a.base_path);
  const auto model = make_model(saved.model);
  const DeltaLog log = read_delta_log(a.log);
  check_result_geometry(a.log, log.geometry, a.base_path, saved.geometry, a.allow_other_geometry,
                        err);
  FitOptions f = fit_options(a);
  f.model = saved.model;
  warn_about_log(err, log, saved.prepare.time_steps);
  const PayloadResult p =
      fit_payload(*model, saved.beta, log, saved.prepare, min_speed_for(f), f.threads);
  nlohmann::json payload{{"base", a.base_path},
                         {"log", a.log},
                         {"payload_mass_kg", p.mass_kg},
                         {"payload_mass_std_kg", p.std_dev_kg},
                         {"payload_mass_ls_std_kg", p.ls_std_dev_kg},
                         {"equations", p.equations},
                         {"rmse_base_Nm", p.rmse_base_Nm},
                         {"rmse_with_payload_Nm", p.rmse_payload_Nm}};
  if (!a.out_path.empty()) {
    nlohmann::json result = nlohmann::json::parse(delta::read_whole_file(a.base_path));
    const Eigen::VectorXd loaded = with_payload(*model, saved.beta, p.mass_kg);
    for (std::size_t c = 0; c < model->size(); ++c) {
      const std::string& name = model->parameters()[c].name;
      if (result["parameters"].contains(name) && !result["parameters"][name].is_null()) {
        result["parameters"][name] = loaded(static_cast<Eigen::Index>(c));
      }
    }
    result["payload"] = payload;
    delta::write_file_atomically(a.out_path, result.dump(2) + "\n");
  }
  if (a.json) {
    out << payload.dump(2) << "\n";
    return 0;
  }
  char line[200];
  out << "host_id fit: " << a.log << ", a payload on " << a.base_path << " (model "
      << saved.model.name << ", every other parameter held)\n";
  out << "            " << p.derivatives << "; " << p.equations << " equations\n";
  std::snprintf(line, sizeof line,
                "  payload_mass   %.6g kg, std dev %.3g kg (%.3g %%; with model error, "
                "docs/trust.md)\n",
                p.mass_kg, p.std_dev_kg,
                p.mass_kg != 0 ? 100.0 * p.std_dev_kg / std::abs(p.mass_kg) : 0.0);
  out << line;
  std::snprintf(line, sizeof line,
                "  torque RMSE [N m]   base model %.5f %.5f %.5f, with the payload %.5f %.5f "
                "%.5f\n",
                p.rmse_base_Nm[0], p.rmse_base_Nm[1], p.rmse_base_Nm[2], p.rmse_payload_Nm[0],
                p.rmse_payload_Nm[1], p.rmse_payload_Nm[2]);
  out << line;
  if (!a.out_path.empty()) out << "  saved     " << a.out_path << " (the base with the payload)\n";
  return 0;
}

// The calibration's JSON: the scales, their standard deviations and the
// robot's parameters in true units.
nlohmann::json calibration_json(const FitArguments& a, const Model& model,
                                const TorqueScaleResult& s) {
  nlohmann::json params = nlohmann::json::object();
  for (std::size_t c = 0; c < model.size(); ++c) {
    params[model.parameters()[c].name] = s.beta(static_cast<Eigen::Index>(c));
  }
  return {{"unloaded", a.log},
          {"loaded", a.calibrate_path},
          {"payload_mass_kg", a.payload_mass_kg},
          {"model", model.options().name},
          {"model_terms", "per-joint arms, load friction"},
          {"cogging_periods_per_rev", model.options().cogging_periods_per_rev},
          {"torque_scale", s.scale},
          {"torque_scale_std", s.scale_std},
          {"torque_scale_ls_std", s.scale_ls_std},
          {"parameters_true_units", params},
          {"equations", s.equations},
          {"rmse_Nm", s.rmse_Nm}};
}

// The calibration's report: each joint's scale and what to do with it.
void print_calibration(const FitArguments& a, const Model& model, const TorqueScaleResult& s,
                       std::ostream& out) {
  char line[200];
  out << "host_id fit: torque scale from " << a.log << " (no payload) and " << a.calibrate_path
      << " (" << a.payload_mass_kg << " kg), model " << model.options().name << "; " << s.equations
      << " equations\n";
  out << "  joint  logged torque per true torque   what to do\n";
  for (unsigned k = 0; k < 3; ++k) {
    std::snprintf(line, sizeof line,
                  "  %u      %.4f, std dev %.2g (%.2g %%)      divide joint%u's torque scale "
                  "(gear_ratio x rated_torque / rated_current x gearbox_efficiency) by %.4f\n",
                  k + 1, s.scale[k], s.scale_std[k], 100.0 * s.scale_std[k] / s.scale[k], k + 1,
                  s.scale[k]);
    out << line;
  }
  out << "  std dev   with model error: the scales' spread over the logs' motions, at least the "
         "noise's (docs/trust.md)\n";
  if (model.options().cogging()) {
    const delta::Joint3& n = model.options().cogging_periods_per_rev;
    std::snprintf(line, sizeof line,
                  "  cogging   %.5g, %.5g, %.5g periods per revolution (0: none), taken in%s\n",
                  n[0], n[1], n[2],
                  a.cogging_periods.empty() ? " (found in the unloaded log's residual)" : "");
    out << line;
  }
  std::snprintf(line, sizeof line, "  torque RMSE [N m, true units] %.5f %.5f %.5f\n", s.rmse_Nm[0],
                s.rmse_Nm[1], s.rmse_Nm[2]);
  out << line;
  if (!a.out_path.empty()) out << "  saved     " << a.out_path << "\n";
}

// Cogging in the residual of the calibration's model fitted to the
// unloaded log, where the fit with its terms lowers the held-out error as
// --model auto asks (zeros: none), for the calibration to take in: its
// share of a joint's torque is largest where the payload's is small.
delta::Joint3 cogging_in(const DeltaLog& unloaded, FitOptions f) {
  f.method = Method::kLeastSquares;
  f.fit_elasticity = false;
  f.fit_friction_shape = false;
  const FitResult r = fit_log(unloaded, f, {}, false);
  if (!r.cogging || !r.cogging->found()) return {};
  f.model.cogging_periods_per_rev = r.cogging->periods_per_rev;
  const FitResult with = fit_log(unloaded, f, {}, false);
  const bool supported = with.cogging_support && with.cogging_support->supported;
  return supported ? r.cogging->periods_per_rev : delta::Joint3{};
}

// fit LOG.csv --calibrate-torque LOADED.csv --payload-mass KG: each joint's
// torque scale, and the robot's parameters in true units.
int run_calibration(const FitArguments& a, std::ostream& out, std::ostream& err) {
  if (!(a.payload_mass_kg > 0.0)) {
    throw UsageError("--calibrate-torque needs --payload-mass KG, the payload's known mass");
  }
  if (a.fit.model.torque_gains) {
    throw UsageError(
        "--calibrate-torque finds each joint's torque scale itself; leave out --torque-gains");
  }
  FitOptions f = fit_options(a);
  // Arms are never made alike, and gear friction grows with load: left out,
  // each biases the scales (on our drive-train robot, 3 % arm scatter by
  // +-1.5 %, 5 % load friction by up to 1.2 %).
  f.model.per_joint = true;
  f.model.load_friction = true;
  const DeltaLog unloaded = read_delta_log(a.log);
  const DeltaLog loaded = read_delta_log(a.calibrate_path);
  if (f.search_cogging) f.model.cogging_periods_per_rev = cogging_in(unloaded, f);
  const auto model = make_model(f.model);
  check_geometry(a.calibrate_path, loaded.geometry, a.log + " has", unloaded.geometry,
                 a.allow_other_geometry, err);
  warn_about_log(err, unloaded, f.prepare.time_steps);
  warn_about_log(err, loaded, f.prepare.time_steps);
  const TorqueScaleResult s = fit_torque_scale(*model, unloaded, loaded, a.payload_mass_kg,
                                               f.prepare, min_speed_for(f), f.threads);
  const nlohmann::json j = calibration_json(a, *model, s);
  if (!a.out_path.empty()) delta::write_file_atomically(a.out_path, j.dump(2) + "\n");
  if (a.json) {
    out << j.dump(2) << "\n";
    return 0;
  }
  print_calibration(a, *model, s, out);
  return 0;
}

// --model auto unless told: --per-joint, --offsets, a payload or a torque
// calibration name their model, delta.
void name_the_model_where_implied(FitArguments& a) {
  if (a.model_given->count() == 0 &&
      (a.fit.model.per_joint || a.fit.model.offsets || a.fit.model.load_friction ||
       a.fit.model.torque_gains || !a.calibrate_path.empty() || !a.base_path.empty())) {
    a.models = {"delta"};
  }
}

void check_calibration_arguments(const FitArguments& a) {
  if (a.models.size() > 1 || a.models.front() == "auto" || !a.validate.empty() ||
      !a.plot_path.empty() || !a.truth_path.empty() || !a.base_path.empty()) {
    throw UsageError(
        "--calibrate-torque: one model (delta or lumped); not with --validate, --plot, "
        "--truth or --base");
  }
}

void check_payload_arguments(const FitArguments& a) {
  if (a.models.size() > 1 || a.models.front() != "delta" || !a.validate.empty() ||
      !a.plot_path.empty() || !a.truth_path.empty()) {
    throw UsageError(
        "--base: the model is the base fit's; not with --model, --validate, "
        "--plot or --truth");
  }
}

// Whether --model auto was asked for (alone, and deciding --per-joint and
// --offsets itself); its first fit is of the delta model's shared arms.
bool take_model_auto(FitArguments& a) {
  const bool automatic = a.models.front() == "auto";
  if (automatic && a.models.size() > 1) {
    throw UsageError("--model auto: not with other --model values");
  }
  if (automatic && (a.fit.model.per_joint || a.fit.model.offsets || a.fit.model.load_friction ||
                    a.fit.model.torque_gains)) {
    throw UsageError(
        "--model auto decides --per-joint, --offsets, --torque-gains and --load-friction itself");
  }
  if (automatic) a.models.front() = "delta";
  return automatic;
}

// What a fit reads before doing any work, so a bad validation log fails
// fast: the log, the validation logs and the --truth robot, their
// geometries checked and their warnings printed.
struct FitInputs {
  DeltaLog log;
  std::vector<DeltaLog> validation_logs;
  std::optional<delta::RobotDescription> robot;
};

FitInputs read_fit_inputs(const FitArguments& a, const FitOptions& f, std::ostream& err) {
  FitInputs in;
  in.log = read_delta_log(a.log);
  for (const auto& v : a.validate) in.validation_logs.push_back(read_delta_log(v));
  warn_about_log(err, in.log, f.prepare.time_steps);
  for (const DeltaLog& l : in.validation_logs) warn_about_log(err, l, f.prepare.time_steps);
  if (!a.truth_path.empty()) in.robot = delta::read_robot_description(a.truth_path);
  for (std::size_t i = 0; i < in.validation_logs.size(); ++i) {
    check_geometry(a.validate[i], in.validation_logs[i].geometry, "the fitted " + a.log,
                   in.log.geometry, a.allow_other_geometry, err);
  }
  if (in.robot) {
    check_geometry(a.log, in.log.geometry, "the robot of --truth " + a.truth_path,
                   in.robot->geometry, a.allow_other_geometry, err);
  }
  return in;
}

// --model auto (fit_auto.hpp): further fits read the file again.
std::vector<FitResult> fit_chosen_variant(FitArguments& a, const FitOptions& f, FitInputs& in,
                                          std::ostream& err) {
  AutoFit fit = fit_auto(
      std::move(in.log), [&a] { return read_delta_log(a.log); }, f, pointers(in.validation_logs),
      !a.plot_path.empty());
  a.selection = fit.selection;
  if (!a.selection) {
    err << a.log << ": warning: --model auto: " << fit.result.fit.samples
        << " samples are too few to judge the model's variants on " << kSupportFolds
        << " time blocks (at least " << 20 * kSupportFolds << "); the shared arms are fitted\n";
  }
  if (in.robot) fit.result.truth = parameter_truth(fit.result.options.model, *in.robot);
  return {std::move(fit.result)};
}

// Each --model given, fitted on the same log; the first is plotted.
std::vector<FitResult> fit_each_model(const FitArguments& a, const FitOptions& f, FitInputs& in) {
  std::vector<FitResult> results;
  for (std::size_t i = 0; i < a.models.size(); ++i) {
    const FitOptions fi = i == 0 ? f : options_for_model(f, a.models[i]);
    const bool last = i + 1 == a.models.size();
    // The last fit takes the log itself (a long log's memory); the others a copy.
    results.push_back(fit_log(last ? std::move(in.log) : in.log, fi, pointers(in.validation_logs),
                              i == 0 && !a.plot_path.empty()));
    if (in.robot) results.back().truth = parameter_truth(fi.model, *in.robot);
  }
  return results;
}

// A log with one joint's angle or torque inverted (joint_signs.hpp) is
// refused, naming it: no fit of it means anything. Read again: the fits
// took the log.
void refuse_inverted_joint(const FitArguments& a, const FitOptions& f) {
  const std::optional<InvertedJoint> inverted = inverted_joint(read_delta_log(a.log), f);
  if (inverted) throw delta::InputError(inverted_joint_message(*inverted, a.log));
}

// A doubtful result is written, and said so on stderr as well as in it.
void warn_about_doubts(const FitArguments& a, const std::vector<FitResult>& results,
                       std::ostream& err) {
  for (const FitResult& r : results) {
    for (const std::string& d : r.doubts) {
      err << a.log << ": warning: the " << r.options.model.name << " fit is doubtful: " << d
          << "\n";
    }
  }
}

int run_fit(FitArguments& a, std::ostream& out, std::ostream& err) {
  std::vector<std::string> inputs{a.log, a.calibrate_path, a.base_path, a.truth_path};
  inputs.insert(inputs.end(), a.validate.begin(), a.validate.end());
  refuse_writing_over_input(a.out_path, "-o", inputs);
  refuse_writing_over_input(a.plot_path, "--plot", inputs);
  name_the_model_where_implied(a);
  if (!a.calibrate_path.empty()) {
    check_calibration_arguments(a);
    return run_calibration(a, out, err);
  }
  if (a.payload_mass_kg > 0.0) {
    throw UsageError("--payload-mass goes with --calibrate-torque LOADED.csv");
  }
  if (!a.base_path.empty()) {
    check_payload_arguments(a);
    return run_payload(a, out, err);
  }
  const bool automatic = take_model_auto(a);
  FitOptions f = fit_options(a);
  ProgressBar bar("pso", a.quiet || f.method != Method::kPso);
  f.pso.progress = [&bar](std::size_t it, std::size_t max, double c) {
    char cost[48];
    std::snprintf(cost, sizeof cost, "cost %.6e", c);
    bar.show(it, max, cost);
  };
  f.pso.progress_every = 200;
  FitInputs in = read_fit_inputs(a, f, err);
  std::vector<FitResult> results;
  try {
    results = automatic ? fit_chosen_variant(a, f, in, err) : fit_each_model(a, f, in);
  } catch (const delta::InputError&) {
    bar.finish();
    refuse_inverted_joint(a, f);  // the likelier cause of a fit that failed
    throw;
  }
  bar.finish();
  if (std::any_of(results.begin(), results.end(), suspect_inverted_joint)) {
    refuse_inverted_joint(a, f);
  }
  for (const LogRmse& v : results.front().validation) {
    warn_beyond(err, v.log, a.log, results.front().fit.ranges, v.ranges);
  }
  warn_about_doubts(a, results, err);
  write_outputs(a, results, out);
  return 0;
}

}  // namespace

void add_fit_command(CLI::App& command, CommandContext& context) {
  CLI::App* c = &command;
  c->description(
      "Estimates the dynamic parameters from LOG.csv and prints a report "
      "(docs/identification.md).");
  auto a = std::make_shared<FitArguments>();
  c->add_option("log", a->log, "the delta-log/1 file to fit")->required();
  add_model_options(*c, *a);
  add_estimator_options(*c, *a);
  add_sample_options(*c, *a);
  add_output_options(*c, *a);
  c->callback([a, &context] { context.exit_code = run_fit(*a, context.out, context.err); });
}

}  // namespace host_id
