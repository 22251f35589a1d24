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
#include <charconv>
#include <cstring>
#include <optional>
#include <ostream>

#include "delta/can/cia402.hpp"
#include "delta/can/protocol.hpp"
#include "delta/monotonic_clock.hpp"
#include "fw/controller.hpp"
#include "fw_linux/collision_setting.hpp"
#include "fw_linux/controller_node.hpp"
#include "fw_linux/drive_plan.hpp"
#include "fw_linux/linux_hardware.hpp"
#include "fw_linux/run_coordinator.hpp"
#include "fw_linux/trajectories.hpp"

namespace fw_linux {

namespace p = delta::can::protocol;
using delta::monotonic_us;

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

// Frames to the controller's own node (NMT, its SDO requests) go there;
// the rest (the drives') to the master.
void drain(delta::can::Socket& socket, CanopenMaster& master, ControllerNode& node) {
  const std::uint32_t own_sdo = p::cob_id(p::kSdoRx, p::kControllerNode);
  while (auto r = socket.receive()) {
    const bool own = !r->error && (r->frame.id == p::cob_id(p::kNmt, 0) || r->frame.id == own_sdo);
    if (own) {
      node.on_frame(r->frame, monotonic_us());
    } else {
      master.on_frame(*r, monotonic_us());
    }
  }
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

p::LogPayloads log_payloads(const fw::LogRecord& r) {
  std::array<std::int32_t, 3> q{};
  std::array<std::int32_t, 3> tau{};
  for (unsigned j = 0; j < 3; ++j) {
    q[j] = static_cast<std::int32_t>(delta::fx::shift_round(r.q_rad[j].raw(), 8));
    tau[j] = static_cast<std::int32_t>(delta::fx::shift_round(r.tau_Nm[j].raw(), 3));
  }
  return p::pack_log(r.seq, r.stale, q, tau);
}

p::ArmLogPayloads arm_log_payloads(const fw::LogRecord& r) {
  std::array<std::int32_t, 3> qa{};
  for (unsigned j = 0; j < 3; ++j)
    qa[j] = static_cast<std::int32_t>(delta::fx::shift_round(r.qa_rad[j].raw(), 8));
  return p::pack_arm_log(r.seq, r.stale, qa);
}

namespace {

// Frames of the messages with the payloads, in order; false if any send failed.
template <std::size_t N>
bool send_frames(FrameSink& bus, const std::array<const p::Message*, N>& messages,
                 const std::array<std::array<std::uint8_t, 8>, N>& payloads) {
  bool ok = true;
  for (std::size_t i = 0; i < N; ++i) {
    delta::can::Frame f;
    f.id = messages[i]->base_id;
    f.dlc = messages[i]->dlc;
    f.data = payloads[i];
    ok = bus.send(f) && ok;
  }
  return ok;
}

}  // namespace

bool send_arm_log_frames(FrameSink& bus, const p::ArmLogPayloads& payloads) {
  return send_frames<2>(bus, {&p::kLogD, &p::kLogE}, payloads.data);
}

bool send_log_frames(FrameSink& bus, const p::LogPayloads& payloads) {
  return send_frames<3>(bus, {&p::kLogA, &p::kLogB, &p::kLogC}, payloads.data);
}

namespace {

// The command line's trajectories, built and checked against the limits
// before the bus is touched (the check walks every tick: not in the loop);
// or the exit code when one is unknown or breaks a limit.
std::optional<int> checked_runs(const PortConfig& config, const fw::ControllerConfig& core,
                                const RunOptions& options, std::vector<NamedRun>& runs,
                                std::ostream& out) {
  for (const std::string& given : options.trajectories) {
    // NAME or NAME:REPETITIONS (Fourier periods or pick-and-place cycles),
    // as the Modbus register `repetitions` gives them.
    const std::size_t colon = given.find(':');
    const std::string name = given.substr(0, colon);
    TrajectoryParams params;
    if (colon != std::string::npos) {
      const std::string count = given.substr(colon + 1);
      unsigned long n = 0;
      const auto [end, ec] = std::from_chars(count.data(), count.data() + count.size(), n);
      if (ec != std::errc{} || end != count.data() + count.size() || n < 1 || n > 65535) {
        out << "delta_fw: --run " << given
            << ": the repetitions after ':' must be a whole number from 1 to 65535\n";
        return kExitUsage;
      }
      params.repetitions = static_cast<std::uint16_t>(n);
    }
    auto t = named_trajectory(name, config, params);
    if (!t) {
      out << "delta_fw: unknown trajectory '" << name << "' (known:";
      for (const auto& n : trajectory_names()) out << " " << n;
      out << ")\n";
      return kExitUsage;
    }
    runs.push_back({name, fw::CheckedTrajectory::check(fw::trajectory_bounds(core), *t)});
    if (!runs.back().trajectory.ok()) {
      out << "delta_fw: trajectory '" << name
          << "' rejected: " << describe_check(runs.back().trajectory.result()) << "\n";
      return kExitRejected;
    }
  }
  return std::nullopt;
}

// What the drives send: the TPDOs their plans use (each by its COB-ID: a
// drive's fixed PDO may have one outside CiA 301's predefined set), SDO
// responses, EMCY and heartbeats (and error frames, which need no filter).
delta::can::Socket open_drive_socket(const std::string& iface, const PortConfig& config) {
  std::vector<delta::can::Filter> filters{
      {p::kSdoTx.base_id, p::kFunctionCodeMask, false},
      {p::kEmcy.base_id, p::kFunctionCodeMask, false},
      {p::kHeartbeat.base_id, p::kFunctionCodeMask, false},
      // and what comes to the controller's own node
      {p::cob_id(p::kNmt, 0), p::kStandardIdMask, false},
      {p::cob_id(p::kSdoRx, p::kControllerNode), p::kStandardIdMask, false}};
  for (const DrivePlan& plan : plan_drives(config).drives) {
    for (const PlannedPdo* pdo : plan.tpdos()) {
      if (pdo->used)
        filters.push_back({pdo->cob_id & p::kStandardIdMask, p::kStandardIdMask, false});
    }
  }
  return delta::can::Socket::open(iface, filters, 1 << 20);
}

// The real-time tick: a timerfd every period, and the wake-up latencies in
// 10 us bins up to 100 ms (the last bin holds the rest), allocated once so
// that a long run never allocates in the loop.
class CycleTimer {
 public:
  static constexpr std::int64_t kBinUs = 10;
  CycleTimer() : bins_(10001) {}
  CycleTimer(const CycleTimer&) = delete;
  CycleTimer& operator=(const CycleTimer&) = delete;
  ~CycleTimer() {
    if (fd_ >= 0) close(fd_);
  }
  bool start(std::uint32_t period_us, std::ostream& out) {
    period_us_ = period_us;
    fd_ = timerfd_create(CLOCK_MONOTONIC, TFD_CLOEXEC);
    if (fd_ < 0) {
      out << "delta_fw: timerfd_create failed: " << std::strerror(errno) << "\n";
      return false;
    }
    t0_ = monotonic_us() + period_us;
    itimerspec spec{};
    spec.it_value = {static_cast<time_t>(t0_ / 1000000), static_cast<long>(t0_ % 1000000 * 1000)};
    spec.it_interval = {0, static_cast<long>(period_us) * 1000};
    if (period_us >= 1000000) spec.it_interval = {1, 0};
    timerfd_settime(fd_, TFD_TIMER_ABSTIME, &spec, nullptr);
    return true;
  }
  // The next tick's time, once it has come (nothing when the read failed).
  std::optional<std::uint64_t> wait(CycleStats& stats) {
    std::uint64_t n = 0;
    if (read(fd_, &n, sizeof n) != static_cast<ssize_t>(sizeof n)) return std::nullopt;
    expirations_ += n;
    stats.overruns += n - 1;
    const std::uint64_t now = monotonic_us();
    const std::uint64_t tick_us = t0_ + (expirations_ - 1) * period_us_;
    const auto latency = static_cast<std::int64_t>(now - tick_us);
    ++bins_[static_cast<std::size_t>(
        std::min<std::int64_t>(std::max<std::int64_t>(latency, 0) / kBinUs, 10000))];
    ++count_;
    sum_ += static_cast<double>(latency);
    stats.latency_max_us = std::max(stats.latency_max_us, latency);
    return tick_us;
  }
  void summarise(CycleStats& stats) const {
    if (count_ == 0) return;
    std::uint64_t below = 0;
    std::size_t bin = 0;
    while (bin + 1 < bins_.size() && (below += bins_[bin]) < count_ * 99 / 100) ++bin;
    stats.latency_p99_us = static_cast<std::int64_t>(bin + 1) * kBinUs;  // upper edge of the bin
    stats.latency_mean_us = sum_ / static_cast<double>(count_);
  }

 private:
  int fd_{-1};
  std::uint32_t period_us_{0};
  std::uint64_t t0_{0};
  std::uint64_t expirations_{0};
  std::vector<std::uint64_t> bins_;
  std::uint64_t count_{0};
  double sum_{0};
};

// The controller and everything it is wired to, for one run of the loop.
struct Loop {
  Loop(const PortConfig& config, const RunOptions& options, SafetyIo& io,
       const fw::ControllerConfig& core, FeedForwardSlot& slot, std::vector<NamedRun> runs,
       std::ostream& out)
      : socket(open_drive_socket(options.iface, config)),
        sink(socket),
        master(config, sink),
        hw(master, io, sink),
        controller(hw, core),
        program(options.supervision, controller_identity(options.program.version)),
        feed_forward(slot),
        node(sink, config, options.program.version, program, feed_forward),
        coordinator(std::move(runs), options.exit_when_done, options.panel, out) {
    if (options.panel != nullptr) hw.gate_log(&options.panel->log_enabled());
    hw.gate_pdos(&node);
    feed_forward.set_apply(
        [this, &config, &out](const fw::FeedForwardConfig& f,
                              const std::optional<fw::CollisionThresholds>& thresholds) {
          return apply_model(config, f, thresholds, out);
        });
    feed_forward.set_check([&config](const fw::FeedForwardConfig& f,
                                     const std::optional<fw::CollisionThresholds>& thresholds) {
      return collision_check(config, f, thresholds);
    });
    feed_forward.set_report([&out, iface = options.iface](const std::string& what) {
      out << "delta_fw: " << what << ", on " << iface << "\n";
    });
    coordinator.set_feed_forward_slot(&feed_forward);
  }
  // A model (or feed-forward mode) set over the bus, with the detector's
  // settings that go with it: false where a run is on.
  bool apply_model(const PortConfig& config, const fw::FeedForwardConfig& f,
                   const std::optional<fw::CollisionThresholds>& thresholds, std::ostream& out) {
    const auto s = fw_linux::apply_model(controller, config, f, thresholds);
    if (s) out << "delta_fw: " << describe_collision(*s) << "\n";
    if (s && !describe_deflection(f).empty()) out << "delta_fw: " << describe_deflection(f) << "\n";
    return s.has_value();
  }
  delta::can::Socket socket;
  SocketSink sink;
  CanopenMaster master;
  LinuxHardware hw;
  fw::Controller<LinuxHardware> controller;
  ProgramDownload program;
  FeedForwardSlot& feed_forward;
  ControllerNode node;
  RunCoordinator coordinator;
};

// One cycle's exchange: late frames, SYNC, the TPDOs until all came or the
// deadline passed, end of the window. In real time the deadline is the
// tick's window; in lock-step it is the timeout from now (or a pending SDO
// request's, if sooner).
void exchange(Loop& l, std::optional<std::uint64_t> window_end_us,
              std::uint64_t lockstep_timeout_us) {
  drain(l.socket, l.master, l.node);  // whatever came after the last window is late
  l.master.begin_cycle(monotonic_us());
  std::uint64_t deadline_us = window_end_us ? *window_end_us : monotonic_us() + lockstep_timeout_us;
  if (!window_end_us && l.master.sdo_deadline_us() != 0) {
    deadline_us = std::min(deadline_us, l.master.sdo_deadline_us());
  }
  while (!l.master.exchange_complete()) {
    if (!wait_readable_until(l.socket.fd(), deadline_us)) break;
    drain(l.socket, l.master, l.node);
  }
  l.master.end_window();
}

// Whatever ended the loop, the drives are left disabled (controlword 0, no
// torque) and the safety outputs off: nothing keeps running after us.
void shut_down(Loop& l, SafetyIo& io) {
  l.master.enable_drives(false);
  l.master.send_commands();
  l.master.leave_network();
  io.set_outputs(fw::SafetyOutputs{});
}

void report(const CycleStats& stats, bool realtime, std::ostream& out) {
  out << "delta_fw: " << stats.cycles << " cycles in " << stats.wall_s << " s ("
      << stats.simulated_s << " s of bus time); step max " << stats.step_max_us
      << " us; late frames " << stats.late_frames << "; log records marked stale "
      << stats.stale_log_records << "; send failures " << stats.send_failures;
  if (realtime) {
    out << "; wake-up latency mean " << stats.latency_mean_us << " us, p99 " << stats.latency_p99_us
        << " us, max " << stats.latency_max_us << " us; overruns " << stats.overruns;
  }
  out << "\n";
}

// What runs, where and how fast, and with which feed-forward.
void announce(const PortConfig& config, const RunOptions& options,
              const FeedForwardSlot& feed_forward, const CollisionSetting& collision, bool realtime,
              std::ostream& out) {
  out << "delta_fw: " << options.iface << ", " << (realtime ? "real time" : "lock-step") << ", "
      << 1000000 / config.period_us << " Hz\n";
  if (config.robot) out << "delta_fw: " << describe_robot(config) << "\n";
  if (feed_forward.startup_note().empty()) {
    out << "delta_fw: " << describe_feed_forward(config) << "\n";
  } else {
    out << "delta_fw: feed-forward: " << feed_forward.startup_note() << "\n";
    const std::string deflection = describe_deflection(feed_forward.current());
    if (!deflection.empty()) out << "delta_fw: " << deflection << "\n";
  }
  out << "delta_fw: " << describe_collision(collision) << "\n";
}

// The control step after the cycle's exchange: the controller's step, its
// commands sent, the controller node and the run coordinator told.
void step(Loop& l, CycleStats& stats) {
  const std::uint64_t step_start = monotonic_us();
  l.controller.step();
  l.master.send_commands();
  stats.step_max_us =
      std::max(stats.step_max_us, static_cast<std::int64_t>(monotonic_us() - step_start));
  l.node.after_step(step_report(l.controller.state(), l.controller.fault(), l.controller.cycles(),
                                l.hw.last_outputs(), &l.controller.collision()),
                    monotonic_us());
  ++stats.cycles;
  l.coordinator.after_step(l.controller, l.hw, l.master);
}

// Stopped by a signal: a fault stays a fault; unfinished runs are not done.
int exit_code_when_stopped(const Loop& l) {
  return l.controller.state() == fw::State::kFault ? kExitFault
         : l.coordinator.unfinished()              ? kExitStopped
                                                   : kExitDone;
}

// The loop's statistics once it ended.
void finish_stats(const Loop& l, const PortConfig& config, std::uint64_t wall_start,
                  const CycleTimer& timer, CycleStats& stats) {
  stats.wall_s = static_cast<double>(monotonic_us() - wall_start) * 1e-6;
  stats.simulated_s = static_cast<double>(stats.cycles) * config.period_us * 1e-6;
  stats.late_frames = l.master.late_frames();
  stats.stale_log_records = l.controller.stale_log_records();
  stats.send_failures = l.sink.failures();
  timer.summarise(stats);
}

}  // namespace

namespace {

CollisionSetting collision_for(const PortConfig& config, const FeedForwardSlot& slot) {
  return collision_setting(config, slot.current().mode == fw::FeedForwardMode::kModel,
                           slot.thresholds(), slot.fit_id());
}

}  // namespace

CollisionSetting collision_at_start(const PortConfig& config) {
  return collision_for(config, FeedForwardSlot(config, controller_config(config)));
}

int run_port(const PortConfig& config, const RunOptions& options, SafetyIo& io,
             const std::atomic<bool>& stop, std::ostream& out, CycleStats* stats_out) {
  fw::ControllerConfig core = controller_config(config);
  // The feed-forward: the configuration's, or a model loaded over the bus
  // before a restart.
  FeedForwardSlot feed_forward(config, core);
  core.feed_forward = feed_forward.current();
  const CollisionSetting collision = collision_for(config, feed_forward);
  if (!collision.problem.empty()) {
    out << "delta_fw: " << collision.problem << "\n";
    return kExitUsage;
  }
  core.collision = collision.config;
  std::vector<NamedRun> runs;
  if (const auto refused = checked_runs(config, core, options, runs, out)) return *refused;
  Loop l(config, options, io, core, feed_forward, std::move(runs), out);
  const bool realtime = config.mode == CycleMode::kRealTime;
  const std::uint64_t window_us =
      config.response_window_us != 0 ? config.response_window_us : config.period_us / 2;
  CycleTimer timer;
  if (realtime) {
    set_realtime(options.rt_priority, out);
    if (!timer.start(config.period_us, out)) return kExitCanError;
  }
  announce(config, options, feed_forward, collision, realtime, out);
  CycleStats stats;
  const std::uint64_t wall_start = monotonic_us();
  int exit_code = -1;
  while (!stop.load() && exit_code < 0) {
    std::optional<std::uint64_t> window_end_us;
    if (realtime) {
      const auto tick_us = timer.wait(stats);
      if (!tick_us) continue;
      window_end_us = *tick_us + window_us;
    }
    exchange(l, window_end_us, config.lockstep_timeout_ms * 1000ull);
    step(l, stats);
    if (const auto code = l.coordinator.exit_code()) exit_code = *code;
    if (options.max_cycles != 0 && stats.cycles >= options.max_cycles) {
      exit_code = l.controller.state() == fw::State::kFault ? kExitFault : kExitDone;
    }
  }
  if (exit_code < 0) exit_code = exit_code_when_stopped(l);
  shut_down(l, io);
  finish_stats(l, config, wall_start, timer, stats);
  report(stats, realtime, out);
  if (stats_out != nullptr) *stats_out = stats;
  return exit_code;
}

}  // namespace fw_linux
