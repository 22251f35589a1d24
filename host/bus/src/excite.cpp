#include "host_id/excite.hpp"

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <future>
#include <ostream>
#include <sstream>
#include <thread>

#include "delta/atomic_file.hpp"
#include "delta/controller/vocabulary.hpp"
#include "delta/custom_trajectory_block.hpp"
#include "delta/input_error.hpp"
#include "delta/modbus/register_map.hpp"
#include "delta/trajectory_file.hpp"
#include "host_id/controller_link.hpp"
#include "host_id/controller_text.hpp"
#include "host_id/delta_log.hpp"

namespace host_id {

namespace {

namespace mb = delta::modbus;

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
std::vector<std::uint16_t> prepare_controller(ControllerLink& link, const ExciteOptions& a) {
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

// How long a run's tick may stand still before excite gives it up.
constexpr std::chrono::seconds kStall{10};

// Starts the run and polls it until it ends, one way or another.
RunOutcome run_excitation(ControllerLink& link, const ExciteOptions& a, double rate_hz,
                          std::ostream& err) {
  RunOutcome o;
  link.write(mb::kCommand.address, {static_cast<std::uint16_t>(mb::Command::kStart)});
  std::vector<std::uint16_t> in = link.inputs();
  o.run_id = raw("run_id", in);
  o.run_length = raw("run_length", in);
  if (!a.quiet) {
    err << "host_id excite: running " << a.trajectory << " on " << a.address << " (run #"
        << o.run_id << ", " << static_cast<double>(o.run_length) / rate_hz << " s), recording "
        << a.iface << "\n";
  }
  // A run may go slower than real time (lock-step behind a slow plant); it
  // is given up when its tick stops moving for kStall, or when --timeout is
  // over.
  const auto start = std::chrono::steady_clock::now();
  auto last_progress = start;
  std::int64_t last_tick = 0;
  const bool tty = !a.quiet && isatty(STDERR_FILENO) != 0;
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

// The closing lines on out, the verdict's message on err; the exit status.
int report(const ExciteOptions& a, const RunOutcome& run, const Recording& rec, std::uint64_t sent,
           double rate_hz, const std::string& path, std::ostream& out, std::ostream& err) {
  if (a.json) {
    nlohmann::json j = json_summary(rec.summary);
    j["trajectory"] = a.trajectory;
    j["run_id"] = run.run_id;
    j["finished"] = run.ending.empty();
    j["ending"] = run.ending;
    j["sent"] = sent != UINT64_MAX ? nlohmann::json(sent) : nlohmann::json();
    j["sample_rate_hz"] = rate_hz;
    j["log"] = path;
    j["raw"] = a.raw_path.empty() ? nlohmann::json() : nlohmann::json(a.raw_path);
    nlohmann::json tracking = nlohmann::json::object();
    for (const auto& [key, value] : rec.log.metadata) {
      if (key.rfind("tracking_", 0) == 0) tracking[key] = std::stod(value);
    }
    j["tracking"] = tracking;
    out << j.dump(2) << "\n";
  } else if (!a.quiet) {
    out << "host_id excite: " << a.trajectory << " (run #" << run.run_id << ") "
        << (run.ending.empty() ? "finished" : "NOT finished") << "\n"
        << "  samples   " << rec.summary.samples << " recorded";
    if (sent != UINT64_MAX) out << " of " << sent << " sent";
    out << ", " << rec.summary.lost << " lost, " << rec.summary.stale << " stale left out, "
        << static_cast<double>(rec.log.t.size()) / rate_hz << " s at " << rate_hz << " Hz\n"
        << "  log       " << path << "\n";
    if (!a.raw_path.empty()) out << "  raw       " << a.raw_path << "\n";
  }
  report_left_out(err, "host_id excite", rec.summary);
  report_emergencies(err, "host_id excite", rec.summary);
  const ExciteVerdict v = excite_verdict(run.ending, rec.summary, sent, path);
  if (!v.message.empty()) err << "host_id excite: " << v.message << "\n";
  return v.exit_code;
}

}  // namespace

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

ExciteVerdict excite_verdict(const std::string& ending, const RecordSummary& summary,
                             std::uint64_t sent, const std::string& log_path) {
  if (!ending.empty()) {
    return {kExitExciteNotFinished, ending + "; the partial log is " + log_path};
  }
  if (summary.lost > 0) {
    return {kExitExciteSamplesLost, "samples were lost; the log keeps them as gaps in seq"};
  }
  const std::uint64_t accounted = summary.samples + summary.stale;
  if (sent != UINT64_MAX && accounted < sent) {
    return {kExitExciteSamplesLost, "the log ends " + std::to_string(sent - accounted) +
                                        " record(s) short of the " + std::to_string(sent) +
                                        " the controller sent"};
  }
  return {};
}

// The controller's tracking error of the run (docs/modbus.md), into the
// log's metadata: tracking_rms_rad_1..3, tracking_max_rad_1..3.
void add_tracking(ControllerLink& link, std::int64_t run_id, DeltaLog& log) {
  std::vector<std::uint16_t> in;
  try {
    in = link.inputs();
  } catch (const delta::InputError&) {
    return;  // the log is worth keeping without them
  }
  if (raw("tracking_run_id", in) != run_id || raw("tracking_ticks", in) == 0) return;
  for (const char* kind : {"rms", "max"}) {
    for (const char* j : {"1", "2", "3"}) {
      const std::string name = std::string("tracking_") + kind + "_" + j;
      log.metadata.emplace_back(std::string("tracking_") + kind + "_rad_" + j,
                                format_number(scaled(name.c_str(), in)));
    }
  }
}

RecordOptions record_options(const ExciteOptions& a, const std::vector<std::uint16_t>& in) {
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

int run_excite(const ExciteOptions& a, std::ostream& out, std::ostream& err) {
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
  if (run.ending.empty()) add_tracking(link, run.run_id, rec.log);
  const std::string path = run.ending.empty() ? a.out_path : delta::partial_log_path(a.out_path);
  write_recording(path, rec.log, a.raw_path, rec.raw);
  return report(a, run, rec, recording.expected(), rate_hz, path, out, err);
}

}  // namespace host_id
