// host_id excite: select and start an excitation on the controller over
// Modbus, record its CAN log frames meanwhile, stop when the run ends.
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <future>
#include <memory>
#include <ostream>
#include <sstream>
#include <thread>

#include "commands/command.hpp"
#include "commands/controller_text.hpp"
#include "delta/atomic_file.hpp"
#include "delta/controller/vocabulary.hpp"
#include "delta/custom_trajectory_block.hpp"
#include "delta/input_error.hpp"
#include "delta/trajectory_file.hpp"
#include "host_id/controller_link.hpp"
#include "host_id/delta_log.hpp"
#include "host_id/recorder.hpp"

namespace host_id {

namespace {

namespace mb = delta::modbus;

constexpr const char* kExciteDescription =
    "Selects and starts an excitation trajectory on the controller over Modbus, records its "
    "CAN log frames meanwhile (as host_id record), and stops when the controller reports the "
    "run finished. The log's geometry and sample rate come from the controller. On a fault, a "
    "stop from elsewhere, a lost connection or Ctrl-C (which stops the run), it keeps what it "
    "recorded as LOG.partial.csv and exits 4. Exit status: 0 finished, 1 error, 2 usage, "
    "3 samples lost, 4 run not finished.";

struct ExciteArguments {
  std::string address;
  std::string trajectory;
  std::string trajectory_file;  // uploaded as the custom trajectory
  std::string iface;
  std::string out_path;
  double amplitude_scale{1.0};
  std::uint16_t repetitions{0};  // 0: the trajectory's own
  std::string raw_path;
  double rated_current_A{2.0};
  double timeout_s{0};  // 0: no limit on the whole run (a stall still ends it)
};

std::atomic<bool> g_interrupted{false};
void on_interrupt(int) {
  g_interrupted.store(true);
}

std::uint16_t trajectory_id(const std::string& name) {
  delta::controller::TrajectoryId id{};
  delta::controller::trajectory_id(name, id);  // the option's check took only known names
  return static_cast<std::uint16_t>(id);
}

// Refuses a controller that is not ready, then writes the settings in one
// write (trajectory, amplitude, repetitions, log on). Returns the inputs.
std::vector<std::uint16_t> prepare_controller(ControllerLink& link, const ExciteArguments& a) {
  const std::vector<std::uint16_t> in = link.inputs();
  const auto state = raw("state", in);
  if (state == static_cast<int>(delta::controller::State::kFault)) {
    throw delta::InputError("excite: the controller at " + a.address + " is in fault " +
                            fault_text(raw("fault_code", in)) +
                            "; clear the cause and reset it (Modbus command 3) first");
  }
  if (state != static_cast<int>(delta::controller::State::kReady)) {
    throw delta::InputError("excite: the controller at " + a.address + " is " + state_text(state) +
                            ", not ready");
  }
  if (!a.trajectory_file.empty()) {
    // The file's coefficients into the custom block in one write; the
    // controller checks them when the settings below select it.
    std::vector<std::uint16_t> block;
    try {
      block = delta::custom_trajectory_block(delta::read_trajectory_file(a.trajectory_file));
    } catch (const delta::InputError& e) {
      throw delta::InputError(a.trajectory_file + ": " + e.what());
    }
    link.write(mb::kCustomFirst, block);
  }
  const auto permille = static_cast<std::uint16_t>(std::lround(a.amplitude_scale * 1000));
  link.write(mb::kTrajectory.address,
             {trajectory_id(a.trajectory), permille, a.repetitions, std::uint16_t{1}});
  return in;
}

// The recorder on its own thread, until the controller's records are all in
// (expect()) or finish() is called.
class BackgroundRecording {
 public:
  explicit BackgroundRecording(RecordOptions o) : options_(std::move(o)) {
    options_.keep_going = [this](std::uint64_t records) {
      return !finish_.load() && records < expected_.load();
    };
    auto ready = listening_.get_future();
    result_ = std::async(std::launch::async,
                         [this] { return capture(options_, [this] { listening_.set_value(); }); });
    // Wait for the socket, or the recorder's failure to open it.
    if (ready.wait_for(std::chrono::seconds(10)) != std::future_status::ready) finish_.store(true);
    if (result_.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
      result_.get();  // rethrows the recorder's error
    }
  }
  // On any way out, the recorder stops within its 50 ms poll and 10 ms of
  // gathering frames (result_'s destructor then waits for it).
  ~BackgroundRecording() { finish_.store(true); }
  BackgroundRecording(const BackgroundRecording&) = delete;
  BackgroundRecording& operator=(const BackgroundRecording&) = delete;
  void expect(std::uint64_t records) { expected_.store(records); }
  std::uint64_t expected() const { return expected_.load(); }
  // Waits 2 s at most for the last records, then ends the recording.
  Recording finish() {
    if (result_.wait_for(std::chrono::seconds(2)) != std::future_status::ready) {
      finish_.store(true);
    }
    return result_.get();
  }
  const RecordOptions& options() const { return options_; }

 private:
  RecordOptions options_;
  std::atomic<bool> finish_{false};
  std::atomic<std::uint64_t> expected_{UINT64_MAX};
  std::promise<void> listening_;
  std::future<Recording> result_;  // last: destroyed first, after the thread ends
};

struct RunOutcome {
  std::string ending;  // empty: finished
  std::int64_t run_id{0};
  std::int64_t run_length{0};
};

// Why the run ended early, from one poll of the inputs; empty while it
// goes on or when it finished.
std::optional<std::string> poll_ending(const std::vector<std::uint16_t>& in, std::int64_t run_id) {
  if (raw("run_id", in) != run_id) {
    return "another client started run #" + std::to_string(raw("run_id", in));
  }
  switch (static_cast<mb::RunResult>(raw("run_result", in))) {
    case mb::RunResult::kFinished:
      return std::string();
    case mb::RunResult::kFaulted:
      return "the controller faulted: fault " + fault_text(raw("fault_code", in)) + " at cycle " +
             std::to_string(raw("fault_history_0_cycle", in));
    case mb::RunResult::kStopped:
      return std::string("the run was stopped by another client");
    default:
      return std::nullopt;
  }
}

// How long a run's tick may stand still before excite gives it up.
constexpr std::chrono::seconds kStall{10};

// Starts the run and polls it until it ends, one way or another.
RunOutcome run_excitation(ControllerLink& link, const ExciteArguments& a, double rate_hz,
                          std::ostream& err) {
  RunOutcome o;
  link.write(mb::kCommand.address, {static_cast<std::uint16_t>(mb::Command::kStart)});
  std::vector<std::uint16_t> in = link.inputs();
  o.run_id = raw("run_id", in);
  o.run_length = raw("run_length", in);
  err << "host_id excite: running " << a.trajectory << " on " << a.address << " (run #" << o.run_id
      << ", " << static_cast<double>(o.run_length) / rate_hz << " s), recording " << a.iface
      << "\n";
  // A run may go slower than real time (lock-step behind a slow plant); it
  // is given up when its tick stops moving for kStall, or when --timeout is
  // over.
  const auto start = std::chrono::steady_clock::now();
  auto last_progress = start;
  std::int64_t last_tick = 0;
  const bool tty = isatty(STDERR_FILENO) != 0;
  const auto stop = [&](const std::string& why) {
    link.write(mb::kCommand.address, {static_cast<std::uint16_t>(mb::Command::kStop)});
    o.ending = why;
  };
  for (;;) {
    if (g_interrupted.load()) {
      stop("interrupted (Ctrl-C); the run was stopped");
      break;
    }
    in = link.inputs();
    if (const auto ending = poll_ending(in, o.run_id)) {
      o.ending = *ending;
      break;
    }
    const auto now = std::chrono::steady_clock::now();
    if (const std::int64_t tick = raw("run_tick", in); tick != last_tick) {
      last_tick = tick;
      last_progress = now;
    }
    if (now - last_progress > kStall) {
      std::ostringstream m;
      m << "the run stalled at tick " << last_tick << " of " << o.run_length << " for "
        << std::chrono::duration<double>(kStall).count() << " s; stopped it";
      stop(m.str());
      break;
    }
    if (a.timeout_s > 0 && now - start > std::chrono::duration<double>(a.timeout_s)) {
      std::ostringstream m;
      m << "the run did not finish within " << a.timeout_s << " s (--timeout); stopped it";
      stop(m.str());
      break;
    }
    if (tty) {
      err << "\rhost_id excite: tick " << raw("run_tick", in) << " / " << o.run_length << "   "
          << std::flush;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));  // the poll period
  }
  if (tty) err << "\r" << std::string(50, ' ') << "\r";
  return o;
}

int report(const ExciteArguments& a, const RunOutcome& run, const Recording& rec,
           std::uint64_t sent, double rate_hz, const std::string& path, std::ostream& out,
           std::ostream& err) {
  out << "host_id excite: " << a.trajectory << " (run #" << run.run_id << ") "
      << (run.ending.empty() ? "finished" : "NOT finished") << "\n"
      << "  samples   " << rec.summary.samples << " recorded";
  if (sent != UINT64_MAX) out << " of " << sent << " sent";
  out << ", " << rec.summary.lost << " lost, " << rec.summary.stale << " stale left out, "
      << static_cast<double>(rec.log.t.size()) / rate_hz << " s at " << rate_hz << " Hz\n"
      << "  log       " << path << "\n";
  if (!a.raw_path.empty()) out << "  raw       " << a.raw_path << "\n";
  report_left_out(err, "host_id excite", rec.summary);
  report_emergencies(err, "host_id excite", rec.summary);
  if (!run.ending.empty()) {
    err << "host_id excite: " << run.ending << "; the partial log is " << path << "\n";
    return 4;
  }
  if (rec.summary.lost > 0) {
    err << "host_id excite: samples were lost; the log keeps them as gaps in seq\n";
    return 3;
  }
  const std::uint64_t accounted = rec.summary.samples + rec.summary.stale;
  if (sent != UINT64_MAX && accounted < sent) {
    err << "host_id excite: the log ends " << sent - accounted << " record(s) short of the " << sent
        << " the controller sent\n";
    return 3;
  }
  return 0;
}

RecordOptions record_options(const ExciteArguments& a, const std::vector<std::uint16_t>& in) {
  RecordOptions ro;
  ro.iface = a.iface;
  ro.out_path = a.out_path;
  if (!a.raw_path.empty()) ro.raw_path = a.raw_path;
  ro.sample_rate_hz = 1e6 / static_cast<double>(raw("period_us", in));
  ro.rated_current_A = a.rated_current_A;
  ro.geometry = {scaled("upper_arm_length", in), scaled("forearm_length", in),
                 scaled("base_radius", in), scaled("platform_radius", in)};
  return ro;
}

int run_excite(const ExciteArguments& a, std::ostream& out, std::ostream& err) {
  ControllerLink link(a.address);
  const std::vector<std::uint16_t> in = prepare_controller(link, a);
  BackgroundRecording recording(record_options(a, in));
  const double rate_hz = recording.options().sample_rate_hz;
  const auto records_before = static_cast<std::uint64_t>(raw("log_records", in));
  const auto previous_handler = std::signal(SIGINT, on_interrupt);
  g_interrupted.store(false);
  RunOutcome run;
  try {
    run = run_excitation(link, a, rate_hz, err);
    // The recorder has all the run's records once it holds as many as the
    // controller sent.
    if (run.ending.empty()) {
      recording.expect(static_cast<std::uint64_t>(raw("log_records", link.inputs())) -
                       records_before);
    }
  } catch (const delta::InputError& e) {
    if (run.ending.empty()) run.ending = std::string("lost the controller: ") + e.what();
  }
  std::signal(SIGINT, previous_handler);
  Recording rec;
  try {
    rec = recording.finish();
  } catch (const delta::InputError&) {
    if (!run.ending.empty()) {
      throw delta::InputError("excite: " + run.ending +
                              "; no log sample was recorded, nothing written");
    }
    throw;
  }
  rec.log.metadata.emplace_back("trajectory", a.trajectory);
  if (!a.trajectory_file.empty())
    rec.log.metadata.emplace_back("trajectory_file", a.trajectory_file);
  const std::string path = run.ending.empty() ? a.out_path : delta::partial_log_path(a.out_path);
  delta::write_file_atomically(path, format_delta_log(rec.log));
  if (!a.raw_path.empty()) delta::write_file_atomically(a.raw_path, rec.raw);
  return report(a, run, rec, recording.expected(), rate_hz, path, out, err);
}

}  // namespace

void add_excite_command(CLI::App& command, CommandContext& context) {
  CLI::App* c = &command;
  c->description(kExciteDescription);
  auto a = std::make_shared<ExciteArguments>();
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
  c->add_option("-o,--out", a->out_path, "the log to write (atomically)")->required();
  c->add_option("--amplitude-scale", a->amplitude_scale, "the trajectory's amplitude")
      ->check(finite_range(0.001, 2.0))
      ->capture_default_str();
  c->add_option("--repetitions", a->repetitions,
                "Fourier periods or pick-and-place cycles (default: the trajectory's own, 2 or 3)")
      ->check(CLI::Range(1, 100));
  c->add_option("--raw", a->raw_path, "also write every CAN frame of the session (candump -L)");
  c->add_option("--rated-current-A", a->rated_current_A,
                "the drives' rated current, for the i1..i3 columns")
      ->check(kPositive)
      ->capture_default_str();
  c->add_option("--timeout", a->timeout_s,
                "give up when the run has not finished after S seconds (default: no limit; a run "
                "whose tick stops moving for 10 s is given up anyway)")
      ->check(kPositive);
  c->callback([a, &context] {
    ExciteArguments args = *a;
    if (args.trajectory.empty() && args.trajectory_file.empty()) {
      throw UsageError("excite: one of --trajectory and --trajectory-file is required");
    }
    if (!args.trajectory_file.empty()) args.trajectory = "custom";
    context.exit_code = run_excite(args, context.out, context.err);
  });
}

}  // namespace host_id
