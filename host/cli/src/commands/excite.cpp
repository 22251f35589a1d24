// host_id excite: its options (host_id/excite.hpp does the work).
#include "host_id/excite.hpp"

#include <memory>
#include <string>
#include <vector>

#include "commands/command.hpp"
#include "delta/controller/vocabulary.hpp"

namespace host_id {

namespace {

constexpr const char* kExciteDescription =
    "Selects and starts an excitation trajectory on the controller over Modbus, records its "
    "CAN log frames meanwhile (as host_id record), and stops when the controller reports the "
    "run finished. The log's geometry and sample rate come from the controller. On a fault, a "
    "stop from elsewhere, a lost connection or Ctrl-C (which stops the run), it keeps what it "
    "recorded as LOG.partial.csv and exits 4. Exit status: 0 finished, 1 error, 2 usage, "
    "3 samples lost, 4 run not finished.";

}  // namespace

void add_excite_command(CLI::App& command, CommandContext& context) {
  CLI::App* c = &command;
  c->description(kExciteDescription);
  auto a = std::make_shared<ExciteOptions>();
  c->add_option("--modbus", a->address, "the controller's Modbus TCP address")
      ->required()
      ->check(kHostPort);
  CLI::Option* named = c->add_option("--trajectory", a->trajectory, "the excitation")
                           ->check(CLI::IsMember(std::vector<std::string>(
                               delta::controller::kTrajectoryNames.begin(),
                               delta::controller::kTrajectoryNames.end())));
  CLI::Option* file = c->add_option(
      "--trajectory-file", a->trajectory_file,
      "a trajectory file (docs/trajectory-file.md, from host_id design): uploaded into the "
      "controller's custom trajectory registers and run as trajectory 'custom'");
  named->excludes(file);
  c->add_option("--can", a->iface, "the CAN interface to record")->required();
  c->add_option("-o,--out", a->out_path, "the log to write (atomically)")
      ->check(kOutputPath)
      ->required();
  c->add_option("--amplitude-scale", a->amplitude_scale, "the trajectory's amplitude")
      ->check(finite_range(0.001, 2.0))
      ->capture_default_str();
  c->add_option("--repetitions", a->repetitions,
                "Fourier periods or pick-and-place cycles (default: the trajectory's own, 2 or 3)")
      ->check(CLI::Range(1, 100));
  c->add_option("--raw", a->raw_path, "also write every CAN frame of the session (candump -L)")
      ->check(kOutputPath);
  c->add_option("--rated-current-A", a->rated_current_A,
                "the drives' rated current, for the i1..i3 columns")
      ->check(kPositive)
      ->capture_default_str();
  c->add_option("--timeout", a->timeout_s,
                "give up when the run has not finished after S seconds (default: no limit; a run "
                "whose tick stops moving for 10 s is given up anyway)")
      ->check(kPositive);
  c->add_flag("--quiet", a->quiet, "no running line, progress or closing lines (warnings stay)");
  c->add_flag("--json", a->json, "the closing summary as JSON on stdout");
  c->callback([a, &context] {
    ExciteOptions args = *a;
    if (args.trajectory.empty() && args.trajectory_file.empty()) {
      throw UsageError("excite: one of --trajectory and --trajectory-file is required");
    }
    if (!args.trajectory_file.empty()) args.trajectory = "custom";
    context.exit_code = run_excite(args, context.out, context.err);
  });
}

}  // namespace host_id
