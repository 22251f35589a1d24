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
#include "commands/fit_arguments.hpp"
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

using fit_cli::FitArguments;

namespace {

std::vector<const DeltaLog*> pointers(const std::vector<DeltaLog>& logs) {
  std::vector<const DeltaLog*> out;
  for (const DeltaLog& l : logs) out.push_back(&l);
  return out;
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
  add_fit_options(*c, *a);
  c->callback([a, &context] { context.exit_code = run_fit(*a, context.out, context.err); });
}

}  // namespace host_id
