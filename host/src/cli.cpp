#include "host_id/cli.hpp"

#include <unistd.h>

#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>

#include "delta/parameter_file.hpp"
#include "host_id/atomic_file.hpp"
#include "host_id/controller_commands.hpp"
#include "host_id/dbc.hpp"
#include "host_id/delta_log.hpp"
#include "host_id/identify.hpp"
#include "host_id/options.hpp"
#include "host_id/recorder.hpp"
#include "host_id/report.hpp"
#include "host_id/simulate.hpp"
#include "host_id/svg_plot.hpp"

namespace host_id {

namespace {

constexpr const char* kUsage = R"(usage: host_id <command> [options]

Identifies the dynamic parameters of a delta parallel robot from delta-log/1
files (see docs/log-format.md).

commands:
  fit LOG.csv [options]            estimate the parameters (PSO by default)
  validate RESULT.json LOG.csv...  torque RMSE of a saved fit on other logs
  simulate -o LOG.csv [options]    write a log from known parameters
  record --can IFACE -o LOG.csv    record the controller's CAN log frames
  excite --modbus HOST:PORT --trajectory NAME --can IFACE -o LOG.csv
                                   run an excitation over Modbus and record it
  status --modbus HOST:PORT        the controller's state, faults and settings
  dbc [-o FILE.dbc]                the bus's DBC description (for CAN tools)

'host_id <command> --help' describes a command's options.
)";

constexpr const char* kFitHelp = R"(usage: host_id fit LOG.csv [options]

Estimates the dynamic parameters from LOG.csv and prints a report.

model:
  --model delta|paper14     delta: lumped model with lambda solved per sample
                            (default); paper14: the paper's 14 coefficients
  --per-joint               delta: arm inertia and gravity moment per joint
  --offsets                 delta: a torque offset per joint
  --coulomb-smoothing W     Coulomb sign smoothed as tanh(qd/W), rad/s (0.01)
estimator:
  --method pso|ls           particle swarm (default) or least squares
  --particles N             swarm size (40)
  --iterations N            maximum iterations (10000, as in the paper)
  --topology gbest|ring     swarm topology (gbest)
  --seed N                  random seed; same seed, same result (1)
  --stall-iterations N      stop or restart after N iterations without
                            improvement (1000)
  --restarts N              restarts on stall before stopping (2)
  --bound-factor K          PSO box: |beta_j| <= K rms(tau)/rms(Psi_j) (10)
  --solver qr|svd           least-squares solver (qr)
  --weights none|joint      ordinary, or weighted by each joint's residual
                            variance (none)
  --threads N               threads for building the regressor (0: all cores)
samples:
  --cutoff-hz F             low-pass cut-off for q and tau when the log has no
                            qd/qdd columns (20)
  --trim N                  samples dropped at each segment end (auto)
  --min-speed W             leave out a joint's equation where its |qd| < W
                            rad/s (delta: 0.1, paper14: 0 = every sample)
output:
  --validate LOG2.csv       torque RMSE on another log (repeatable)
  --out FILE.json           save the result (atomically)
  --json                    print the whole report as JSON instead of text
  --plot FILE.svg           measured vs predicted torque and the residuals
  --quiet                   no progress bar
)";

constexpr const char* kValidateHelp =
    R"(usage: host_id validate RESULT.json LOG.csv [LOG.csv...] [--json]

Prints the torque RMSE per joint of the parameters saved by
'host_id fit --out RESULT.json' on each log.
  --json                    print JSON instead of text
  --plot FILE.svg           measured vs predicted torque and the residuals
)";

constexpr const char* kSimulateHelp = R"(usage: host_id simulate -o LOG.csv [options]

Writes a delta-log/1 file by inverse dynamics of the lumped model with known
parameters (the default robot's unless --params is given).
  -o, --out FILE            the log to write (atomically)
  --trajectory fourier|pick-and-place   (fourier)
  --duration S              seconds (10)
  --rate HZ                 sample rate (1000)
  --seed N                  Fourier coefficients and noise (1)
  --harmonics N             Fourier harmonics (5)
  --base-hz F               Fourier base frequency (0.2)
  --amplitude RAD           largest joint amplitude of the Fourier path (0.35)
  --torque-noise F          Gaussian torque noise, fraction of RMS torque (0)
  --encoder-bits N          quantise q to 2 pi / 2^N (0: off)
  --with-derivatives        also write exact qd and qdd columns
  --params FILE.json        parameters (keys as in 'host_id fit' output)
  --name NAME               the log's trajectory name
)";

class ProgressBar {
 public:
  explicit ProgressBar(bool enabled) : enabled_(enabled) {}
  void operator()(std::size_t it, std::size_t max, double cost) const {
    if (!enabled_) return;
    const int width = 40;
    const int filled = max ? static_cast<int>(static_cast<double>(width) * static_cast<double>(it) /
                                              static_cast<double>(max))
                           : width;
    std::fprintf(stderr, "\rpso [%-*s] %6zu/%zu  cost %.6e", width,
                 std::string(static_cast<std::size_t>(std::min(filled, width)), '#').c_str(), it,
                 max, cost);
    std::fflush(stderr);
  }
  void finish() const {
    if (enabled_) std::fprintf(stderr, "\r%*s\r", 90, "");
  }

 private:
  bool enabled_;
};

std::vector<Prediction> predictions(const Model& model, const Eigen::VectorXd& beta,
                                    const std::vector<const DeltaLog*>& logs,
                                    const PrepareOptions& prepare, unsigned threads) {
  std::vector<Prediction> out;
  for (const DeltaLog* l : logs) out.push_back(predict(model, beta, *l, prepare, threads));
  return out;
}

void check_plot_path(const std::string& command, const std::string& path) {
  if (path.size() < 4 || path.substr(path.size() - 4) != ".svg") {
    throw UsageError(command + ": --plot writes SVG; give a file name ending in .svg, got '" +
                     path + "'");
  }
}

int cmd_fit(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  if (wants_help(args)) {
    out << kFitHelp;
    return 0;
  }
  const ParsedOptions o("fit",
                        {{"--model"},
                         {"--per-joint", false},
                         {"--offsets", false},
                         {"--coulomb-smoothing"},
                         {"--method"},
                         {"--particles"},
                         {"--iterations"},
                         {"--topology"},
                         {"--seed"},
                         {"--stall-iterations"},
                         {"--restarts"},
                         {"--bound-factor"},
                         {"--solver"},
                         {"--weights"},
                         {"--threads"},
                         {"--cutoff-hz"},
                         {"--trim"},
                         {"--min-speed"},
                         {"--validate", true, true},
                         {"--out"},
                         {"--json", false},
                         {"--plot"},
                         {"--quiet", false}},
                        args);
  if (o.positional().size() != 1) {
    throw UsageError("fit: expected one log file, got " + std::to_string(o.positional().size()) +
                     " (usage: host_id fit LOG.csv [options])");
  }
  FitOptions f;
  f.model.name = o.choice("--model", "delta", {"delta", "paper14"});
  f.model.per_joint = o.flag("--per-joint");
  f.model.offsets = o.flag("--offsets");
  f.model.coulomb_smoothing_rad_s = o.number("--coulomb-smoothing", 0.01);
  f.method =
      o.choice("--method", "pso", {"pso", "ls"}) == "pso" ? Method::kPso : Method::kLeastSquares;
  f.pso.particles = o.whole("--particles", 40, 2, 100000);
  f.pso.iterations = o.whole("--iterations", 10000, 1, 100000000);
  f.pso.topology = o.choice("--topology", "gbest", {"gbest", "ring"}) == "gbest"
                       ? PsoTopology::kGlobal
                       : PsoTopology::kRing;
  f.pso.seed = o.whole("--seed", 1, 0, UINT64_MAX);
  f.pso.stall_iterations = o.whole("--stall-iterations", 1000, 1, 100000000);
  f.pso.restarts = o.whole("--restarts", 2, 0, 1000);
  f.bound_factor = o.number("--bound-factor", 10.0);
  if (!(f.bound_factor > 0)) throw UsageError("fit: --bound-factor must be positive");
  f.solver = o.choice("--solver", "qr", {"qr", "svd"}) == "qr" ? LsSolver::kQr : LsSolver::kSvd;
  f.weights = o.choice("--weights", "none", {"none", "joint"}) == "none" ? LsWeights::kNone
                                                                         : LsWeights::kJoint;
  f.threads = static_cast<unsigned>(o.whole("--threads", 0, 0, 256));
  f.prepare.cutoff_hz = o.number("--cutoff-hz", kDefaultCutoffHz);
  f.prepare.trim_samples =
      o.value("--trim") ? static_cast<long>(o.whole("--trim", 0, 0, 1000000)) : -1;
  if (o.value("--min-speed")) {
    f.min_speed_rad_s = o.number("--min-speed", 0.0);
    if (!(*f.min_speed_rad_s >= 0.0)) throw UsageError("fit: --min-speed must be 0 or more");
  }
  if (const auto p = o.value("--plot")) check_plot_path("fit", *p);
  const bool as_json = o.flag("--json");
  const ProgressBar bar(!o.flag("--quiet") && isatty(STDERR_FILENO) && f.method == Method::kPso);
  f.pso.progress = [&bar](std::size_t it, std::size_t max, double c) { bar(it, max, c); };
  f.pso.progress_every = 200;

  // Read every input before doing any work, so a bad validation log fails fast.
  const DeltaLog log = read_delta_log(o.positional()[0]);
  std::vector<DeltaLog> validation_logs;
  for (const auto& v : o.values("--validate")) validation_logs.push_back(read_delta_log(v));
  for (const auto& l : {&log}) {
    for (const auto& g : l->gaps) {
      err << l->name << ":" << g.line << ": warning: " << g.what
          << "; segments are fitted separately\n";
    }
  }

  FitResult r = fit_log(log, f);
  bar.finish();
  const auto model = make_model(f.model);
  std::vector<const DeltaLog*> all{&log};
  for (const auto& v : validation_logs) {
    const Prediction p = predict(*model, r.beta, v, f.prepare, f.threads);
    r.validation.push_back({v.name, p.t_s.size(), p.rmse_Nm});
    all.push_back(&v);
  }
  const nlohmann::json j = json_report(r);
  if (const auto path = o.value("--out")) write_file_atomically(*path, j.dump(2) + "\n");
  if (const auto path = o.value("--plot")) {
    write_file_atomically(*path,
                          svg_torque_plot(predictions(*model, r.beta, all, f.prepare, f.threads),
                                          "host_id fit, model " + f.model.name));
  }
  if (as_json) {
    out << j.dump(2) << "\n";
  } else {
    out << text_report(r);
    if (const auto path = o.value("--out")) out << "  saved     " << *path << "\n";
    if (const auto path = o.value("--plot")) out << "  plot      " << *path << "\n";
  }
  return 0;
}

int cmd_validate(const std::vector<std::string>& args, std::ostream& out) {
  if (wants_help(args)) {
    out << kValidateHelp;
    return 0;
  }
  const ParsedOptions o("validate", {{"--json", false}, {"--plot"}}, args);
  if (o.positional().size() < 2) {
    throw UsageError(
        "validate: expected RESULT.json and at least one log (usage: host_id validate RESULT.json "
        "LOG.csv...)");
  }
  if (const auto p = o.value("--plot")) check_plot_path("validate", *p);
  const SavedResult saved = read_saved_result(o.positional()[0]);
  const auto model = make_model(saved.model);
  std::vector<DeltaLog> logs;
  for (std::size_t i = 1; i < o.positional().size(); ++i)
    logs.push_back(read_delta_log(o.positional()[i]));
  std::vector<LogRmse> rows;
  std::vector<Prediction> preds;
  for (const auto& l : logs) {
    preds.push_back(predict(*model, saved.beta, l, saved.prepare, 0));
    rows.push_back({l.name, preds.back().t_s.size(), preds.back().rmse_Nm});
  }
  if (const auto path = o.value("--plot")) {
    write_file_atomically(*path, svg_torque_plot(preds, "host_id validate " + o.positional()[0]));
  }
  if (o.flag("--json")) {
    nlohmann::json j = nlohmann::json::array();
    for (const auto& r : rows) j.push_back(json_rmse(r));
    out << nlohmann::json{{"result", o.positional()[0]}, {"validation", j}}.dump(2) << "\n";
  } else {
    out << "host_id validate: " << o.positional()[0] << " (model " << saved.model.name << ")\n";
    out << text_rmse_table(rows, "validate");
  }
  return 0;
}

int cmd_simulate(const std::vector<std::string>& args, std::ostream& out) {
  if (wants_help(args)) {
    out << kSimulateHelp;
    return 0;
  }
  const ParsedOptions o("simulate",
                        {{"--out", true, false, "-o"},
                         {"--trajectory"},
                         {"--duration"},
                         {"--rate"},
                         {"--seed"},
                         {"--harmonics"},
                         {"--base-hz"},
                         {"--amplitude"},
                         {"--torque-noise"},
                         {"--encoder-bits"},
                         {"--with-derivatives", false},
                         {"--params"},
                         {"--name"}},
                        args);
  if (!o.positional().empty()) {
    throw UsageError("simulate: unexpected argument '" + o.positional()[0] +
                     "' (the output goes with -o)");
  }
  const auto path = o.value("--out");
  if (!path) throw UsageError("simulate: -o LOG.csv is required");
  SimulateOptions s;
  s.trajectory = o.choice("--trajectory", "fourier", {"fourier", "pick-and-place"});
  s.duration_s = o.number("--duration", 10.0);
  s.sample_rate_hz = o.number("--rate", 1000.0);
  s.seed = o.whole("--seed", 1, 0, UINT64_MAX);
  s.harmonics = static_cast<unsigned>(o.whole("--harmonics", 5, 1, 20));
  s.base_frequency_hz = o.number("--base-hz", 0.2);
  s.amplitude_rad = o.number("--amplitude", 0.35);
  s.torque_noise = o.number("--torque-noise", 0.0);
  s.encoder_bits = static_cast<unsigned>(o.whole("--encoder-bits", 0, 0, 32));
  s.with_derivatives = o.flag("--with-derivatives");
  s.name = o.value("--name").value_or("");
  if (const auto p = o.value("--params")) s.parameters = delta::read_lumped_parameters(*p);
  const DeltaLog log = simulate_log(s);
  write_file_atomically(*path, format_delta_log(log));
  out << "host_id simulate: wrote " << *path << " (" << log.size() << " samples, " << s.trajectory
      << ")\n";
  return 0;
}

constexpr const char* kRecordHelp =
    R"(usage: host_id record --can IFACE -o LOG.csv [limits] [options]

Records the controller's log frames (LOG_A..LOG_C, docs/protocol.md) from a
CAN interface into delta-log/1, with the drives' motor currents (TPDO1) as
columns i1..i3 when every sample has them. Samples are paired by their sequence
counter; a lost sample is reported and the log keeps its seq column, so no
gap is ever bridged. A cycle the controller marked stale (a drive's feedback
missed it) is left out the same way and reported, but is not lost. Exit
status 3 when samples were lost (unless --allow-gaps).
limits (at least one):
  --duration S              stop after S seconds
  --samples N               stop after N complete samples
  --idle S                  stop when no log frame came for S seconds, counted
                            from the first log frame
options:
  --rate HZ                 the controller's cycle rate, for t (500)
  --raw FILE.log            also write every frame of the session (all IDs) in
                            candump -L format, for canplayer and DBC tools
  --rated-current-A A       the drives' rated current (0x6075), for the i1..i3
                            columns: the drives' TPDO1 currents in A (2)
  --allow-gaps              exit 0 even when samples were lost
  --upper-arm-m, --forearm-m, --base-radius-m, --platform-radius-m
                            the robot's geometry for the metadata (default robot)
)";

int cmd_record(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  if (wants_help(args)) {
    out << kRecordHelp;
    return 0;
  }
  const ParsedOptions o("record",
                        {{"--can"},
                         {"--out", true, false, "-o"},
                         {"--duration"},
                         {"--samples"},
                         {"--idle"},
                         {"--rate"},
                         {"--raw"},
                         {"--allow-gaps", false},
                         {"--rated-current-A"},
                         {"--upper-arm-m"},
                         {"--forearm-m"},
                         {"--base-radius-m"},
                         {"--platform-radius-m"}},
                        args);
  if (!o.positional().empty())
    throw UsageError("record: unexpected argument '" + o.positional()[0] + "'");
  RecordOptions r;
  r.iface = o.value("--can").value_or("");
  if (r.iface.empty()) throw UsageError("record: --can IFACE is required");
  r.out_path = o.value("--out").value_or("");
  if (r.out_path.empty()) throw UsageError("record: -o LOG.csv is required");
  r.raw_path = o.value("--raw");
  r.duration_s = o.number("--duration", 0);
  r.samples = o.whole("--samples", 0, 0, UINT64_MAX);
  r.idle_s = o.number("--idle", 0);
  r.sample_rate_hz = o.number("--rate", 500);
  r.rated_current_A = o.number("--rated-current-A", r.rated_current_A);
  if (!(r.rated_current_A > 0)) throw UsageError("record: --rated-current-A must be positive");
  r.geometry.upper_arm_length_m = o.number("--upper-arm-m", r.geometry.upper_arm_length_m);
  r.geometry.forearm_length_m = o.number("--forearm-m", r.geometry.forearm_length_m);
  r.geometry.base_radius_m = o.number("--base-radius-m", r.geometry.base_radius_m);
  r.geometry.platform_radius_m = o.number("--platform-radius-m", r.geometry.platform_radius_m);
  // The line tells scripts and tests that the socket is open.
  const RecordSummary s =
      record(r, [&] { err << "host_id record: listening on " << r.iface << std::endl; });
  out << "host_id record: " << s.samples << " samples (" << s.frames << " frames) from " << r.iface
      << " in " << s.seconds << " s -> " << r.out_path
      << (s.currents ? " (with the drives' currents i1..i3)" : "") << "\n";
  report_left_out(err, "host_id record", s);
  if (s.socket_drops)
    err << "host_id record: the kernel dropped " << s.socket_drops << " frames for this reader\n";
  if (s.samples_without_currents > 0) {
    err << "host_id record: " << s.samples_without_currents
        << " samples came without all three drives' TPDO1; the i1..i3 columns are left out\n";
  }
  if (s.lost > 0 && !o.flag("--allow-gaps")) {
    err << "host_id record: " << s.lost
        << " samples lost; the log keeps them as gaps in seq (--allow-gaps to accept)\n";
    return 3;
  }
  return 0;
}

int cmd_dbc(const std::vector<std::string>& args, std::ostream& out) {
  if (wants_help(args)) {
    out << "usage: host_id dbc [-o FILE.dbc]\n\nWrites the DBC description of the controller's CAN "
           "bus (the "
           "protocol table in common/portable/include/delta/can/protocol.hpp) to FILE or stdout.\n";
    return 0;
  }
  const ParsedOptions o("dbc", {{"--out", true, false, "-o"}}, args);
  if (!o.positional().empty())
    throw UsageError("dbc: unexpected argument '" + o.positional()[0] + "'");
  if (const auto path = o.value("--out")) {
    write_file_atomically(*path, make_dbc());
  } else {
    out << make_dbc();
  }
  return 0;
}

}  // namespace

int run_cli(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  try {
    if (args.empty() || args[0] == "--help" || args[0] == "-h" || args[0] == "help") {
      (args.empty() ? err : out) << kUsage;
      return args.empty() ? 2 : 0;
    }
    const std::string& cmd = args[0];
    const std::vector<std::string> rest(args.begin() + 1, args.end());
    if (cmd == "fit") return cmd_fit(rest, out, err);
    if (cmd == "validate") return cmd_validate(rest, out);
    if (cmd == "simulate") return cmd_simulate(rest, out);
    if (cmd == "dbc") return cmd_dbc(rest, out);
    if (cmd == "record") return cmd_record(rest, out, err);
    if (cmd == "excite") return cmd_excite(rest, out, err);
    if (cmd == "status") return cmd_status(rest, out, err);
    throw UsageError("unknown command '" + cmd +
                     "' (commands: fit, validate, simulate, record, excite, status, dbc; see "
                     "host_id --help)");
  } catch (const UsageError& e) {
    err << "host_id: error: " << e.what() << "\n";
    return 2;
  } catch (const delta::InputError& e) {
    err << "host_id: error: " << e.what() << "\n";
    return 1;
  } catch (const std::invalid_argument& e) {
    err << "host_id: error: " << e.what() << "\n";
    return 1;
  } catch (const std::bad_alloc&) {
    err << "host_id: error: out of memory\n";
    return 1;
  }
}

}  // namespace host_id
