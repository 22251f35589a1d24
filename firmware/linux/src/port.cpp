#include "fw_linux/port.hpp"

#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/timerfd.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <ostream>

#include "delta/can/cia402.hpp"
#include "delta/can/protocol.hpp"
#include "fw/controller.hpp"
#include "fw_linux/announcer.hpp"
#include "fw_linux/linux_hardware.hpp"
#include "fw_linux/monotonic_clock.hpp"
#include "fw_linux/run_coordinator.hpp"
#include "fw_linux/trajectories.hpp"

namespace fw_linux {

namespace p = delta::can::protocol;

namespace {

// Waits until the socket is readable or the absolute deadline passes.
bool wait_readable_until(int fd, std::uint64_t deadline_us) {
  const std::uint64_t now = monotonic_us();
  if (now >= deadline_us) return false;
  const std::uint64_t left = deadline_us - now;
  timespec ts{static_cast<time_t>(left / 1000000), static_cast<long>((left % 1000000) * 1000)};
  pollfd pfd{fd, POLLIN, 0};
  return ppoll(&pfd, 1, &ts, nullptr) > 0;
}

void drain(delta::can::Socket& socket, CanopenMaster& master) {
  while (auto r = socket.receive()) master.on_frame(*r, monotonic_us());
}

void set_realtime(int priority, std::ostream& out) {
  if (priority <= 0) return;
  sched_param sp{};
  sp.sched_priority = priority;
  if (pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp) != 0) {
    out << "delta_fw: warning: cannot use SCHED_FIFO priority " << priority
        << " (needs root or CAP_SYS_NICE); running without\n";
  }
  if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0) {
    out << "delta_fw: warning: mlockall failed: " << std::strerror(errno) << "\n";
  }
}

}  // namespace

bool send_log_frames(FrameSink& bus, const fw::LogRecord& r) {
  std::array<std::int32_t, 3> q{};
  std::array<std::int32_t, 3> tau{};
  for (unsigned j = 0; j < 3; ++j) {
    q[j] = static_cast<std::int32_t>(delta::fx::detail::shift_round(r.q_rad[j].raw(), 8));
    tau[j] = static_cast<std::int32_t>(delta::fx::detail::shift_round(r.tau_Nm[j].raw(), 3));
  }
  const p::LogPayloads payloads = p::pack_log(r.seq, r.stale, q, tau);
  const p::Message* messages[3] = {&p::kLogA, &p::kLogB, &p::kLogC};
  bool ok = true;
  for (unsigned i = 0; i < 3; ++i) {
    delta::can::Frame f;
    f.id = messages[i]->base_id;
    f.dlc = 8;
    f.data = payloads.data[i];
    ok = bus.send(f) && ok;
  }
  return ok;
}

int run_port(const PortConfig& config, const RunOptions& options, SafetyIo& io,
             const std::atomic<bool>& stop, std::ostream& out, CycleStats* stats_out) {
  // The trajectories are built and checked against the limits before
  // touching the bus (the check walks every tick: not in the loop).
  const fw::ControllerConfig core_config = controller_config(config);
  std::vector<NamedRun> runs;
  for (const std::string& name : options.trajectories) {
    auto t = named_trajectory(name, config);
    if (!t) {
      out << "delta_fw: unknown trajectory '" << name << "' (known:";
      for (const auto& n : trajectory_names()) out << " " << n;
      out << ")\n";
      return kExitUsage;
    }
    runs.push_back(
        {name, fw::CheckedTrajectory::check(core_config.geometry, *t, core_config.limits)});
    if (!runs.back().trajectory.ok()) {
      out << "delta_fw: trajectory '" << name
          << "' rejected: " << describe_check(runs.back().trajectory.result()) << "\n";
      return kExitRejected;
    }
  }

  // What the drives send: TPDO1/2, SDO responses, EMCY and heartbeats
  // (and error frames, which need no filter).
  delta::can::Socket socket =
      delta::can::Socket::open(options.iface,
                               {{p::kTpdo1.base_id, p::kFunctionCodeMask, false},
                                {p::kTpdo2.base_id, p::kFunctionCodeMask, false},
                                {p::kSdoTx.base_id, p::kFunctionCodeMask, false},
                                {p::kEmcy.base_id, p::kFunctionCodeMask, false},
                                {p::kHeartbeat.base_id, p::kFunctionCodeMask, false}},
                               1 << 20);
  SocketSink sink(socket);
  CanopenMaster master(config, sink);
  LinuxHardware hw(master, io, sink);
  if (options.panel != nullptr) hw.gate_log(&options.panel->log_enabled());
  fw::Controller<LinuxHardware> controller(hw, core_config);
  Announcer announcer(sink, config);
  RunCoordinator coordinator(std::move(runs), options.exit_when_done, options.panel, out);

  const bool realtime = config.mode == CycleMode::kRealTime;
  const std::uint64_t window_us =
      config.response_window_us != 0 ? config.response_window_us : config.period_us / 2;
  int timer = -1;
  std::uint64_t t0 = 0;
  if (realtime) {
    set_realtime(options.rt_priority, out);
    timer = timerfd_create(CLOCK_MONOTONIC, TFD_CLOEXEC);
    if (timer < 0) {
      out << "delta_fw: timerfd_create failed: " << std::strerror(errno) << "\n";
      return kExitCanError;
    }
    t0 = monotonic_us() + config.period_us;
    itimerspec spec{};
    spec.it_value = {static_cast<time_t>(t0 / 1000000), static_cast<long>(t0 % 1000000 * 1000)};
    spec.it_interval = {0, static_cast<long>(config.period_us) * 1000};
    if (config.period_us >= 1000000) spec.it_interval = {1, 0};
    timerfd_settime(timer, TFD_TIMER_ABSTIME, &spec, nullptr);
  }

  out << "delta_fw: " << options.iface << ", " << (realtime ? "real time" : "lock-step") << ", "
      << 1000000 / config.period_us << " Hz\n";
  CycleStats stats;
  // Wake-up latencies in 10 us bins up to 100 ms (the last bin holds the
  // rest): allocated once, so a long run never allocates in the loop.
  constexpr std::int64_t kBinUs = 10;
  std::vector<std::uint64_t> latency_bins(realtime ? 10001 : 0);
  std::uint64_t latency_count = 0;
  std::uint64_t expirations = 0;
  double latency_sum = 0;
  const std::uint64_t wall_start = monotonic_us();
  int exit_code = -1;
  while (!stop.load() && exit_code < 0) {
    std::uint64_t tick_us = monotonic_us();
    if (realtime) {
      std::uint64_t n = 0;
      if (read(timer, &n, sizeof n) != static_cast<ssize_t>(sizeof n)) continue;
      expirations += n;
      stats.overruns += n - 1;
      const std::uint64_t now = monotonic_us();
      tick_us = t0 + (expirations - 1) * config.period_us;
      const auto latency = static_cast<std::int64_t>(now - tick_us);
      ++latency_bins[static_cast<std::size_t>(
          std::min<std::int64_t>(std::max<std::int64_t>(latency, 0) / kBinUs, 10000))];
      ++latency_count;
      latency_sum += static_cast<double>(latency);
      stats.latency_max_us = std::max(stats.latency_max_us, latency);
    }
    drain(socket, master);  // whatever came after the last window is late
    master.begin_cycle(monotonic_us());
    std::uint64_t deadline =
        realtime ? tick_us + window_us : monotonic_us() + config.lockstep_timeout_ms * 1000ull;
    if (!realtime && master.sdo_deadline_us() != 0) {
      deadline = std::min(deadline, master.sdo_deadline_us());
    }
    while (!master.exchange_complete()) {
      if (!wait_readable_until(socket.fd(), deadline)) break;
      drain(socket, master);
    }
    master.end_window();

    const std::uint64_t step_start = monotonic_us();
    controller.step();
    master.send_commands();
    stats.step_max_us =
        std::max(stats.step_max_us, static_cast<std::int64_t>(monotonic_us() - step_start));
    announcer.after_step(controller.fault(), controller.cycles());
    ++stats.cycles;

    coordinator.after_step(controller, hw, master);
    if (const auto code = coordinator.exit_code()) exit_code = *code;
    if (options.max_cycles != 0 && stats.cycles >= options.max_cycles) {
      exit_code = controller.state() == fw::State::kFault ? kExitFault : kExitDone;
    }
  }
  if (exit_code < 0) {
    // Stopped by a signal: a fault stays a fault; unfinished runs are not done.
    exit_code = controller.state() == fw::State::kFault ? kExitFault
                : coordinator.unfinished()              ? kExitStopped
                                                        : kExitDone;
  }
  // Whatever ended the loop, the drives are left disabled (controlword 0,
  // no torque) and the safety outputs off: nothing keeps running after us.
  master.enable_drives(false);
  master.send_commands();
  master.leave_network();
  io.set_outputs(fw::SafetyOutputs{});
  if (timer >= 0) close(timer);

  stats.wall_s = static_cast<double>(monotonic_us() - wall_start) * 1e-6;
  stats.simulated_s = static_cast<double>(stats.cycles) * config.period_us * 1e-6;
  stats.late_frames = master.late_frames();
  stats.stale_log_records = controller.stale_log_records();
  stats.send_failures = sink.failures();
  if (latency_count != 0) {
    std::uint64_t below = 0;
    std::size_t bin = 0;
    while (bin + 1 < latency_bins.size() &&
           (below += latency_bins[bin]) < latency_count * 99 / 100) {
      ++bin;
    }
    stats.latency_p99_us = static_cast<std::int64_t>(bin + 1) * kBinUs;  // upper edge of the bin
    stats.latency_mean_us = latency_sum / static_cast<double>(latency_count);
  }
  out << "delta_fw: " << stats.cycles << " cycles in " << stats.wall_s << " s ("
      << stats.simulated_s << " s of bus time); step max " << stats.step_max_us
      << " us; late frames " << stats.late_frames << "; log records marked stale "
      << stats.stale_log_records << "; send failures " << stats.send_failures;
  if (realtime) {
    out << "; wake-up latency mean " << stats.latency_mean_us << " us, p99 " << stats.latency_p99_us
        << " us, max " << stats.latency_max_us << " us; overruns " << stats.overruns;
  }
  out << "\n";
  if (stats_out != nullptr) *stats_out = stats;
  return exit_code;
}

}  // namespace fw_linux
