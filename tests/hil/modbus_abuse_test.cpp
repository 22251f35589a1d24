// Modbus clients that abuse delta_fw's server on vcan with the real
// programs: the control loop keeps its rate.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <iostream>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "bus_observer.hpp"
#include "child_process.hpp"
#include "delta/can/protocol.hpp"
#include "delta/can/socketcan.hpp"
#include "pipeline_programs.hpp"
#include "raw_modbus.hpp"
#include "wake_up_probe.hpp"

namespace {

namespace p = delta::can::protocol;
using delta::can::Frame;
using hil::BusObserver;
using hil::kBin;
using hil::kIface;
using namespace std::chrono_literals;

// --- Modbus clients that abuse the server: the control loop keeps its rate --

// The fault matrix's Modbus row (docs/dev/hil-tests.md): three clients reading as
// fast as they can, one trickling its requests a byte every 150 ms and one
// connecting and leaving in a loop, while delta_fw runs in real time at
// 100 Hz with SCHED_FIFO (an 8 ms response window: the VM's emulated CPUs
// wake up to 4 ms late, which a 2 ms window at 250 Hz missed now and then,
// with or without the clients). The flood and the churn are on and off in
// alternating windows of 1 s (4 s of each; the trickle goes on throughout).
// Always checked: every client is served, a well-behaved one quickly, and
// the loop does not collapse with the clients (a loop that waited on them
// would lose far more than 15 %). Checked where the VM keeps real time: the
// controller does not fault, and with the clients the loop's cycle counter
// (input registers 6-7) and the SYNCs on the bus keep within 2 % of their
// nominal rate and of the rate they have without the clients.
// Whether the VM keeps real time is measured beside the test, by a thread
// above every other one (hil::WakeUpProbe). ctest runs this test alone
// (RUN_SERIAL, in tests/hil/CMakeLists.txt), but the host may still take the
// VM's CPUs away: beside other work on the same two cores the loop ran at
// 89-97 Hz with the clients and 95-99 Hz without, 8-26 % of the probe's
// wakes came over 5 ms late (on a quiet host at most 1.8 %), and the
// emulated drives, starved, missed ten SYNCs in a row (fault 3). There
// those bars measure the host, not delta_fw, and the test reports itself
// skipped with its figures.
namespace modbus_abuse {

struct Window {
  bool abused;  // the flood and the churn on
  std::chrono::steady_clock::time_point from, to;
  std::uint32_t cycles;  // the loop's cycle counter's advance
};

// Per second over the windows with (abused) or without the clients.
template <class CountIn>
double rate_hz(const std::vector<Window>& windows, bool abused, CountIn count_in) {
  double events = 0.0, seconds = 0.0;
  for (const Window& w : windows) {
    if (w.abused != abused) continue;
    events += count_in(w);
    seconds += std::chrono::duration<double>(w.to - w.from).count();
  }
  return events / seconds;
}

// The share of the probe's wakes in those windows that came over 5 ms late.
double late_wake_share(const hil::WakeUpProbe& probe, const std::vector<Window>& windows,
                       bool abused) {
  std::size_t wakes = 0, late = 0;
  for (const Window& w : windows) {
    if (w.abused != abused) continue;
    const hil::WakeUpProbe::Count c = probe.later_than(5ms, w.from, w.to);
    wakes += c.wakes;
    late += c.late;
  }
  return wakes == 0 ? 1.0 : static_cast<double>(late) / static_cast<double>(wakes);
}

// At most this share of wakes over 5 ms late: the VM kept real time.
constexpr double kRealTimeLateShare = 0.03;
// Below this share of its rate without the clients the loop collapsed.
constexpr double kCollapsedShare = 0.85;

// The abusing clients: three reading as fast as they can and one
// connecting and leaving in a loop (the flood and the churn, on while
// set_abuse(true)), and one trickling its requests a byte every 150 ms
// throughout; until stop() (or destruction).
class Abusers {
 public:
  explicit Abusers(int port) : port_(port) {
    for (int k = 0; k < 3; ++k) {
      threads_.emplace_back([this] {
        hil::RawModbus c(port_);
        while (abuse_allowed() && c.read_input(0, 40)) ++flood_answers_;
      });
    }
    threads_.emplace_back([this] {
      hil::RawModbus c(port_);
      while (!stop_.load() && c.trickle(6, 2, 150ms, stop_)) ++loris_answers_;
    });
    threads_.emplace_back([this] {
      while (abuse_allowed()) {
        hil::RawModbus c(port_);
        churn_connections_ += c.connected() ? 1 : 0;
      }
    });
  }
  ~Abusers() { stop(); }
  Abusers(const Abusers&) = delete;
  Abusers& operator=(const Abusers&) = delete;

  void set_abuse(bool on) {
    {
      const std::lock_guard<std::mutex> lock(gate_mutex_);
      abuse_on_ = on;
    }
    gate_.notify_all();
  }
  void stop() {
    stop_.store(true);
    set_abuse(true);
    for (std::thread& t : threads_) {
      if (t.joinable()) t.join();
    }
  }
  std::uint64_t flood_answers() const { return flood_answers_.load(); }
  std::uint64_t loris_answers() const { return loris_answers_.load(); }
  std::uint64_t churn_connections() const { return churn_connections_.load(); }

 private:
  // Blocks while the flood and the churn are off; false once stopped.
  bool abuse_allowed() {
    std::unique_lock<std::mutex> lock(gate_mutex_);
    gate_.wait(lock, [this] { return abuse_on_ || stop_.load(); });
    return !stop_.load();
  }

  int port_;
  std::atomic<bool> stop_{false};
  std::mutex gate_mutex_;
  std::condition_variable gate_;
  bool abuse_on_{true};
  std::atomic<std::uint64_t> flood_answers_{0};
  std::atomic<std::uint64_t> loris_answers_{0};
  std::atomic<std::uint64_t> churn_connections_{0};
  std::vector<std::thread> threads_;
};

// As in a cell: the control loop at real-time priority (--rt-priority),
// the Modbus server's threads at normal priority; the emulated drives,
// which stand in for hardware that the host's load does not reach, below
// the loop but above the clients. A fatal failure when one does not come up.
void start_programs(int port, std::optional<hil::Child>& emu, std::optional<hil::Child>& fw) {
  emu.emplace(hil::Child::spawn({"/usr/bin/chrt", "-f", "40", kBin + "/delta_drive_emu", "--can",
                                 kIface, "--plant", "lumped"}));
  ASSERT_TRUE(emu->wait_for_output("ready on " + kIface, 30s)) << emu->err();
  // The drives' supervision is FaultInjection's subject; here 10 cycles
  // without feedback fault, not 3: in the VM's emulated CPUs the drives now
  // and then answered three SYNCs in a row late (fault 3 at cycle 9 or 800 in
  // 2 of 5 runs on a quiet host), with or without the clients.
  fw.emplace(hil::Child::spawn({kBin + "/delta_fw", "--can", kIface, "--rt-priority", "50", "--set",
                                "period_us=10000", "--set", "response_window_us=8000", "--set",
                                "lost_feedback_cycles=10", "--set",
                                "modbus.tcp=127.0.0.1:" + std::to_string(port)}));
  ASSERT_TRUE(fw->wait_for_output("delta_fw: ready", 60s)) << fw->err();
}

// The loop's cycle counter (input registers 6-7) as the probe reads it.
std::optional<std::uint32_t> cycle_counter(hil::RawModbus& probe) {
  const auto r = probe.read_input(6, 2);
  if (!r) return std::nullopt;
  return std::uint32_t{(*r)[0]} << 16 | (*r)[1];
}

// Eight windows of 1 s, the flood and the churn on in every other one
// (first on), each with the cycle counter's advance; the probe reads the
// counter every 50 ms, and its slowest answer is kept. A fatal failure
// when the probe gets no answer.
void measure_windows(hil::RawModbus& probe, Abusers& abusers, std::vector<Window>& windows,
                     std::chrono::nanoseconds& worst_probe) {
  for (int w = 0; w < 8; ++w) {
    const bool abused = w % 2 == 0;
    abusers.set_abuse(abused);
    const auto from = std::chrono::steady_clock::now();
    const std::optional<std::uint32_t> c0 = cycle_counter(probe);
    ASSERT_TRUE(c0.has_value()) << "the probe got no answer";
    while (std::chrono::steady_clock::now() - from < 1s) {
      const auto asked = std::chrono::steady_clock::now();
      ASSERT_TRUE(cycle_counter(probe).has_value()) << "the probe got no answer";
      worst_probe = std::max(worst_probe, std::chrono::steady_clock::now() - asked);
      std::this_thread::sleep_for(50ms);  // the probe's pace
    }
    const std::optional<std::uint32_t> c1 = cycle_counter(probe);
    ASSERT_TRUE(c1.has_value()) << "the probe got no answer";
    windows.push_back({abused, from, std::chrono::steady_clock::now(), *c1 - *c0});
  }
}

// Always checked: every client was served, the probe quickly, and the
// loop did not collapse with the clients.
void expect_every_client_served(const Abusers& abusers, std::chrono::nanoseconds worst_probe,
                                double abused_hz, double quiet_hz, double nominal_hz) {
  std::cout << "Modbus abuse: " << abusers.flood_answers() << " flood answers, "
            << abusers.loris_answers() << " slow-loris answers, " << abusers.churn_connections()
            << " short connections in 4 s; cycle counter rate " << abused_hz << " Hz with them, "
            << quiet_hz << " Hz without (nominal " << nominal_hz << "); slowest probe answer "
            << std::chrono::duration<double, std::milli>(worst_probe).count() << " ms\n";
  EXPECT_GT(abusers.flood_answers(), 300u) << "the flood was served";
  EXPECT_GE(abusers.loris_answers(), 1u) << "the slow client was served too";
  EXPECT_GT(abusers.churn_connections(), 50u);
  EXPECT_LT(worst_probe, 250ms);
  EXPECT_GT(abused_hz, kCollapsedShare * quiet_hz) << "the loop waits on the clients";
}

// The SYNCs per second on the bus in the windows with (abused) or without
// the clients, by the frames' kernel receive times (wall clock).
double sync_rate_hz(const std::vector<Window>& windows, bool abused,
                    const std::vector<Frame>& frames,
                    const std::vector<std::chrono::nanoseconds>& times) {
  const auto wall_offset = std::chrono::system_clock::now().time_since_epoch() -
                           std::chrono::steady_clock::now().time_since_epoch();
  const auto syncs_in = [&](const Window& w) {
    const auto from = w.from.time_since_epoch() + wall_offset;
    const auto to = w.to.time_since_epoch() + wall_offset;
    double syncs = 0.0;
    for (std::size_t i = 0; i < frames.size(); ++i) {
      if (frames[i].id != p::kSync.base_id || frames[i].error_frame) continue;
      if (times[i] >= from && times[i] < to) ++syncs;
    }
    return syncs;
  };
  return rate_hz(windows, abused, syncs_in);
}

}  // namespace modbus_abuse

TEST(ModbusAbuse, AFloodAndASlowLorisClientDoNotSlowTheControlLoop) {
  constexpr int kPort = 15041;
  constexpr double kRateHz = 100.0;
  BusObserver bus;
  std::optional<hil::Child> emu, fw;
  ASSERT_NO_FATAL_FAILURE(modbus_abuse::start_programs(kPort, emu, fw));
  hil::RawModbus probe(kPort);
  ASSERT_TRUE(probe.connected());
  modbus_abuse::Abusers abusers(kPort);
  // Above the loop (50) and the drives (40), every 2 ms; 20 000 wakes are
  // more than the windows need.
  hil::WakeUpProbe wake_up_probe(60, 2000us, 20000);
  std::vector<modbus_abuse::Window> windows;
  std::chrono::nanoseconds worst_probe{0};
  ASSERT_NO_FATAL_FAILURE(modbus_abuse::measure_windows(probe, abusers, windows, worst_probe));
  abusers.stop();
  wake_up_probe.stop();
  ASSERT_EQ(wake_up_probe.error(), "")
      << "the wake-up probe needs SCHED_FIFO, as delta_fw does here";

  const auto cycles_in = [](const modbus_abuse::Window& w) {
    return static_cast<double>(w.cycles);
  };
  const double abused_hz = modbus_abuse::rate_hz(windows, true, cycles_in);
  const double quiet_hz = modbus_abuse::rate_hz(windows, false, cycles_in);
  modbus_abuse::expect_every_client_served(abusers, worst_probe, abused_hz, quiet_hz, kRateHz);

  const int fw_exit = fw->terminate(30s).value_or(-1);
  EXPECT_EQ(emu->terminate(30s).value_or(-1), 0) << emu->err();
  std::cout << fw->err() << emu->err();
  const std::vector<Frame> all = bus.stop();
  const double abused_sync_hz = modbus_abuse::sync_rate_hz(windows, true, all, bus.kernel_times());
  const double quiet_sync_hz = modbus_abuse::sync_rate_hz(windows, false, all, bus.kernel_times());
  std::cout << "SYNCs on the bus: " << abused_sync_hz << " Hz with the clients, " << quiet_sync_hz
            << " Hz without\n";
  EXPECT_GT(abused_sync_hz, modbus_abuse::kCollapsedShare * quiet_sync_hz)
      << "the SYNCs wait on the clients";

  const double late_abused = modbus_abuse::late_wake_share(wake_up_probe, windows, true);
  const double late_quiet = modbus_abuse::late_wake_share(wake_up_probe, windows, false);
  std::cout << "Wake-up probe: " << 100 * late_abused << " % of wakes over 5 ms late with the "
            << "clients, " << 100 * late_quiet << " % without\n";
  if (std::max(late_abused, late_quiet) > modbus_abuse::kRealTimeLateShare) {
    GTEST_SKIP() << "the VM did not keep real time (over " << 100 * modbus_abuse::kRealTimeLateShare
                 << " % of a FIFO thread's wakes over 5 ms late: the host took its CPUs), so "
                    "the 2 % rate bars and the drives' supervision were not judged";
  }
  EXPECT_EQ(fw_exit, 0) << "delta_fw faulted (its stderr is above)";
  EXPECT_NEAR(abused_hz, kRateHz, 0.02 * kRateHz) << "the loop lost its rate with the clients";
  EXPECT_GT(abused_hz, quiet_hz - 0.02 * kRateHz) << "the clients slowed the loop";
  EXPECT_NEAR(abused_sync_hz, kRateHz, 0.02 * kRateHz);
  EXPECT_GT(abused_sync_hz, quiet_sync_hz - 0.02 * kRateHz) << "the clients slowed the SYNCs";
}

}  // namespace
