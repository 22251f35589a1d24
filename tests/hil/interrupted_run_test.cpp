// A run interrupted, on vcan with the real programs (rows of the fault
// matrix): delta_fw stopped by a signal or killed, the recorder killed and
// started again, and the e-stop opened on a real kernel GPIO chip.
#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "bus_observer.hpp"
#include "child_process.hpp"
#include "delta/can/cia402.hpp"
#include "delta/can/protocol.hpp"
#include "delta/can/socketcan.hpp"
#include "gpio_sim.hpp"
#include "pipeline_programs.hpp"
#include "recorded_log.hpp"
#include "scratch_directory.hpp"

namespace {

namespace p = delta::can::protocol;
using delta::can::Frame;
using hil::all_drives_enabled;
using hil::BusObserver;
using hil::count_frames;
using hil::expect_every_record_accounted_for;
using hil::recorded_seqs;
using hil::start_emulator;
using hil::start_path1_firmware;
using hil::start_recorder;
using hil::u16;
using namespace std::chrono_literals;

TEST(FirmwareStop, ASignalMidRunDisablesTheDrivesAndExitsWithStopped) {
  BusObserver bus;
  hil::Child emu = start_emulator();
  hil::Child fw = start_path1_firmware();
  ASSERT_TRUE(fw.wait_for_output("delta_fw: running\n", 60s)) << fw.err();
  // The drives are enabled within a few cycles of the run's start: wait
  // for operation enabled on the bus before the signal.
  const auto enabled_deadline = std::chrono::steady_clock::now() + 60s;
  bool enabled = false;
  while (!enabled && std::chrono::steady_clock::now() < enabled_deadline) {
    ASSERT_FALSE(fw.wait_for_output("delta_fw: stopping", 100ms)) << "the run ended first";
    enabled = all_drives_enabled(bus.snapshot());
  }
  ASSERT_TRUE(enabled);
  EXPECT_EQ(fw.terminate(60s).value_or(-1), 5) << fw.err();
  const std::vector<Frame> frames = bus.stop();
  emu.terminate(30s);
  for (std::uint8_t node = 1; node <= 3; ++node) {
    SCOPED_TRACE("node " + std::to_string(node));
    std::optional<std::array<std::uint8_t, 8>> last;
    for (const Frame& f : frames) {
      if (f.id == p::cob_id(p::kRpdo1, node)) last = f.data;
    }
    ASSERT_TRUE(last.has_value());
    EXPECT_EQ((*last)[0] | ((*last)[1] << 8), 0) << "controlword";
    EXPECT_EQ((*last)[2] | ((*last)[3] << 8), 0) << "target torque";
  }
}

// The recorder killed mid-run and started again (the fault matrix's row):
// the controller does not notice (its log frames go to the bus, not to a
// reader), the killed recorder leaves no file at all (it writes at the end,
// atomically), and the second one records every record that came after its
// socket opened, without a gap.
TEST(RecorderKilled, NothingIsHalfWrittenAndTheNextRecorderTakesOverWithoutAGap) {
  const testsupport::ScratchDirectory scratch("delta_hil");
  const std::string& dir = scratch.path();
  BusObserver bus;
  hil::Child emu = start_emulator({"--plant", "lumped"});
  hil::Child first = start_recorder(dir + "/first.csv");
  hil::Child fw = start_path1_firmware({}, 1);  // 9.4 s: the kill comes after 2 s
  while (count_frames(bus.snapshot(), p::kLogA.base_id) < 1000) {
    ASSERT_FALSE(fw.wait_for_output("delta_fw: stopping", 20ms)) << "the run ended first";
  }
  kill(first.pid(), SIGKILL);
  EXPECT_EQ(first.wait(30s).value_or(-1), 128 + SIGKILL);
  const auto spawned = std::chrono::system_clock::now();
  hil::Child second = start_recorder(dir + "/second.csv");
  const auto listening = std::chrono::system_clock::now();
  EXPECT_EQ(fw.wait(300s).value_or(-1), 0) << "the controller finished its run: " << fw.err();
  EXPECT_EQ(second.wait(60s).value_or(-1), 0) << second.out() << second.err();
  const std::vector<Frame> frames = bus.stop();
  emu.terminate(30s);
  // Only the second recorder's log is in the folder: no temporary, no part.
  std::vector<std::string> files;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    files.push_back(e.path().filename());
  EXPECT_EQ(files, std::vector<std::string>{"second.csv"});
  // Its rows: every record sent after it listened, perhaps some sent while
  // it opened its socket, none before it started; seq without a gap.
  const auto& times = bus.kernel_times();
  std::size_t sent_after_listening = 0;
  std::size_t sent_after_spawn = 0;
  const auto since_epoch = [](std::chrono::system_clock::time_point t) {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch());
  };
  for (std::size_t i = 0; i < frames.size(); ++i) {
    if (frames[i].id != p::kLogA.base_id) continue;
    sent_after_listening += times[i] >= since_epoch(listening);
    sent_after_spawn += times[i] >= since_epoch(spawned);
  }
  const std::vector<std::uint64_t> seqs = recorded_seqs(dir + "/second.csv");
  const std::size_t rows = seqs.size();
  for (std::size_t k = 0; k < rows; ++k) EXPECT_EQ(seqs[k], k) << "row " << k;
  std::cout << "second recorder: " << rows << " rows; records sent after it listened "
            << sent_after_listening << ", after it was started " << sent_after_spawn << "\n";
  EXPECT_GE(rows, sent_after_listening);
  EXPECT_LE(rows, sent_after_spawn);
  EXPECT_GT(rows, 0u);
  EXPECT_NE(second.out().find(" samples"), std::string::npos) << second.out();
  EXPECT_EQ(second.err().find("lost"), std::string::npos) << second.err();
}

// Waits until the drives are enabled and then for a controller heartbeat.
// CiA 301: a consumer watches from the first heartbeat it receives after
// 0x1016 was written; killed before one, the controller would leave the
// drives unwatched (and the test would wait for nothing). A fatal failure
// when the controller stops first.
void wait_for_a_heartbeat_after_enabling(BusObserver& bus, hil::Child& fw) {
  while (!all_drives_enabled(bus.snapshot())) {
    ASSERT_FALSE(fw.wait_for_output("delta_fw: stopping", 100ms));
  }
  const std::size_t enabled_at = bus.snapshot().size();
  const auto heartbeat_since_enabled = [&] {
    const std::vector<Frame> frames = bus.snapshot();
    for (std::size_t i = enabled_at; i < frames.size(); ++i) {
      if (frames[i].id == p::kControllerHeartbeat.base_id) return true;
    }
    return false;
  };
  while (!heartbeat_since_enabled()) {
    ASSERT_FALSE(fw.wait_for_output("delta_fw: stopping", 20ms));
  }
}

// The drives' EMCYs 0x8130 (heartbeat lost) on the bus so far.
int heartbeat_lost_emcys(const std::vector<Frame>& frames) {
  int n = 0;
  for (const Frame& f : frames) {
    n += p::function_code(f.id) == p::kEmcy.base_id && f.id != p::kControllerEmcy.base_id &&
         u16(f) == delta::can::od::kEmcyHeartbeat;
  }
  return n;
}

// Each drive's EMCY 0x8130 came within its consumer timeout plus the
// emulator's grace after the controller's last heartbeat.
void expect_each_drive_stopped_in_time(const std::vector<Frame>& frames,
                                       const std::vector<std::chrono::nanoseconds>& times,
                                       const std::string& emulator_said) {
  std::optional<std::chrono::nanoseconds> last_heartbeat;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    if (frames[i].id == p::kControllerHeartbeat.base_id) last_heartbeat = times[i];
  }
  ASSERT_TRUE(last_heartbeat.has_value());
  for (std::uint8_t node = 1; node <= 3; ++node) {
    SCOPED_TRACE("node " + std::to_string(node));
    std::optional<std::chrono::nanoseconds> emcy;
    for (std::size_t i = 0; i < frames.size() && !emcy; ++i) {
      if (frames[i].id == p::cob_id(p::kEmcy, node) &&
          u16(frames[i]) == delta::can::od::kEmcyHeartbeat) {
        emcy = times[i];
      }
    }
    ASSERT_TRUE(emcy.has_value()) << "no EMCY 0x8130; the emulator said:\n" << emulator_said;
    const auto after_ms =
        std::chrono::duration_cast<std::chrono::milliseconds>(*emcy - *last_heartbeat);
    std::cout << "node " << int{node} << ": EMCY 0x8130 " << after_ms.count()
              << " ms after the controller's last heartbeat\n";
    // 150 ms timeout (controller_heartbeat_timeout_ms) + 5 s grace + the
    // emulator's 10 ms poll and this machine's scheduling.
    EXPECT_LE(after_ms.count(), 150 + 5000 + 250);
    EXPECT_GE(after_ms.count(), 5000);
  }
}

// The drives watch the controller (0x1016): when delta_fw dies mid-motion
// (SIGKILL: no clean exit), every drive faults with EMCY 0x8130 (heartbeat
// lost) within its consumer timeout plus the emulator's wall-clock grace
// for a starved lock-step controller (docs/firmware.md), and drops its torque.
TEST(FirmwareKilled, TheDrivesStopThemselvesWithinTheirHeartbeatTimeout) {
  const testsupport::ScratchDirectory scratch("delta_hil");
  const std::string& dir = scratch.path();
  BusObserver bus;
  hil::Child emu = start_emulator({"--plant", "lumped"});
  hil::Child rec = start_recorder(dir + "/killed.csv");
  hil::Child fw = start_path1_firmware();
  ASSERT_TRUE(fw.wait_for_output("delta_fw: running\n", 60s)) << fw.err();
  ASSERT_NO_FATAL_FAILURE(wait_for_a_heartbeat_after_enabling(bus, fw));
  kill(fw.pid(), SIGKILL);
  EXPECT_EQ(fw.wait(30s).value_or(-1), 128 + SIGKILL);
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  while (heartbeat_lost_emcys(bus.snapshot()) < 3 && std::chrono::steady_clock::now() < deadline) {
    ASSERT_FALSE(emu.wait_for_output("delta_drive_emu: stopped", 50ms));
  }
  const std::vector<Frame> frames = bus.stop();
  emu.terminate(30s);
  // The log up to the kill: every record the controller sent.
  EXPECT_EQ(rec.wait(60s).value_or(-1), 0) << rec.out() << rec.err();
  const std::size_t rows = recorded_seqs(dir + "/killed.csv").size();
  std::cout << "recorded " << rows << " rows up to the kill\n";
  EXPECT_GT(rows, 0u);
  expect_every_record_accounted_for(rec.out() + rec.err(), rows,
                                    count_frames(frames, p::kLogA.base_id), true);
  expect_each_drive_stopped_in_time(frames, bus.kernel_times(), emu.err());
}

// The e-stop on a real kernel GPIO chip (gpio-sim, in hil/vcan-run's VM):
// opened during motion, it faults the controller within a cycle, the drives
// are disabled, the enable and brake lines go low (braked), and the log up
// to the fault is kept.
TEST(GpioEStop, OpeningTheLineMidRunFaultsWithinACycleDisablesBrakesAndKeepsTheLog) {
  ASSERT_TRUE(delta::test::GpioSim::unavailable().empty()) << delta::test::GpioSim::unavailable();
  delta::test::GpioSim sim;
  sim.pull(0, true);  // the e-stop circuit closed: the active-low line high
  const testsupport::ScratchDirectory scratch("delta_hil");
  const std::string& dir = scratch.path();
  BusObserver bus;
  hil::Child emu = start_emulator({"--plant", "lumped"});
  hil::Child rec = start_recorder(dir + "/estop.csv");
  hil::Child fw = start_path1_firmware(
      {"--set", "gpio.chip=" + sim.chip(), "--set", "gpio.estop_debounce_ms=0"});
  // During motion: 1000 log records (2 s into the run) on the bus.
  const auto deadline = std::chrono::steady_clock::now() + 120s;
  while (count_frames(bus.snapshot(), p::kLogA.base_id) < 1000) {
    ASSERT_LT(std::chrono::steady_clock::now(), deadline) << fw.err();
    ASSERT_FALSE(fw.wait_for_output("delta_fw: stopping", 20ms)) << fw.err();
  }
  sim.pull(0, false);  // open
  // From here on the line reads open (the frames' kernel times are on the
  // same clock).
  const auto opened = std::chrono::system_clock::now().time_since_epoch();
  EXPECT_EQ(fw.wait(120s).value_or(-1), 3) << fw.err();
  EXPECT_EQ(rec.wait(60s).value_or(-1), 0) << rec.err();
  emu.terminate(30s);
  const std::vector<Frame> frames = bus.stop();
  EXPECT_NE(fw.err().find("fault 1 (e-stop)"), std::string::npos) << fw.err();
  // The controller's EMCY, and the SYNCs sent between the line's opening
  // and it, by the frames' kernel receive times.
  const std::vector<std::chrono::nanoseconds>& times = bus.kernel_times();
  std::uint64_t syncs_after_open = 0;
  std::size_t emcy_index = frames.size();
  for (std::size_t i = 0; i < frames.size() && emcy_index == frames.size(); ++i) {
    if (frames[i].id == p::kSync.base_id && times[i] > opened) ++syncs_after_open;
    if (frames[i].id == p::kControllerEmcy.base_id) emcy_index = i;
  }
  ASSERT_LT(emcy_index, frames.size()) << "no controller EMCY";
  EXPECT_EQ(frames[emcy_index].data[3], 1) << "fault 1, e-stop";
  std::cout << "e-stop: EMCY after " << syncs_after_open << " SYNC(s) of the line open\n";
  EXPECT_LE(syncs_after_open, 1u) << "within one cycle of the line opening";
  for (std::uint8_t node = 1; node <= 3; ++node) {
    std::optional<std::array<std::uint8_t, 8>> last;
    for (std::size_t i = emcy_index; i < frames.size(); ++i) {
      if (frames[i].id == p::cob_id(p::kRpdo1, node)) last = frames[i].data;
    }
    ASSERT_TRUE(last.has_value()) << "node " << int{node};
    EXPECT_EQ((*last)[0] | ((*last)[1] << 8), 0) << "node " << int{node} << ": controlword";
  }
  EXPECT_EQ(sim.value(1), 0) << "enable line";
  EXPECT_EQ(sim.value(2), 0) << "brake line (low: braked)";
  // The log up to the fault is whole: at least the 1000 records before it
  // (data rows; the fault may come before the next record).
  const std::size_t rows = recorded_seqs(dir + "/estop.csv").size();
  EXPECT_GE(rows, 1000u) << rec.out() << rec.err();
  expect_every_record_accounted_for(rec.out() + rec.err(), rows,
                                    count_frames(frames, p::kLogA.base_id));
}

}  // namespace
