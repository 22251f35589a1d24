// host_id predict RESULT.json LOG.csv -o PRED.csv [--json]: the fitted
// model's torque at every sample of a log.
#include "host_id/predict.hpp"

#include <memory>
#include <nlohmann/json.hpp>
#include <ostream>

#include "commands/command.hpp"
#include "delta/atomic_file.hpp"
#include "host_id/delta_log.hpp"
#include "host_id/geometry_check.hpp"
#include "host_id/report.hpp"

namespace host_id {

namespace {

struct PredictArguments {
  std::string result_path;
  std::string log_path;
  std::string out_path;
  bool json{false};
  bool allow_other_geometry{false};
  std::string time_steps;  // "": as the result was fitted
};

int run_predict(const PredictArguments& a, std::ostream& out, std::ostream& err) {
  refuse_writing_over_input(a.out_path, "-o", {a.log_path, a.result_path});
  SavedResult saved = read_saved_result(a.result_path);
  if (!a.time_steps.empty()) saved.prepare.time_steps = time_steps_named(a.time_steps);
  const auto model = make_model(saved.model);
  const DeltaLog log = read_delta_log(a.log_path);
  check_result_geometry(a.log_path, log.geometry, a.result_path, saved.geometry,
                        a.allow_other_geometry, err);
  warn_about_log(err, log, saved.prepare.time_steps);
  const PredictedLog p = predict_log(*model, saved.beta, log, saved.prepare, a.result_path);
  warn_beyond(err, a.log_path, a.result_path, saved.excitation, p.report.ranges);
  write_delta_log_atomically(a.out_path, p.log);
  const std::size_t left_out = log.size() - p.log.size();
  if (a.json) {
    out << nlohmann::json{{"result", a.result_path},
                          {"log", a.log_path},
                          {"out", a.out_path},
                          {"model", saved.model.name},
                          {"samples", p.log.size()},
                          {"samples_left_out", left_out},
                          {"derivatives", p.report.derivatives},
                          {"rmse_measured_Nm", p.rmse_measured_Nm}}
               .dump(2)
        << "\n";
    return 0;
  }
  char buf[160];
  out << "host_id predict: " << a.log_path << " with " << a.result_path << " (model "
      << saved.model.name << ")\n";
  out << "  samples   " << p.log.size() << " of " << log.size() << " (" << left_out
      << " left out: trimmed segment ends and segments too short)\n";
  out << "            " << p.report.derivatives << "\n";
  std::snprintf(buf, sizeof buf,
                "  torque RMSE against the measured torque [N m]: %.5f %.5f %.5f\n",
                p.rmse_measured_Nm[0], p.rmse_measured_Nm[1], p.rmse_measured_Nm[2]);
  out << buf << "  wrote     " << a.out_path << "\n";
  return 0;
}

}  // namespace

void add_predict_command(CLI::App& command, CommandContext& context) {
  CLI::App* c = &command;
  c->description(
      "Writes PRED.csv, a delta-log/1 file with the log's metadata and, for every sample a fit "
      "would use, t (and seq), the states used (q, qd, qdd: the log's own qd and qdd where it "
      "has them, otherwise the fit's filtering and differences), the measured tau and the "
      "model's tau_model1..3. Samples the trim drops are left out.");
  auto a = std::make_shared<PredictArguments>();
  c->add_option("result", a->result_path, "RESULT.json saved by host_id fit --out")->required();
  c->add_option("log", a->log_path, "the delta-log/1 file")->required();
  c->add_option("-o,--out", a->out_path, "the prediction to write (atomically)")
      ->check(kOutputPath)
      ->required();
  c->add_flag("--json", a->json, "print a JSON summary instead of text");
  c->add_flag("--allow-other-geometry", a->allow_other_geometry,
              "go on (with a warning) where the log's geometry is not the one the result was "
              "fitted for");
  add_time_steps_option(*c, a->time_steps);  // default: as the result was fitted
  c->callback([a, &context] { context.exit_code = run_predict(*a, context.out, context.err); });
}

}  // namespace host_id
