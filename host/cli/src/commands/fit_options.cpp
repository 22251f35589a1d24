// host_id fit's options (fit_arguments.hpp).
#include <string>
#include <vector>

#include "commands/command.hpp"
#include "commands/fit_arguments.hpp"
#include "host_id/model.hpp"

namespace host_id::fit_cli {

namespace {

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
               "threads for the fit's passes over the log and its analyses (0: all cores)")
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

}  // namespace

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

void add_fit_options(CLI::App& c, FitArguments& a) {
  add_model_options(c, a);
  add_estimator_options(c, a);
  add_sample_options(c, a);
  add_output_options(c, a);
}

}  // namespace host_id::fit_cli
