// host_id validate RESULT.json LOG.csv...: torque RMSE of a saved fit.
#include <memory>
#include <nlohmann/json.hpp>
#include <ostream>

#include "commands/command.hpp"
#include "delta/atomic_file.hpp"
#include "host_id/delta_log.hpp"
#include "host_id/geometry_check.hpp"
#include "host_id/identify.hpp"
#include "host_id/report.hpp"
#include "host_id/svg_plot.hpp"

namespace host_id {

namespace {

struct ValidateArguments {
  std::string result_path;
  std::vector<std::string> logs;
  bool json{false};
  std::string plot_path;
  bool allow_other_geometry{false};
  std::string time_steps;  // "": as the result was fitted
};

int run_validate(const ValidateArguments& a, std::ostream& out, std::ostream& err) {
  SavedResult saved = read_saved_result(a.result_path);
  if (!a.time_steps.empty()) saved.prepare.time_steps = time_steps_named(a.time_steps);
  const auto model = make_model(saved.model);
  std::vector<DeltaLog> logs;
  for (const auto& path : a.logs) {
    logs.push_back(read_delta_log(path));
    check_result_geometry(path, logs.back().geometry, a.result_path, saved.geometry,
                          a.allow_other_geometry, err);
  }
  std::vector<LogRmse> rows;
  std::vector<Prediction> predictions;
  for (const auto& l : logs) {
    warn_about_log(err, l, saved.prepare.time_steps);
    predictions.push_back(predict(*model, saved.beta, l, saved.prepare, 0));
    rows.push_back(predictions.back().rmse());
    warn_beyond(err, l.name, a.result_path, saved.excitation, rows.back().ranges);
  }
  if (!a.plot_path.empty()) {
    delta::write_file_atomically(a.plot_path,
                                 svg_torque_plot(predictions, "host_id validate " + a.result_path));
  }
  if (a.json) {
    nlohmann::json j = nlohmann::json::array();
    for (const auto& r : rows) j.push_back(json_rmse(r));
    out << nlohmann::json{{"result", a.result_path}, {"validation", j}}.dump(2) << "\n";
  } else {
    out << "host_id validate: " << a.result_path << " (model " << saved.model.name << ")\n";
    out << text_rmse_table(rows, "validate");
  }
  return 0;
}

}  // namespace

void add_validate_command(CLI::App& command, CommandContext& context) {
  CLI::App* c = &command;
  c->description(
      "Prints the torque RMSE per joint of the parameters saved by 'host_id fit --out "
      "RESULT.json' on each log.");
  auto a = std::make_shared<ValidateArguments>();
  c->add_option("result", a->result_path, "RESULT.json saved by host_id fit --out")->required();
  c->add_option("logs", a->logs, "the delta-log/1 files (one or more)")->required();
  c->add_flag("--json", a->json, "print JSON instead of text");
  c->add_flag("--allow-other-geometry", a->allow_other_geometry,
              "go on (with a warning) where a log's geometry is not the one the result was "
              "fitted for");
  add_time_steps_option(*c, a->time_steps);  // default: as the result was fitted
  c->add_option("--plot", a->plot_path, "measured vs predicted torque and the residuals")
      ->check(kSvgPath)
      ->check(kOutputPath);
  c->callback([a, &context] { context.exit_code = run_validate(*a, context.out, context.err); });
}

}  // namespace host_id
