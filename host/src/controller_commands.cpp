#include "host_id/controller_commands.hpp"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <future>
#include <iomanip>
#include <ostream>
#include <sstream>
#include <thread>

#include "delta/controller/vocabulary.hpp"
#include "host_id/atomic_file.hpp"
#include "host_id/controller_link.hpp"
#include "host_id/delta_log.hpp"
#include "host_id/options.hpp"
#include "host_id/recorder.hpp"

namespace host_id {

namespace mb = delta::modbus;

namespace {

constexpr const char* kStatusHelp = R"(usage: host_id status --modbus HOST:PORT [--json]

Reads the controller's state over Modbus TCP (docs/modbus.md): firmware
and register map versions, state and fault, the fault history, the run,
the safety lines, the settings, the live joint angles and torques, and the
geometry.
)";

constexpr const char* kExciteHelp =
    R"(usage: host_id excite --modbus HOST:PORT --trajectory NAME --can IFACE -o LOG.csv [options]

Selects and starts an excitation trajectory on the controller over Modbus,
records its CAN log frames meanwhile (as host_id record), and stops when
the controller reports the run finished. The log's geometry and sample
rate come from the controller.
  --trajectory NAME     path1, path2 or pick-and-place
options:
  --amplitude-scale X   the trajectory's amplitude, 0.001-2 (1)
  --repetitions N       Fourier periods or pick-and-place cycles, 1-100
                        (default: the trajectory's own, 2 or 3)
  --raw FILE.log        also write every CAN frame of the session (candump -L)
  --rated-current-A A   the drives' rated current, for the i1..i3 columns (2)
  --timeout S           give up when the run has not finished after S seconds
                        (default: the run's length plus 30 s)
On a fault, a stop from elsewhere, a lost connection or Ctrl-C (which stops
the run), it keeps what it recorded as LOG.partial.csv and exits 4.
Exit status: 0 finished, 1 error, 2 usage, 3 samples lost, 4 run not finished.
)";

std::atomic<bool> g_interrupted{false};
void on_interrupt(int) {
  g_interrupted.store(true);
}

std::string fault_text(std::int64_t code) {
  return std::to_string(code) + " (" +
         delta::controller::fault_name(static_cast<delta::controller::Fault>(code)) + ")";
}

std::string state_text(std::int64_t s) {
  return delta::controller::state_name(static_cast<delta::controller::State>(s));
}

const char* run_result_text(std::int64_t r) {
  switch (static_cast<mb::RunResult>(r)) {
    case mb::RunResult::kNone:
      return "none yet";
    case mb::RunResult::kRunning:
      return "running";
    case mb::RunResult::kFinished:
      return "finished";
    case mb::RunResult::kStopped:
      return "stopped";
    case mb::RunResult::kFaulted:
      return "ended by a fault";
  }
  return "unknown";
}

std::string trajectory_name(std::int64_t id) {
  return id >= 0 && static_cast<std::size_t>(id) < mb::kTrajectoryNames.size()
             ? mb::kTrajectoryNames[static_cast<std::size_t>(id)]
             : "#" + std::to_string(id);
}

double metres(const char* name, const std::vector<std::uint16_t>& in) {
  return scaled(mb::named(name), in);
}

}  // namespace

std::string partial_log_path(const std::string& path) {
  const auto slash = path.find_last_of('/');
  const auto dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash) ||
      dot == (slash == std::string::npos ? 0 : slash + 1)) {
    return path + ".partial";
  }
  return path.substr(0, dot) + ".partial" + path.substr(dot);
}

int cmd_status(const std::vector<std::string>& args, std::ostream& out, std::ostream&) {
  if (wants_help(args)) {
    out << kStatusHelp;
    return 0;
  }
  const ParsedOptions o("status", {{"--modbus"}, {"--json", false}}, args);
  if (!o.positional().empty()) {
    throw UsageError("status: unexpected argument '" + o.positional()[0] + "'");
  }
  const auto address = o.value("--modbus");
  if (!address) throw UsageError("status: --modbus HOST:PORT is required");
  ControllerLink link(*address);
  const std::vector<std::uint16_t> in = link.inputs();
  const std::vector<std::uint16_t> hold = link.holding();
  const auto r = [&](const char* name) { return raw(name, in); };
  const std::int64_t io = r("io");
  if (o.flag("--json")) {
    out << "{";
    bool first = true;
    for (const mb::Register& reg : mb::kRegisters) {
      const auto& table = reg.table == mb::Table::kInput ? in : hold;
      out << (first ? "" : ",") << "\n  \"" << reg.name << "\": " << mb::decode(reg, table.data());
      first = false;
    }
    out << "\n}\n";
    return 0;
  }
  out << std::fixed;
  out << "controller " << link.address() << ": firmware " << r("firmware_version_major") << "."
      << r("firmware_version_minor") << "." << r("firmware_version_patch") << ", register map "
      << r("protocol_version") << "\n";
  out << "  state      " << state_text(r("state"));
  if (r("fault_code") != 0) out << ", fault " << fault_text(r("fault_code"));
  out << "\n  cycle      " << r("cycle_counter") << " (period " << r("period_us") << " us)\n";
  out << "  safety     e-stop " << ((io & mb::kIoEStopOpen) ? "OPEN" : "closed") << ", drives "
      << ((io & mb::kIoDriveEnable) ? "enabled" : "disabled") << ", brake "
      << ((io & mb::kIoBrakeReleased) ? "released" : "engaged") << ", status "
      << ((io & mb::kIoStatusOk) ? "ok" : "fault") << ", log frames "
      << ((io & mb::kIoLogEnabled) ? "on" : "off") << "\n";
  out << "  run        ";
  if (r("run_id") == 0) {
    out << "none since start";
  } else {
    out << "#" << r("run_id") << " " << run_result_text(r("run_result")) << ", tick "
        << r("run_tick") << " of " << r("run_length");
  }
  out << "; " << r("log_records") << " log records sent";
  if (r("stale_log_records") != 0) out << " (" << r("stale_log_records") << " marked stale)";
  out << "\n";
  const std::int64_t reps = hold[mb::kRepetitions.address];
  out << "  settings   trajectory " << trajectory_name(hold[mb::kTrajectory.address])
      << ", amplitude " << std::setprecision(1) << hold[mb::kAmplitudeScale.address] / 10.0
      << " %, repetitions " << (reps == 0 ? std::string("preset") : std::to_string(reps)) << "\n";
  out << std::setprecision(4) << "  q          " << metres("q1", in) << " " << metres("q2", in)
      << " " << metres("q3", in) << " rad\n";
  out << "  tau        " << metres("tau1", in) << " " << metres("tau2", in) << " "
      << metres("tau3", in) << " N m (last run)\n";
  out << "  faults     " << r("fault_count") << " since start";
  for (unsigned k = 0; k < mb::kFaultHistoryLength; ++k) {
    const std::int64_t code = mb::decode(mb::fault_history_code(k), in.data());
    if (code == 0) break;
    const std::int64_t cycle = mb::decode(mb::fault_history_cycle(k), in.data());
    out << (k == 0 ? ": " : "; ") << fault_text(code) << " at cycle " << cycle;
  }
  out << "\n  geometry   upper arm " << metres("upper_arm_length", in) << " m, forearm "
      << metres("forearm_length", in) << " m, base radius " << metres("base_radius", in)
      << " m, platform radius " << metres("platform_radius", in) << " m\n";
  if (r("last_rejection") != 0) {
    const mb::Register* reg =
        mb::find(mb::Table::kHolding, static_cast<std::uint16_t>(r("last_rejection_register")));
    out << "  refused    last: " << mb::describe(static_cast<mb::Rejection>(r("last_rejection")))
        << " (register " << (reg ? reg->name : "?") << ")\n";
  }
  return 0;
}

int cmd_excite(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  if (wants_help(args)) {
    out << kExciteHelp;
    return 0;
  }
  const ParsedOptions o("excite",
                        {{"--modbus"},
                         {"--trajectory"},
                         {"--can"},
                         {"--out", true, false, "-o"},
                         {"--amplitude-scale"},
                         {"--repetitions"},
                         {"--raw"},
                         {"--rated-current-A"},
                         {"--timeout"}},
                        args);
  if (!o.positional().empty()) {
    throw UsageError("excite: unexpected argument '" + o.positional()[0] + "'");
  }
  const auto need = [&](const char* name, const char* what) {
    const auto v = o.value(name);
    if (!v || v->empty())
      throw UsageError(std::string("excite: ") + name + " " + what + " is required");
    return *v;
  };
  const std::string address = need("--modbus", "HOST:PORT");
  const std::string trajectory = need("--trajectory", "NAME");
  const std::string iface = need("--can", "IFACE");
  const std::string out_path = need("--out", "LOG.csv");
  std::size_t id = 0;
  while (id < mb::kTrajectoryNames.size() && trajectory != mb::kTrajectoryNames[id]) ++id;
  if (id == mb::kTrajectoryNames.size()) {
    throw UsageError("excite: unknown trajectory '" + trajectory +
                     "' (known: path1, path2, pick-and-place)");
  }
  const double scale = o.number("--amplitude-scale", 1.0);
  const long permille = std::lround(scale * 1000);
  if (!(permille >= mb::kMinAmplitudeScale && permille <= mb::kMaxAmplitudeScale)) {
    throw UsageError("excite: --amplitude-scale must be from 0.001 to 2, got " +
                     o.value("--amplitude-scale").value_or(""));
  }
  const auto repetitions = static_cast<std::uint16_t>(o.whole("--repetitions", 0, 1, 100));
  const double timeout_option = o.number("--timeout", 0);

  ControllerLink link(address);
  std::vector<std::uint16_t> in = link.inputs();
  const auto state = raw("state", in);
  if (state == static_cast<int>(delta::controller::State::kFault)) {
    throw delta::InputError("excite: the controller at " + address + " is in fault " +
                            fault_text(raw("fault_code", in)) +
                            "; clear the cause and reset it (Modbus command 3) first");
  }
  if (state != static_cast<int>(delta::controller::State::kReady)) {
    throw delta::InputError("excite: the controller at " + address + " is " + state_text(state) +
                            ", not ready");
  }
  // The settings in one write: trajectory, amplitude, repetitions, log on.
  link.write(mb::kTrajectory.address, {static_cast<std::uint16_t>(id),
                                       static_cast<std::uint16_t>(permille), repetitions, 1});

  const double rate_hz = 1e6 / static_cast<double>(raw("period_us", in));
  RecordOptions ro;
  ro.iface = iface;
  ro.out_path = out_path;
  ro.raw_path = o.value("--raw");
  ro.sample_rate_hz = rate_hz;
  ro.rated_current_A = o.number("--rated-current-A", ro.rated_current_A);
  if (!(ro.rated_current_A > 0)) throw UsageError("excite: --rated-current-A must be positive");
  ro.geometry = {metres("upper_arm_length", in), metres("forearm_length", in),
                 metres("base_radius", in), metres("platform_radius", in)};
  std::atomic<bool> finish{false};
  std::atomic<std::uint64_t> expected{UINT64_MAX};
  ro.keep_going = [&](std::uint64_t records) {
    return !finish.load() && records < expected.load();
  };
  std::promise<void> listening;
  auto recording =
      std::async(std::launch::async, [&] { return capture(ro, [&] { listening.set_value(); }); });
  // Wait for the socket (or the recorder's failure to open it).
  if (listening.get_future().wait_for(std::chrono::seconds(10)) != std::future_status::ready) {
    finish.store(true);
  }
  if (recording.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
    recording.get();  // rethrows the recorder's error
  }

  const std::uint64_t records_before = static_cast<std::uint64_t>(raw("log_records", in));
  const auto previous_handler = std::signal(SIGINT, on_interrupt);
  g_interrupted.store(false);
  std::string ending;  // empty: finished
  std::int64_t run_id = 0;
  std::int64_t run_length = 0;
  try {
    link.write(mb::kCommand.address, {static_cast<std::uint16_t>(mb::Command::kStart)});
    in = link.inputs();
    run_id = raw("run_id", in);
    run_length = raw("run_length", in);
    err << "host_id excite: running " << trajectory << " on " << address << " (run #" << run_id
        << ", " << static_cast<double>(run_length) / rate_hz << " s), recording " << iface << "\n";
    const double timeout_s =
        timeout_option > 0 ? timeout_option : static_cast<double>(run_length) / rate_hz + 30.0;
    const auto deadline =
        std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    const bool tty = isatty(STDERR_FILENO) != 0;
    for (;;) {
      if (g_interrupted.load()) {
        link.write(mb::kCommand.address, {static_cast<std::uint16_t>(mb::Command::kStop)});
        ending = "interrupted (Ctrl-C); the run was stopped";
        break;
      }
      in = link.inputs();
      if (raw("run_id", in) != run_id) {
        ending = "another client started run #" + std::to_string(raw("run_id", in));
        break;
      }
      const auto result = static_cast<mb::RunResult>(raw("run_result", in));
      if (result == mb::RunResult::kFinished) break;
      if (result == mb::RunResult::kFaulted) {
        ending = "the controller faulted: fault " + fault_text(raw("fault_code", in)) +
                 " at cycle " + std::to_string(raw("fault_history_0_cycle", in));
        break;
      }
      if (result == mb::RunResult::kStopped) {
        ending = "the run was stopped by another client";
        break;
      }
      if (std::chrono::steady_clock::now() > deadline) {
        link.write(mb::kCommand.address, {static_cast<std::uint16_t>(mb::Command::kStop)});
        ending = "the run did not finish within " + std::to_string(timeout_s) + " s; stopped it";
        break;
      }
      if (tty) {
        err << "\rhost_id excite: tick " << raw("run_tick", in) << " / " << run_length << "   "
            << std::flush;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));  // the poll period
    }
    if (tty) err << "\r" << std::string(50, ' ') << "\r";
  } catch (const delta::InputError& e) {
    ending = std::string("lost the controller: ") + e.what();
  }
  std::signal(SIGINT, previous_handler);

  // The recorder has all the run's records once it holds as many samples
  // as the controller sent; it gives up 2 s after the end.
  if (ending.empty()) {
    try {
      expected.store(static_cast<std::uint64_t>(raw("log_records", link.inputs())) -
                     records_before);
    } catch (const delta::InputError&) {
    }
  }
  if (recording.wait_for(std::chrono::seconds(2)) != std::future_status::ready) finish.store(true);
  Recording rec;
  try {
    rec = recording.get();
  } catch (const delta::InputError& e) {
    if (!ending.empty()) {
      throw delta::InputError("excite: " + ending +
                              "; no log sample was recorded, nothing written");
    }
    throw;
  }
  rec.log.metadata.emplace_back("trajectory", trajectory);
  const std::string path = ending.empty() ? out_path : partial_log_path(out_path);
  write_file_atomically(path, format_delta_log(rec.log));
  if (ro.raw_path) write_file_atomically(*ro.raw_path, rec.raw);

  const std::uint64_t sent = expected.load();
  out << "host_id excite: " << trajectory << " (run #" << run_id << ") "
      << (ending.empty() ? "finished" : "NOT finished") << "\n"
      << "  samples   " << rec.summary.samples << " recorded";
  if (sent != UINT64_MAX) out << " of " << sent << " sent";
  out << ", " << rec.summary.lost << " lost, " << rec.summary.stale << " stale left out, "
      << static_cast<double>(rec.log.t.size()) / rate_hz << " s at " << rate_hz << " Hz\n"
      << "  log       " << path << "\n";
  if (ro.raw_path) out << "  raw       " << *ro.raw_path << "\n";
  report_left_out(err, "host_id excite", rec.summary);
  if (!ending.empty()) {
    err << "host_id excite: " << ending << "; the partial log is " << path << "\n";
    return 4;
  }
  if (rec.summary.lost > 0 ||
      (sent != UINT64_MAX && rec.summary.samples + rec.summary.stale < sent)) {
    err << "host_id excite: samples were lost; the log keeps them as gaps in seq\n";
    return 3;
  }
  return 0;
}

}  // namespace host_id
