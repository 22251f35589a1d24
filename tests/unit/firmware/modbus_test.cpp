// The firmware's Modbus server (libmodbus) against the real control loop:
// the controller, the CANopen master and the emulator closed in-process and
// stepped by a loop thread, with the run coordinator and the control panel
// of delta_fw. Clients: libmodbus over TCP on loopback, and RTU frames
// written by hand on a pseudo-terminal pair (posix_openpt).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <latch>
#include <memory>
#include <sstream>
#include <thread>

#include "delta/atomic_file.hpp"
#include "delta/custom_trajectory_block.hpp"
#include "delta/modbus/register_map.hpp"
#include "delta/model_q.hpp"
#include "delta/trajectory_file.hpp"
#include "fw_linux/control_panel.hpp"
#include "fw_linux/modbus_server.hpp"
#include "fw_linux/run_coordinator.hpp"
#include "fw_linux/trajectories.hpp"
#include "host_id/cli.hpp"
#include "in_process_rig.hpp"
#include "scratch_directory.hpp"

namespace fw_linux {
namespace {

namespace mb = delta::modbus;
using std::chrono::milliseconds;
using std::chrono::steady_clock;

// The loop thread: cycles the in-process rig like run_port's loop, about
// every 50 us, until destroyed.
class LoopThread {
 public:
  explicit LoopThread(ControlPanel& panel) : coordinator_({}, false, &panel, messages_) {
    rig_.hw.gate_log(&panel.log_enabled());
    thread_ = std::thread([this] {
      while (!stop_.load()) {
        // Node 3's TPDO1 misses the deadline while late cycles are owed.
        const bool late = late_cycles_.load() > 0;
        if (late) late_cycles_.fetch_sub(1);
        rig_.bus.make_late(late ? delta::can::protocol::cob_id(delta::can::protocol::kTpdo1, 3)
                                : ~0u);
        rig_.cycle();
        if (next_feed_forward_.load()) {
          EXPECT_TRUE(rig_.controller.set_feed_forward(feed_forward_));
          next_feed_forward_.store(false);
        }
        coordinator_.after_step(rig_.controller, rig_.hw, rig_.master);
        cycles_.fetch_add(1);
        std::this_thread::sleep_for(std::chrono::microseconds(50));  // pacing, like the timer
      }
    });
  }
  ~LoopThread() {
    stop_.store(true);
    thread_.join();
  }
  std::uint64_t cycles() const { return cycles_.load(); }
  SimulatedSafetyIo& io() { return rig_.io; }
  // The next n cycles get node 3's feedback after their deadline.
  void make_late(int n) { late_cycles_.store(n); }
  // The controller's feed-forward changed between two cycles, as a model
  // loaded over the bus changes it.
  void set_feed_forward(const fw::FeedForwardConfig& f) {
    feed_forward_ = f;
    next_feed_forward_.store(true);
  }

 private:
  Rig rig_;
  std::ostringstream messages_;
  RunCoordinator coordinator_;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> cycles_{0};
  std::atomic<int> late_cycles_{0};
  fw::FeedForwardConfig feed_forward_{};
  std::atomic<bool> next_feed_forward_{false};
  std::thread thread_;
};

PortConfig modbus_config() {
  PortConfig c = Rig::config();
  c.modbus.tcp = "127.0.0.1:0";
  c.modbus.byte_timeout_ms = 100;
  return c;
}

class Client {
 public:
  explicit Client(int port) : ctx_(modbus_new_tcp("127.0.0.1", port)) {
    modbus_set_response_timeout(ctx_, 5, 0);
    connected_ = modbus_connect(ctx_) == 0;
  }
  ~Client() {
    modbus_close(ctx_);
    modbus_free(ctx_);
  }
  bool connected() const { return connected_; }
  // The whole input table; empty on an error.
  std::vector<std::uint16_t> inputs() {
    std::vector<std::uint16_t> r(mb::kInputCount);
    if (modbus_read_input_registers(ctx_, 0, mb::kInputCount, r.data()) != mb::kInputCount) {
      r.clear();
    }
    return r;
  }
  std::int64_t input(const char* name) {
    const auto r = inputs();
    return r.empty() ? -1 : mb::decode(mb::named(name), r.data());
  }
  // 0 on success, else errno (EMBX* for a Modbus exception).
  int write(const mb::Register& r, std::uint16_t v) {
    return modbus_write_register(ctx_, r.address, v) == 1 ? 0 : errno;
  }
  int write_many(int first, const std::vector<std::uint16_t>& v) {
    return modbus_write_registers(ctx_, first, static_cast<int>(v.size()), v.data()) ==
                   static_cast<int>(v.size())
               ? 0
               : errno;
  }
  modbus_t* ctx() { return ctx_; }

 private:
  modbus_t* ctx_;
  bool connected_{false};
};

// Polls the input registers until `done` holds or 20 s pass.
template <class Pred>
bool poll_until(Client& c, Pred done) {
  const auto deadline = steady_clock::now() + std::chrono::seconds(20);
  while (steady_clock::now() < deadline) {
    const auto r = c.inputs();
    if (!r.empty() && done(r.data())) return true;
    std::this_thread::sleep_for(milliseconds(2));
  }
  return false;
}

std::int64_t value(const std::uint16_t* regs, const char* name) {
  return mb::decode(mb::named(name), regs);
}

delta::BlendedFourierTrajectory path1_as_custom(double scale);

// The program the registers describe: its version, and that delta_boot
// started it after a new program crashed on trial.
const ProgramFacts kFacts{{3, 14, 15}, fw::update::RevertReason::kCrashed};

struct Fixture : ::testing::Test {
  Fixture() : server(modbus_config(), panel, kFacts), loop(panel), client(server.tcp_port()) {}
  void SetUp() override {
    ASSERT_TRUE(client.connected());
    ASSERT_TRUE(poll_until(client, [](const std::uint16_t* r) {
      return value(r, "state") == static_cast<int>(fw::State::kReady);
    }));
  }
  ControlPanel panel;
  ModbusServer server;
  LoopThread loop;
  Client client;
};

// The loop answers a command only after it has published the status the
// command produced: a client that writes start and reads at once sees the
// new run (a race the sanitizer build once lost: run_id still 0).
TEST(ControlPanelTest, TheStatusAfterACommandIsPublishedBeforeItsVerdict) {
  ControlPanel panel;
  PanelStatus before;
  before.run_id = 7;
  panel.publish(before);
  for (int round = 0; round < 200; ++round) {
    std::atomic<bool> done{false};
    std::optional<CommandVerdict> verdict;
    std::thread client([&] {
      PanelCommand start;
      start.kind = mb::Command::kStart;
      verdict = panel.submit(start, std::chrono::seconds(10));
      // Read at once, as a Modbus client reading after its write's reply.
      EXPECT_EQ(panel.status().run_id, 8 + round) << "round " << round;
      done.store(true);
    });
    PanelStatus after;
    after.run_id = static_cast<std::uint16_t>(8 + round);
    while (!done.load()) {
      panel.serve(
          [](const PanelCommand&) {
            CommandVerdict v;
            v.accepted = true;
            return v;
          },
          [&] { return after; });
    }
    client.join();
    ASSERT_TRUE(verdict.has_value());
    EXPECT_TRUE(verdict->accepted);
  }
}

TEST_F(Fixture, ReadsIdentityGeometryAndLiveValues) {
  const auto r = client.inputs();
  ASSERT_EQ(r.size(), mb::kInputCount);
  EXPECT_EQ(value(r.data(), "protocol_version"), mb::kMapVersion);
  EXPECT_EQ(value(r.data(), "firmware_version_major") * 10000 +
                value(r.data(), "firmware_version_minor") * 100 +
                value(r.data(), "firmware_version_patch"),
            31415);
  EXPECT_EQ(value(r.data(), "update_rollback"), 3) << "crashed";
  EXPECT_EQ(value(r.data(), "period_us"), 2000);
  EXPECT_EQ(value(r.data(), "trajectory_count"), 4);
  const PortConfig c = Rig::config();
  EXPECT_EQ(value(r.data(), "upper_arm_length"), std::llround(c.geometry.upper_arm_length_m * 1e6));
  EXPECT_EQ(value(r.data(), "forearm_length"), std::llround(c.geometry.forearm_length_m * 1e6));
  EXPECT_EQ(value(r.data(), "base_radius"), std::llround(c.geometry.base_radius_m * 1e6));
  EXPECT_EQ(value(r.data(), "platform_radius"), std::llround(c.geometry.platform_radius_m * 1e6));
  EXPECT_EQ(value(r.data(), "io") & mb::kIoStatusOk, mb::kIoStatusOk);
  // The emulator starts at rest with its initial pose near 0.1 rad per joint.
  for (const char* q : {"q1", "q2", "q3"}) EXPECT_LT(std::abs(value(r.data(), q)), 1500000) << q;
  // The cycle counter moves.
  const auto first = value(r.data(), "cycle_counter");
  EXPECT_TRUE(poll_until(
      client, [&](const std::uint16_t* x) { return value(x, "cycle_counter") > first + 10; }));
  // Holding registers read back their defaults.
  std::uint16_t hold[mb::kHoldingCount];
  ASSERT_EQ(modbus_read_registers(client.ctx(), 0, mb::kHoldingCount, hold), mb::kHoldingCount);
  EXPECT_EQ(hold[mb::kTrajectory.address], 0);
  EXPECT_EQ(hold[mb::kAmplitudeScale.address], 1000);
  EXPECT_EQ(hold[mb::kRepetitions.address], 0);
  EXPECT_EQ(hold[mb::kLogEnable.address], 1);
  EXPECT_EQ(hold[mb::kCommand.address], 0);
}

TEST_F(Fixture, RunsATrajectoryToItsEndAndRefusesChangesWhileRunning) {
  // path2 with one period instead of two, in one write of three registers.
  ASSERT_EQ(client.write_many(0, {1, 1000, 1}), 0);
  ASSERT_EQ(client.write(mb::kCommand, 1), 0) << modbus_strerror(errno);
  auto r = client.inputs();
  ASSERT_FALSE(r.empty());
  EXPECT_EQ(value(r.data(), "run_id"), 1);
  EXPECT_EQ(value(r.data(), "run_result"), static_cast<int>(mb::RunResult::kRunning));
  const std::int64_t length = value(r.data(), "run_length");
  // 2 s approach + 1 s blend + 4 s (one period at 0.25 Hz) + 1 s blend, at
  // 500 Hz, the last tick included.
  EXPECT_EQ(length, 4001);

  // While it runs: no change of trajectory, no second start (06 busy); the
  // reason is in last_rejection.
  EXPECT_EQ(client.write(mb::kTrajectory, 2), EMBXSBUSY);
  EXPECT_EQ(client.input("last_rejection"), static_cast<int>(mb::Rejection::kWrongState));
  EXPECT_EQ(client.input("last_rejection_register"), mb::kTrajectory.address);
  EXPECT_EQ(client.write(mb::kCommand, 1), EMBXSBUSY);
  // Writing the value it already has is no change.
  EXPECT_EQ(client.write(mb::kTrajectory, 1), 0);

  ASSERT_TRUE(poll_until(client, [](const std::uint16_t* x) {
    return value(x, "run_result") == static_cast<int>(mb::RunResult::kFinished);
  }));
  r = client.inputs();
  EXPECT_EQ(value(r.data(), "state"), static_cast<int>(fw::State::kReady));
  // Every cycle of the run logged once, then the stop's 0.4 s.
  EXPECT_EQ(value(r.data(), "run_tick"), length);
  EXPECT_EQ(value(r.data(), "log_records"), length + 200);
  EXPECT_EQ(value(r.data(), "stale_log_records"), 0);  // every cycle had its feedback
  EXPECT_EQ(value(r.data(), "fault_count"), 0);
  // The run's tracking error: its trajectory's cycles (4001 less the 2 s
  // approach, 1000), each joint's RMS below its largest error.
  EXPECT_EQ(value(r.data(), "tracking_run_id"), 1);
  EXPECT_EQ(value(r.data(), "tracking_ticks"), length - 1000);
  for (const char* j : {"1", "2", "3"}) {
    const std::int64_t rms = value(r.data(), (std::string("tracking_rms_") + j).c_str());
    const std::int64_t largest = value(r.data(), (std::string("tracking_max_") + j).c_str());
    EXPECT_GT(rms, 0) << j;
    EXPECT_LT(rms, largest) << j;
    EXPECT_LT(largest, 20000000) << j;  // 0.02 rad
  }
  std::ostringstream out, err;
  ASSERT_EQ(host_id::run_cli(
                {"status", "--modbus", "127.0.0.1:" + std::to_string(server.tcp_port())}, out, err),
            0)
      << err.str();
  EXPECT_NE(out.str().find("  tracking   run #1, rms "), std::string::npos) << out.str();
  EXPECT_EQ(value(r.data(), "feed_forward_mode"), 1);  // nominal: no model configured
  EXPECT_EQ(value(r.data(), "model_fit_id"), 0);
  EXPECT_NE(out.str().find("  feed-fwd   nominal\n"), std::string::npos) << out.str();
  EXPECT_EQ(client.write(mb::kTrajectory, 2), 0);  // allowed again
}

// A trajectory the server checked against the nominal feed-forward, then a
// model loaded before the start: the server checks it again against the
// model (in its own thread, not in the control loop) and the run starts.
TEST_F(Fixture, ATrajectoryCheckedBeforeAModelWasLoadedIsCheckedAgainAtItsStart) {
  ASSERT_EQ(client.write(mb::kTrajectory, 1), 0);  // checked now, nominal feed-forward
  delta::IdentifiedModel m;
  m.kind = "lumped";
  m.geometry = delta::kDefaultGeometry;
  m.parameters = delta::to_high_fidelity(delta::default_lumped_parameters());
  const fw::ControllerConfig core = controller_config(modbus_config());
  fw::FeedForwardConfig model = core.feed_forward;
  model.mode = fw::FeedForwardMode::kModel;
  model.model = delta::fx::prepare_model(core.geometry, delta::model_parameters_q(m));
  loop.set_feed_forward(model);
  ASSERT_TRUE(poll_until(client, [](const std::uint16_t* x) {
    return value(x, "feed_forward_mode") == static_cast<int>(fw::FeedForwardMode::kModel);
  }));
  ASSERT_EQ(client.write(mb::kCommand, 1), 0)
      << modbus_strerror(errno) << ", last rejection " << client.input("last_rejection");
  EXPECT_EQ(client.input("run_result"), static_cast<int>(mb::RunResult::kRunning));
  ASSERT_EQ(client.write(mb::kCommand, 2), 0);
}

TEST_F(Fixture, StaleRecordsAreCountedInTheirRegister) {
  ASSERT_EQ(client.write(mb::kCommand, 1), 0);
  ASSERT_TRUE(poll_until(client, [](const std::uint16_t* x) {
    return value(x, "state") == static_cast<int>(fw::State::kRunning) && value(x, "run_tick") > 50;
  }));
  EXPECT_EQ(client.input("stale_log_records"), 0);
  loop.make_late(2);  // fewer than lost_feedback_cycles (3): the run goes on
  ASSERT_TRUE(poll_until(
      client, [](const std::uint16_t* x) { return value(x, "stale_log_records") == 2; }));
  ASSERT_EQ(client.write(mb::kCommand, 2), 0);
  ASSERT_TRUE(poll_until(client, [](const std::uint16_t* x) {
    return value(x, "run_result") == static_cast<int>(mb::RunResult::kStopped);
  }));
  EXPECT_EQ(client.input("stale_log_records"), 2);
  EXPECT_EQ(client.input("fault_count"), 0);
}

TEST_F(Fixture, StopEndsTheRunAsStopped) {
  ASSERT_EQ(client.write(mb::kCommand, 1), 0);
  ASSERT_TRUE(poll_until(client, [](const std::uint16_t* x) {
    return value(x, "state") == static_cast<int>(fw::State::kRunning) && value(x, "run_tick") > 50;
  }));
  ASSERT_EQ(client.write(mb::kCommand, 2), 0);
  ASSERT_TRUE(poll_until(client, [](const std::uint16_t* x) {
    return value(x, "run_result") == static_cast<int>(mb::RunResult::kStopped);
  }));
  EXPECT_EQ(client.input("state"), static_cast<int>(fw::State::kReady));
  EXPECT_LT(client.input("log_records"), 1000);
}

TEST_F(Fixture, RefusesIllegalAddressesValuesAndFunctions) {
  std::uint16_t regs[8];
  // Reads past the tables, or too many at once.
  EXPECT_EQ(modbus_read_input_registers(client.ctx(), mb::kInputCount - 1, 2, regs), -1);
  EXPECT_EQ(errno, EMBXILADD);
  EXPECT_EQ(modbus_read_registers(client.ctx(), mb::kHoldingCount, 1, regs), -1);
  EXPECT_EQ(errno, EMBXILADD);
  // Writes to what is not a holding register (an input's address included).
  EXPECT_EQ(modbus_write_register(client.ctx(), 7, 1), -1);
  EXPECT_EQ(errno, EMBXILADD);
  EXPECT_EQ(client.input("last_rejection"), static_cast<int>(mb::Rejection::kIllegalAddress));
  EXPECT_EQ(client.input("last_rejection_register"), 7);
  // Half of a 32-bit register (its second word, or its first alone).
  EXPECT_EQ(modbus_write_register(client.ctx(), mb::custom_q0(0).address + 1, 1), -1);
  EXPECT_EQ(errno, EMBXILADD);
  EXPECT_EQ(modbus_write_register(client.ctx(), mb::custom_q0(0).address, 1), -1);
  EXPECT_EQ(errno, EMBXILADD);
  // A multiple write running past the end changes nothing.
  EXPECT_EQ(client.write_many(3, {0, 0, 0}), EMBXILADD);
  EXPECT_EQ(modbus_read_registers(client.ctx(), 3, 1, regs), 1);
  EXPECT_EQ(regs[0], 1) << "log_enable must be unchanged";
  // Values out of range.
  EXPECT_EQ(client.write(mb::kTrajectory, 4), EMBXILVAL);
  EXPECT_EQ(client.input("last_rejection"), static_cast<int>(mb::Rejection::kOutOfRange));
  EXPECT_EQ(client.write(mb::kAmplitudeScale, 0), EMBXILVAL);
  EXPECT_EQ(client.write(mb::kAmplitudeScale, 2001), EMBXILVAL);
  EXPECT_EQ(client.write(mb::kRepetitions, 101), EMBXILVAL);
  EXPECT_EQ(client.write(mb::kLogEnable, 2), EMBXILVAL);
  EXPECT_EQ(client.write(mb::kCommand, 4), EMBXILVAL);
  // Functions the server does not serve: coils and discrete inputs.
  std::uint8_t bits[4];
  EXPECT_EQ(modbus_read_bits(client.ctx(), 0, 1, bits), -1);
  EXPECT_EQ(errno, EMBXILFUN);
  EXPECT_EQ(modbus_write_bit(client.ctx(), 0, 1), -1);
  EXPECT_EQ(errno, EMBXILFUN);
  EXPECT_EQ(client.input("last_rejection"), static_cast<int>(mb::Rejection::kIllegalFunction));
  // A reset when there is no fault, and a stop when nothing runs, are no-ops.
  EXPECT_EQ(client.write(mb::kCommand, 3), 0);
  EXPECT_EQ(client.write(mb::kCommand, 2), 0);
  EXPECT_EQ(client.input("state"), static_cast<int>(fw::State::kReady));
}

TEST_F(Fixture, ATrajectoryThatBreaksALimitIsRefusedWithTheCheck) {
  // The first trajectory that breaks a limit at twice its amplitude; the
  // same check the controller runs says why.
  const PortConfig c = Rig::config();
  const fw::ControllerConfig core = controller_config(c);
  fw::TrajectoryCheck expected;
  std::uint16_t id = 0;
  for (; id < trajectory_names().size(); ++id) {
    const auto t = named_trajectory(trajectory_names()[id], c, TrajectoryParams{2000, 0});
    ASSERT_TRUE(t.has_value());
    expected = check_trajectory(core.geometry, *t, core.limits);
    if (expected.fault != fw::TrajectoryFault::kOk) break;
  }
  ASSERT_LT(id, trajectory_names().size()) << "no trajectory breaks a limit at 200 %";
  ASSERT_EQ(client.write(mb::kTrajectory, id), 0);
  EXPECT_EQ(client.write(mb::kAmplitudeScale, 2000), EMBXILVAL);
  const auto r = client.inputs();
  ASSERT_FALSE(r.empty());
  EXPECT_EQ(value(r.data(), "last_rejection"), static_cast<int>(mb::Rejection::kTrajectoryLimit));
  EXPECT_EQ(value(r.data(), "trajectory_check"), static_cast<int>(expected.fault));
  EXPECT_EQ(value(r.data(), "trajectory_check_tick"), expected.tick);
  EXPECT_EQ(value(r.data(), "trajectory_check_joint"), expected.joint + 1);
  std::uint16_t scale = 0;
  ASSERT_EQ(modbus_read_registers(client.ctx(), mb::kAmplitudeScale.address, 1, &scale), 1);
  EXPECT_EQ(scale, 1000) << "a refused write changes nothing";
  EXPECT_EQ(client.write(mb::kAmplitudeScale, 500), 0);  // half the amplitude is fine
}

TEST_F(Fixture, TheEStopFaultsAndAResetWaitsForItToClose) {
  ASSERT_EQ(client.write(mb::kCommand, 1), 0);
  ASSERT_TRUE(poll_until(client, [](const std::uint16_t* x) {
    return value(x, "state") == static_cast<int>(fw::State::kRunning);
  }));
  loop.io().open_estop(true);
  ASSERT_TRUE(poll_until(client, [](const std::uint16_t* x) {
    return value(x, "state") == static_cast<int>(fw::State::kFault);
  }));
  auto r = client.inputs();
  EXPECT_EQ(value(r.data(), "fault_code"), static_cast<int>(fw::Fault::kEStop));
  EXPECT_EQ(value(r.data(), "run_result"), static_cast<int>(mb::RunResult::kFaulted));
  EXPECT_EQ(value(r.data(), "fault_count"), 1);
  EXPECT_EQ(value(r.data(), "fault_history_0_code"), static_cast<int>(fw::Fault::kEStop));
  EXPECT_GT(value(r.data(), "fault_history_0_cycle"), 0);
  EXPECT_LE(value(r.data(), "fault_history_0_cycle"), value(r.data(), "cycle_counter"));
  EXPECT_EQ(value(r.data(), "io") & (mb::kIoDriveEnable | mb::kIoBrakeReleased | mb::kIoStatusOk),
            0);
  EXPECT_EQ(value(r.data(), "io") & mb::kIoEStopOpen, mb::kIoEStopOpen);
  // No start in fault; no reset while the e-stop is open.
  EXPECT_EQ(client.write(mb::kCommand, 1), EMBXSBUSY);
  EXPECT_EQ(client.write(mb::kCommand, 3), EMBXSBUSY);
  EXPECT_EQ(client.input("last_rejection"), static_cast<int>(mb::Rejection::kEStopOpen));
  loop.io().open_estop(false);
  EXPECT_EQ(client.write(mb::kCommand, 3), 0);
  ASSERT_TRUE(poll_until(client, [](const std::uint16_t* x) {
    return value(x, "state") == static_cast<int>(fw::State::kReady);
  }));
  r = client.inputs();
  EXPECT_EQ(value(r.data(), "fault_code"), 0);
  EXPECT_EQ(value(r.data(), "fault_history_0_code"), static_cast<int>(fw::Fault::kEStop))
      << "the history keeps it";
}

TEST_F(Fixture, HostIdStatusReadsTheController) {
  std::ostringstream out, err;
  const std::string address = "127.0.0.1:" + std::to_string(server.tcp_port());
  ASSERT_EQ(host_id::run_cli({"status", "--modbus", address}, out, err), 0) << err.str();
  const std::string s = out.str();
  EXPECT_NE(s.find("controller " + address + ": firmware "), std::string::npos) << s;
  EXPECT_NE(s.find("  state      ready\n"), std::string::npos) << s;
  EXPECT_NE(s.find("settings   trajectory path1, amplitude 100.0 %, repetitions preset"),
            std::string::npos)
      << s;
  EXPECT_NE(s.find("upper arm 0.2000 m"), std::string::npos) << s;
  // --json: every register by name.
  std::ostringstream json;
  ASSERT_EQ(host_id::run_cli({"status", "--modbus", address, "--json"}, json, err), 0);
  EXPECT_NE(json.str().find("\"period_us\": 2000"), std::string::npos) << json.str();
  // Errors: nobody listening, a malformed address.
  std::ostringstream e1, e2, o;
  EXPECT_EQ(host_id::run_cli({"status", "--modbus", "127.0.0.1:1"}, o, e1), 1);
  EXPECT_NE(e1.str().find("cannot connect to the controller at 127.0.0.1:1"), std::string::npos)
      << e1.str();
  EXPECT_EQ(host_id::run_cli({"status", "--modbus", "localhost"}, o, e2), 2);
  EXPECT_NE(e2.str().find("expected HOST:PORT"), std::string::npos) << e2.str();
}

TEST_F(Fixture, HostIdExciteRefusesBadArgumentsAndAControllerInFault) {
  const std::string address = "127.0.0.1:" + std::to_string(server.tcp_port());
  std::ostringstream o, e1, e2, e3;
  EXPECT_EQ(host_id::run_cli({"excite", "--modbus", address, "--trajectory", "figure8", "--can",
                              "vcan0", "-o", "x.csv"},
                             o, e1),
            2);
  EXPECT_NE(e1.str().find("--trajectory: figure8 not in {path1,path2,pick-and-place,custom}"),
            std::string::npos)
      << e1.str();
  EXPECT_EQ(host_id::run_cli({"excite", "--modbus", address, "--trajectory", "path1", "--can",
                              "vcan0", "-o", "x.csv", "--amplitude-scale", "3"},
                             o, e2),
            2);
  EXPECT_NE(e2.str().find("--amplitude-scale: must be in [0.001, 2], got '3'"), std::string::npos)
      << e2.str();
  loop.io().open_estop(true);
  ASSERT_TRUE(poll_until(client, [](const std::uint16_t* x) {
    return value(x, "state") == static_cast<int>(fw::State::kFault);
  }));
  EXPECT_EQ(
      host_id::run_cli({"excite", "--modbus", address, "--trajectory", "path1", "--can", "vcan0",
                        "-o", testsupport::process_scratch("modbus_test").file("x.csv")},
                       o, e3),
      1);
  EXPECT_NE(e3.str().find("is in fault 1 (e-stop)"), std::string::npos) << e3.str();
  EXPECT_FALSE(std::ifstream(testsupport::process_scratch("modbus_test").file("x.csv")).good());
}

// excite --trajectory-file uploads the file as the custom trajectory; the
// controller's refusal comes back with the limit and the tick, and nothing
// is recorded or written.
TEST_F(Fixture, HostIdExciteUploadsATrajectoryFileAndReportsItsRefusal) {
  const std::string address = "127.0.0.1:" + std::to_string(server.tcp_port());
  const std::string dir = testsupport::process_scratch("modbus_test").path();
  delta::write_file_atomically(dir + "/fast.json",
                               delta::format_trajectory(path1_as_custom(5.0), ""));
  std::ostringstream o, e1, e2, e3;
  EXPECT_EQ(host_id::run_cli({"excite", "--modbus", address, "--trajectory-file",
                              dir + "/fast.json", "--can", "vcan0", "-o", dir + "/f.csv"},
                             o, e1),
            1);
  EXPECT_NE(e1.str().find("the trajectory with these settings breaks a limit (register "
                          "trajectory, Modbus exception 3): "),
            std::string::npos)
      << e1.str();
  EXPECT_NE(e1.str().find(" at tick "), std::string::npos) << e1.str();
  EXPECT_FALSE(std::ifstream(dir + "/f.csv").good());
  // The block was taken (the check runs when it is selected).
  EXPECT_EQ(client.input("last_rejection"), static_cast<int>(mb::Rejection::kTrajectoryLimit));
  EXPECT_EQ(
      host_id::run_cli({"excite", "--modbus", address, "--trajectory", "path1", "--trajectory-file",
                        dir + "/fast.json", "--can", "vcan0", "-o", dir + "/f.csv"},
                       o, e2),
      2);
  EXPECT_EQ(host_id::run_cli(
                {"excite", "--modbus", address, "--can", "vcan0", "-o", dir + "/f.csv"}, o, e3),
            2);
  EXPECT_NE(e3.str().find("one of --trajectory and --trajectory-file is required"),
            std::string::npos)
      << e3.str();
}

TEST(HostIdExcite, PartialLogNames) {
  EXPECT_EQ(delta::partial_log_path("run.csv"), "run.partial.csv");
  EXPECT_EQ(delta::partial_log_path("/data/v1.2/run.csv"), "/data/v1.2/run.partial.csv");
  EXPECT_EQ(delta::partial_log_path("/data/v1.2/run"), "/data/v1.2/run.partial");
  EXPECT_EQ(delta::partial_log_path(".hidden"), ".hidden.partial");
}

// A raw TCP connection, for what libmodbus would never send.
int raw_connect(int port) {
  const int s = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (connect(s, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    close(s);
    return -1;
  }
  return s;
}

// Reads until the peer closes or `ms` pass; returns the bytes read, or -1
// on timeout with the connection still open.
int read_until_closed(int s, int ms, std::vector<std::uint8_t>& got) {
  const auto deadline = steady_clock::now() + milliseconds(ms);
  for (;;) {
    const auto left = std::chrono::duration_cast<milliseconds>(deadline - steady_clock::now());
    if (left.count() <= 0) return -1;
    pollfd p{s, POLLIN, 0};
    if (poll(&p, 1, static_cast<int>(left.count())) <= 0) return -1;
    std::uint8_t buf[300];
    const ssize_t n = recv(s, buf, sizeof buf, 0);
    if (n <= 0) return static_cast<int>(got.size());
    got.insert(got.end(), buf, buf + n);
  }
}

TEST_F(Fixture, MalformedRequestsAreAnsweredOrDroppedAndTheLoopNeverStalls) {
  const int port = server.tcp_port();
  // A write of 2 registers whose byte count says 3: exception 03.
  {
    const int s = raw_connect(port);
    ASSERT_GE(s, 0);
    const std::uint8_t req[] = {0, 1, 0, 0, 0, 10, 1, 0x10, 0, 0, 0, 2, 3, 0, 1, 0};
    ASSERT_EQ(send(s, req, sizeof req, 0), static_cast<ssize_t>(sizeof req));
    std::vector<std::uint8_t> got;
    pollfd p{s, POLLIN, 0};
    ASSERT_EQ(poll(&p, 1, 5000), 1);
    std::uint8_t buf[64];
    const ssize_t n = recv(s, buf, sizeof buf, 0);
    ASSERT_EQ(n, 9);
    EXPECT_EQ(buf[7], 0x90);
    EXPECT_EQ(buf[8], 0x03);
    close(s);
  }
  // A header whose length field disagrees with the request: the server closes.
  {
    const int s = raw_connect(port);
    const std::uint8_t req[] = {0, 1, 0, 0, 0x00, 0x95, 1, 0x03, 0, 0, 0, 1};
    ASSERT_EQ(send(s, req, sizeof req, 0), static_cast<ssize_t>(sizeof req));
    std::vector<std::uint8_t> got;
    EXPECT_EQ(read_until_closed(s, 5000, got), 0);
    close(s);
  }
  // Half a request, then silence: dropped after the byte timeout, while the
  // control loop keeps cycling and the next client is served.
  {
    const int s = raw_connect(port);
    const std::uint64_t cycles_before = loop.cycles();
    const std::uint8_t half[] = {0, 1, 0, 0, 0, 6, 1, 0x04};
    ASSERT_EQ(send(s, half, sizeof half, 0), static_cast<ssize_t>(sizeof half));
    std::vector<std::uint8_t> got;
    EXPECT_EQ(read_until_closed(s, 5000, got), 0) << "the half request must be dropped";
    EXPECT_GT(loop.cycles(), cycles_before + 100) << "the loop went on meanwhile";
    close(s);
    EXPECT_EQ(client.input("protocol_version"), mb::kMapVersion);
  }
  // A client that vanishes after its request, before the reply.
  for (int i = 0; i < 20; ++i) {
    const int s = raw_connect(port);
    const std::uint8_t req[] = {0, 1, 0, 0, 0, 6, 1, 0x04, 0, 0, 0, 73};
    ASSERT_EQ(send(s, req, sizeof req, 0), static_cast<ssize_t>(sizeof req));
    linger l{1, 0};  // reset, not a graceful close
    setsockopt(s, SOL_SOCKET, SO_LINGER, &l, sizeof l);
    close(s);
  }
  EXPECT_EQ(client.input("protocol_version"), mb::kMapVersion);
  const ModbusStats st = server.stats();
  EXPECT_GE(st.receive_errors, 2u);
  EXPECT_GE(st.exceptions, 1u);
}

// Sends a raw Modbus TCP request and reads one reply (empty on timeout).
std::vector<std::uint8_t> raw_exchange(int s, const std::vector<std::uint8_t>& req) {
  EXPECT_EQ(send(s, req.data(), req.size(), MSG_NOSIGNAL), static_cast<ssize_t>(req.size()));
  std::vector<std::uint8_t> got;
  const auto deadline = steady_clock::now() + std::chrono::seconds(5);
  while (steady_clock::now() < deadline) {
    pollfd p{s, POLLIN, 0};
    if (poll(&p, 1, 100) <= 0) continue;
    std::uint8_t buf[300];
    const ssize_t n = recv(s, buf, sizeof buf, 0);
    if (n <= 0) break;
    got.insert(got.end(), buf, buf + n);
    if (got.size() >= 6 && got.size() >= 6u + ((unsigned{got[4]} << 8) | got[5])) break;
  }
  return got;
}

// Functions the server does not serve get exception 01 with their own
// function code and the exception bit, whatever their payload, and the
// connection stays in step (fuzzing findings of #19: 0x83 was answered as
// 03 01; diagnostics 0x08 reset or timed out the connection).
TEST_F(Fixture, UnservedFunctionsGetExceptionOneAndTheConnectionStaysInStep) {
  const int s = raw_connect(server.tcp_port());
  ASSERT_GE(s, 0);
  const std::vector<std::uint8_t> high = {0, 7, 0, 0, 0, 6, 1, 0x83, 0, 0, 0, 1};
  EXPECT_EQ(raw_exchange(s, high), (std::vector<std::uint8_t>{0, 7, 0, 0, 0, 3, 1, 0x83, 0x01}));
  const std::vector<std::uint8_t> diagnostics = {0, 8, 0, 0, 0, 6, 1, 0x08, 0, 0, 0xA5, 0x37};
  EXPECT_EQ(raw_exchange(s, diagnostics),
            (std::vector<std::uint8_t>{0, 8, 0, 0, 0, 3, 1, 0x88, 0x01}));
  const std::vector<std::uint8_t> odd = {0, 9, 0, 0, 0, 5, 1, 0x2B, 0x0E, 0x01, 0x00};
  EXPECT_EQ(raw_exchange(s, odd), (std::vector<std::uint8_t>{0, 9, 0, 0, 0, 3, 1, 0xAB, 0x01}));
  // The same connection, in step: read input register 73 (the map version).
  const std::vector<std::uint8_t> read = {0, 10, 0, 0, 0, 6, 1, 0x04, 0, 0, 0, 1};
  const std::vector<std::uint8_t> reply = raw_exchange(s, read);
  ASSERT_EQ(reply.size(), 11u);
  EXPECT_EQ(reply[7], 0x04);
  close(s);
}

// A client that trickles its request (a byte every 70 ms, under the
// fixture's 100 ms byte timeout; the finding's was 150 ms under 200 ms) no
// longer holds the server: another client is answered at once (it waited
// 2.1 s before).
TEST_F(Fixture, ASlowClientDoesNotHoldTheOthers) {
  const int slow = raw_connect(server.tcp_port());
  ASSERT_GE(slow, 0);
  std::atomic<bool> done{false};
  std::thread trickle([&] {
    const std::uint8_t req[] = {0, 1, 0, 0, 0, 6, 1, 0x04, 0, 0, 0, 1};
    for (std::uint8_t b : req) {
      if (done.load()) break;
      if (send(slow, &b, 1, MSG_NOSIGNAL) != 1) break;
      std::this_thread::sleep_for(milliseconds(70));  // the attack's pace, not a wait
    }
  });
  std::this_thread::sleep_for(milliseconds(300));  // a few bytes into its request
  double worst_ms = 0;
  for (int i = 0; i < 5; ++i) {
    const auto t0 = steady_clock::now();
    EXPECT_EQ(client.input("protocol_version"), mb::kMapVersion);
    worst_ms = std::max(
        worst_ms, std::chrono::duration<double, std::milli>(steady_clock::now() - t0).count());
  }
  done.store(true);
  trickle.join();
  close(slow);
  // Before, the first read waited for the rest of the trickle (over 500 ms).
  EXPECT_LT(worst_ms, 250.0) << "a read waited behind the slow client";
}

// Idle connections cannot lock the others out: when the server is full, a
// new client displaces the one idle longest (idle at least 1 s); a client
// that is talking is never cut off (the limit test below).
TEST_F(Fixture, IdleConnectionsMakeWayForANewClient) {
  std::vector<int> idle;
  for (int i = 0; i < 7; ++i) {  // with the fixture's client: all 8 places
    idle.push_back(raw_connect(server.tcp_port()));
    ASSERT_GE(idle.back(), 0);
  }
  // The displacement is for clients idle 1 s: let that time pass.
  std::this_thread::sleep_for(milliseconds(1100));
  Client late(server.tcp_port());
  EXPECT_EQ(late.input("protocol_version"), mb::kMapVersion);
  EXPECT_GE(server.stats().clients_idle_closed, 1u);
  for (int s : idle) close(s);
}

// Many short connections from three clients at once are all served. (The
// listen backlog is no longer the client limit, 8 but 128; this test passes
// with either here, so it does not show that change: the fuzzing run's 15
// failures of 300 were not reproduced in-process.)
// 100 clients connecting at the same instant (a SCADA system's pollers after
// a network outage): the kernel queues every handshake, so each connect
// completes at once. With a listen backlog equal to the client limit (8,
// the finding of #19) the queue overflowed, the kernel dropped the extra
// handshakes, and those clients connected only after their SYN's first
// retransmission, 1 s later.
TEST_F(Fixture, SimultaneousConnectionsAreAllQueuedByTheKernel) {
  constexpr int kClients = 100;
  std::latch start(kClients);
  std::atomic<int> failed{0};
  std::atomic<std::int64_t> slowest_us{0};
  std::vector<std::thread> threads;
  for (int k = 0; k < kClients; ++k) {
    threads.emplace_back([&] {
      start.arrive_and_wait();
      const auto t0 = steady_clock::now();
      const int s = raw_connect(server.tcp_port());
      const auto us =
          std::chrono::duration_cast<std::chrono::microseconds>(steady_clock::now() - t0).count();
      std::int64_t seen = slowest_us.load();
      while (us > seen && !slowest_us.compare_exchange_weak(seen, us)) {
      }
      if (s < 0)
        ++failed;
      else
        close(s);
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(failed.load(), 0);
  EXPECT_LT(slowest_us.load(), 500000) << "a handshake waited for its SYN's retransmission";
}

TEST_F(Fixture, ABurstOfShortConnectionsIsServed) {
  std::atomic<int> failed{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < 3; ++t) {
    threads.emplace_back([&] {
      for (int i = 0; i < 100; ++i) {
        const int s = raw_connect(server.tcp_port());
        if (s < 0) {
          ++failed;
          continue;
        }
        const std::vector<std::uint8_t> reply =
            raw_exchange(s, {0, 1, 0, 0, 0, 6, 1, 0x04, 0, 0, 0, 1});
        if (reply.size() != 11u) ++failed;
        close(s);
      }
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(failed.load(), 0);
}

TEST_F(Fixture, ServesManyClientsAtOnceAndRefusesBeyondTheLimit) {
  // The fixture's client holds one of the 8 places; 7 more read at once.
  constexpr int kClients = 7;
  std::atomic<int> good{0};
  std::vector<std::thread> threads;
  for (int i = 0; i < kClients; ++i) {
    threads.emplace_back([&] {
      Client c(server.tcp_port());
      if (!c.connected()) return;
      int ok = 0;
      for (int k = 0; k < 100; ++k) ok += c.input("protocol_version") == mb::kMapVersion;
      good.fetch_add(ok);
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(good.load(), kClients * 100);

  // Eight held open, the ninth is closed at once.
  std::vector<std::unique_ptr<Client>> held;
  for (int i = 0; i < 7; ++i) {
    held.push_back(std::make_unique<Client>(server.tcp_port()));
    ASSERT_EQ(held.back()->input("protocol_version"), mb::kMapVersion);
  }
  Client extra(server.tcp_port());
  modbus_set_response_timeout(extra.ctx(), 2, 0);
  EXPECT_EQ(extra.input("protocol_version"), -1);
  EXPECT_GE(server.stats().clients_refused, 1u);
  held.clear();
  Client after(server.tcp_port());
  EXPECT_EQ(after.input("protocol_version"), mb::kMapVersion) << "a place is free again";
}

// --- RTU on a pseudo-terminal ---

std::uint16_t crc16(const std::vector<std::uint8_t>& d) {
  std::uint16_t crc = 0xFFFF;
  for (std::uint8_t b : d) {
    crc ^= b;
    for (int i = 0; i < 8; ++i)
      crc = (crc & 1) ? static_cast<std::uint16_t>((crc >> 1) ^ 0xA001) : crc >> 1;
  }
  return crc;
}

std::vector<std::uint8_t> rtu_frame(std::vector<std::uint8_t> pdu) {
  const std::uint16_t crc = crc16(pdu);
  pdu.push_back(static_cast<std::uint8_t>(crc & 0xFF));
  pdu.push_back(static_cast<std::uint8_t>(crc >> 8));
  return pdu;
}

// Reads `n` bytes or until `ms` pass (for "no answer": well over the
// server's 100 ms byte timeout).
std::vector<std::uint8_t> read_bytes(int fd, std::size_t n, int ms = 3000) {
  std::vector<std::uint8_t> got;
  const auto deadline = steady_clock::now() + milliseconds(ms);
  while (got.size() < n && steady_clock::now() < deadline) {
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, 100) <= 0) continue;
    std::uint8_t buf[300];
    const ssize_t r = read(fd, buf, sizeof buf);
    if (r > 0) got.insert(got.end(), buf, buf + r);
  }
  return got;
}

// A pseudo-terminal as the serial line: the test writes and reads at the
// master side; the server opens the other side as its device.
class SerialLine {
 public:
  SerialLine() : master_(posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC)) {
    if (master_ < 0 || grantpt(master_) != 0 || unlockpt(master_) != 0) {
      ADD_FAILURE() << "no pseudo-terminal: " << std::strerror(errno);
      return;
    }
    termios t{};
    tcgetattr(master_, &t);
    cfmakeraw(&t);
    tcsetattr(master_, TCSANOW, &t);
  }
  ~SerialLine() { close(master_); }
  SerialLine(const SerialLine&) = delete;
  SerialLine& operator=(const SerialLine&) = delete;
  int fd() const { return master_; }
  // The server's configuration: unit 7, 115200 baud, even parity, a byte
  // timeout of 100 ms.
  PortConfig config() const {
    PortConfig c = Rig::config();
    c.modbus.rtu_device = ptsname(master_);
    c.modbus.rtu_baud = 115200;
    c.modbus.rtu_parity = 'E';
    c.modbus.rtu_unit_id = 7;
    c.modbus.byte_timeout_ms = 100;
    return c;
  }
  void send(const std::vector<std::uint8_t>& bytes) const {
    ASSERT_EQ(write(master_, bytes.data(), bytes.size()), static_cast<ssize_t>(bytes.size()));
  }

 private:
  int master_;
};

TEST(ModbusRtuTest, AnswersFramesOnAPseudoTerminalAndIgnoresBadOnes) {
  SerialLine line;
  const int master = line.fd();
  PortConfig c = line.config();
  ControlPanel panel;
  {
    ModbusServer server(c, panel, kFacts);
    LoopThread loop(panel);
    // Read input registers 3..4 (protocol version, state) from unit 7.
    const auto read_req = rtu_frame({7, 0x04, 0, 3, 0, 2});
    // A frame with a bad CRC, and one for another unit: no answer to either.
    auto bad = read_req;
    bad.back() ^= 0x55;
    ASSERT_EQ(write(master, bad.data(), bad.size()), static_cast<ssize_t>(bad.size()));
    const auto other = rtu_frame({9, 0x04, 0, 3, 0, 2});
    // A gap longer than the byte timeout, so that the next frame starts clean.
    EXPECT_TRUE(read_bytes(master, 1, 500).empty()) << "no answer to a bad CRC";
    ASSERT_EQ(write(master, other.data(), other.size()), static_cast<ssize_t>(other.size()));
    EXPECT_TRUE(read_bytes(master, 1, 500).empty()) << "no answer for another unit";
    // On a multi-drop line unit 9 answers; the server lets that pass too.
    const auto other_reply = rtu_frame({9, 0x04, 4, 0, 1, 0, 2});
    ASSERT_EQ(write(master, other_reply.data(), other_reply.size()),
              static_cast<ssize_t>(other_reply.size()));
    EXPECT_TRUE(read_bytes(master, 1, 500).empty()) << "no answer to unit 9's reply";

    ASSERT_EQ(write(master, read_req.data(), read_req.size()),
              static_cast<ssize_t>(read_req.size()));
    const auto got = read_bytes(master, 9);
    ASSERT_EQ(got.size(), 9u);
    EXPECT_EQ(got[0], 7);
    EXPECT_EQ(got[1], 0x04);
    EXPECT_EQ(got[2], 4);
    EXPECT_EQ((got[3] << 8) | got[4], mb::kMapVersion);
    EXPECT_LE((got[5] << 8) | got[6], static_cast<int>(fw::State::kFault));
    EXPECT_EQ(crc16({got.begin(), got.end() - 2}), got[7] | (got[8] << 8));

    // An out-of-range write: exception 03 in an RTU frame.
    const auto wr = rtu_frame({7, 0x06, 0, 0, 0, 9});
    ASSERT_EQ(write(master, wr.data(), wr.size()), static_cast<ssize_t>(wr.size()));
    const auto ex = read_bytes(master, 5);
    ASSERT_EQ(ex.size(), 5u);
    EXPECT_EQ(ex[1], 0x86);
    EXPECT_EQ(ex[2], 0x03);
    EXPECT_GE(server.stats().receive_errors, 1u);
  }
}

// Functions the server does not serve get exception 01 on the serial line
// too, with their own function code, whatever their payload, and the line
// stays in step (#19: with libmodbus's framing, which takes an unknown
// function's frame to end after its code, diagnostics 0x08 got no answer
// at all). A known request that arrives in two pieces 50 ms apart (a USB
// adapter's latency), within the byte timeout, is still one request.
TEST(ModbusRtuTest, UnservedFunctionsGetExceptionOneAndTheLineStaysInStep) {
  SerialLine line;
  ControlPanel panel;
  ModbusServer server(line.config(), panel, kFacts);
  LoopThread loop(panel);
  const std::vector<std::pair<std::vector<std::uint8_t>, std::uint8_t>> unserved = {
      {{7, 0x08, 0, 0, 0xA5, 0x37}, 0x88},  // diagnostics: return query data
      {{7, 0x83, 0, 0, 0, 1}, 0x83},        // no such function: the code as sent
      {{7, 0x2B, 0x0E, 0x01, 0x00}, 0xAB},  // read device identification
      {{7, 0x01, 0, 0, 0, 8}, 0x81},        // read coils: a known layout, not served
  };
  for (const auto& [request, function] : unserved) {
    line.send(rtu_frame(request));
    EXPECT_EQ(read_bytes(line.fd(), 5), rtu_frame({7, function, 0x01})) << int{request[1]};
  }
  const auto read = rtu_frame({7, 0x04, 0, 3, 0, 1});
  line.send({read.begin(), read.begin() + 3});
  std::this_thread::sleep_for(milliseconds(50));  // the adapter's latency, not synchronisation
  line.send({read.begin() + 3, read.end()});
  const auto got = read_bytes(line.fd(), 7);
  ASSERT_EQ(got.size(), 7u);
  EXPECT_EQ(got[1], 0x04);
  EXPECT_EQ((got[3] << 8) | got[4], mb::kMapVersion);
  EXPECT_EQ(server.stats().exceptions, unserved.size());
  EXPECT_EQ(server.stats().receive_errors, 0u);
}

// mbpoll (Debian's package; libmodbus inside, none of our code) as the
// master on a second pseudo-terminal, bridged byte for byte to the
// server's line by a thread: it reads the map version and the state, and
// its report-slave-id request (0x11, which the server does not serve) is
// told "Illegal function" (exception 01).
class LineBridge {
 public:
  LineBridge(int a, int b) : thread_([this, a, b] { run(a, b); }) {}
  ~LineBridge() {
    stop_.store(true);
    thread_.join();
  }
  LineBridge(const LineBridge&) = delete;
  LineBridge& operator=(const LineBridge&) = delete;

 private:
  void run(int a, int b) {
    while (!stop_.load()) {
      pollfd fds[2] = {{a, POLLIN, 0}, {b, POLLIN, 0}};
      if (poll(fds, 2, 20) <= 0) continue;
      for (int k = 0; k < 2; ++k) {
        if ((fds[k].revents & POLLIN) == 0) continue;
        std::uint8_t buf[256];
        const ssize_t n = read(fds[k].fd, buf, sizeof buf);
        if (n > 0 && write(fds[1 - k].fd, buf, static_cast<std::size_t>(n)) != n) return;
      }
    }
  }
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

std::string run_mbpoll(const std::string& args) {
  std::string out;
  FILE* p = popen(("/usr/bin/mbpoll " + args + " 2>&1").c_str(), "r");
  if (p == nullptr) return "popen failed";
  char buf[256];
  while (fgets(buf, sizeof buf, p) != nullptr) out += buf;
  const int status = pclose(p);
  return out + "exit " + std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + "\n";
}

TEST(ModbusRtuTest, MbpollReadsRegistersAndIsToldWhatIsNotServed) {
  ASSERT_EQ(access("/usr/bin/mbpoll", X_OK), 0) << "mbpoll is not installed (./setup.sh)";
  SerialLine line;
  SerialLine client;
  ControlPanel panel;
  ModbusServer server(line.config(), panel, kFacts);
  LoopThread loop(panel);
  LineBridge bridge(line.fd(), client.fd());
  const std::string device = ptsname(client.fd());
  // Input registers 3 and 4 (PDU addresses): the map version and the state.
  const std::string read =
      run_mbpoll("-m rtu -a 7 -b 115200 -P even -t 3 -0 -r 3 -c 2 -1 -o 2 " + device);
  EXPECT_NE(read.find("[3]: \t" + std::to_string(mb::kMapVersion)), std::string::npos) << read;
  EXPECT_NE(read.find("exit 0"), std::string::npos) << read;
  const std::string report = run_mbpoll("-m rtu -a 7 -b 115200 -P even -u -1 -o 2 " + device);
  EXPECT_NE(report.find("Illegal function"), std::string::npos) << report;
  EXPECT_EQ(server.stats().receive_errors, 0u);
}

// pymodbus (Debian's python3-pymodbus: a Modbus implementation that shares
// no code with ours or with libmodbus) as a TCP client: it reads both
// tables whole, writes a holding register with functions 6 and 16 and reads
// it back, and is told exceptions 02, 03 and 01 where the map says
// (pymodbus_client.py).
TEST_F(Fixture, PymodbusReadsAndWritesTheMapAndGetsItsExceptions) {
  ASSERT_EQ(access("/usr/bin/python3", X_OK), 0);
  const std::string args =
      " --port " + std::to_string(server.tcp_port()) + " --inputs " +
      std::to_string(mb::kInputCount) + " --holdings " + std::to_string(mb::kHoldingCount) +
      " --version-address " + std::to_string(mb::named("protocol_version").address) +
      " --version " + std::to_string(mb::kMapVersion) + " --write-address " +
      std::to_string(mb::kAmplitudeScale.address) + " --write-value 1500 --bad-value 2001";
  std::string out;
  FILE* p = popen(("/usr/bin/python3 " DELTA_PYMODBUS_CLIENT + args + " 2>&1").c_str(), "r");
  ASSERT_NE(p, nullptr);
  char buf[256];
  while (fgets(buf, sizeof buf, p) != nullptr) out += buf;
  const int status = pclose(p);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << out;
  EXPECT_NE(out.find("map version " + std::to_string(mb::kMapVersion)), std::string::npos) << out;
  // The write reached the controller's settings, as libmodbus reads them.
  std::uint16_t amplitude = 0;
  ASSERT_EQ(modbus_read_registers(client.ctx(), mb::kAmplitudeScale.address, 1, &amplitude), 1);
  EXPECT_EQ(amplitude, 1500);
  EXPECT_EQ(client.input("last_rejection"), static_cast<int>(mb::Rejection::kIllegalFunction));
  std::cout << out;
}

TEST(ModbusServerTest, StartUpErrorsNameTheAddressOrDevice) {
  ControlPanel panel;
  PortConfig c = Rig::config();
  c.modbus.rtu_device = "/dev/no-such-tty";
  try {
    ModbusServer s(c, panel, kFacts);
    FAIL() << "expected a ModbusError";
  } catch (const ModbusError& e) {
    EXPECT_NE(std::string(e.what()).find("modbus.rtu_device = /dev/no-such-tty: cannot open"),
              std::string::npos)
        << e.what();
  }
  // A port already taken.
  PortConfig a = Rig::config();
  a.modbus.tcp = "127.0.0.1:0";
  ModbusServer first(a, panel, kFacts);
  PortConfig b = Rig::config();
  b.modbus.tcp = "127.0.0.1:" + std::to_string(first.tcp_port());
  try {
    ModbusServer second(b, panel, kFacts);
    FAIL() << "expected a ModbusError";
  } catch (const ModbusError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot listen"), std::string::npos) << e.what();
  }
}

// The custom trajectory (3): its block uploaded in one write multiple,
// read back as written, checked by the controller when it is selected (or
// rewritten while selected), refused with the reason, tick and joint.
delta::BlendedFourierTrajectory path1_as_custom(double scale) {
  delta::BlendedFourierTrajectory t;
  EXPECT_TRUE(delta::make_fourier_excitation(delta::kDefaultGeometry, {0.0, 0.0, -0.42}, 5, 0.2,
                                             0.35, 1, t.fourier));
  for (unsigned j = 0; j < 3; ++j) {
    for (auto& a : t.fourier.a_rad_s[j]) a *= scale;
    for (auto& b : t.fourier.b_rad_s[j]) b *= scale;
  }
  t.blend_s = 1.0;
  t.periods = 2;
  return t;
}

TEST_F(Fixture, ACustomTrajectoryIsUploadedCheckedAndRefusedByItsLimit) {
  // Nothing uploaded yet: selecting it is refused as an invalid trajectory.
  EXPECT_EQ(client.write(mb::kTrajectory, 3), EMBXILVAL);
  EXPECT_EQ(client.input("last_rejection"), static_cast<int>(mb::Rejection::kTrajectoryLimit));
  EXPECT_EQ(client.input("trajectory_check"),
            static_cast<int>(fw::TrajectoryFault::kInvalidConfig));

  const std::vector<std::uint16_t> good = delta::custom_trajectory_block(path1_as_custom(1.0));
  ASSERT_EQ(good.size(), mb::kCustomCount);
  ASSERT_EQ(client.write_many(mb::kCustomFirst, good), 0);
  std::vector<std::uint16_t> back(mb::kCustomCount);
  ASSERT_EQ(modbus_read_registers(client.ctx(), mb::kCustomFirst, mb::kCustomCount, back.data()),
            mb::kCustomCount);
  EXPECT_EQ(back, good);
  ASSERT_EQ(client.write(mb::kTrajectory, 3), 0);  // checked and accepted
  ASSERT_EQ(modbus_read_registers(client.ctx(), mb::kTrajectory.address, 1, back.data()), 1);
  EXPECT_EQ(back[0], 3);
  // The controller's trajectory is the one uploaded: the same check as
  // the core's on the same coefficients converted directly.
  const PortConfig config = modbus_config();
  const fw::FourierConfig uploaded = fw_linux::custom_trajectory(good.data(), config).fourier;
  const fw::FourierConfig direct =
      fw_linux::fourier_config(path1_as_custom(1.0), config.period_us).fourier;
  EXPECT_EQ(uploaded.base_frequency_mHz, direct.base_frequency_mHz);
  EXPECT_EQ(uploaded.harmonics, direct.harmonics);
  EXPECT_EQ(uploaded.periods, direct.periods);
  for (unsigned j = 0; j < 3; ++j) {
    // 1 nrad in the registers is a quarter of Q3.28's step: at most one step apart.
    EXPECT_LE(std::abs(uploaded.q0_rad[j].raw() - direct.q0_rad[j].raw()), 1);
    for (unsigned k = 0; k < 5; ++k) {
      EXPECT_LE(
          std::abs(uploaded.sin_amplitude_rad[j][k].raw() - direct.sin_amplitude_rad[j][k].raw()),
          1);
      EXPECT_LE(
          std::abs(uploaded.cos_amplitude_rad[j][k].raw() - direct.cos_amplitude_rad[j][k].raw()),
          1);
    }
  }

  // Five times the amplitude leaves the joint range (the check's first
  // finding, before the velocity limit): the write is refused and the
  // block keeps the good trajectory.
  const std::vector<std::uint16_t> fast = delta::custom_trajectory_block(path1_as_custom(5.0));
  EXPECT_EQ(client.write_many(mb::kCustomFirst, fast), EMBXILVAL);
  const auto r = client.inputs();
  ASSERT_FALSE(r.empty());
  EXPECT_EQ(value(r.data(), "last_rejection"), static_cast<int>(mb::Rejection::kTrajectoryLimit));
  EXPECT_EQ(value(r.data(), "trajectory_check"),
            static_cast<int>(fw::TrajectoryFault::kJointLimit));
  EXPECT_GT(value(r.data(), "trajectory_check_tick"), 0);
  EXPECT_GE(value(r.data(), "trajectory_check_joint"), 1);
  ASSERT_EQ(modbus_read_registers(client.ctx(), mb::kCustomFirst, mb::kCustomCount, back.data()),
            mb::kCustomCount);
  EXPECT_EQ(back, good);

  // 100 periods at 50 mHz last 2000 s, more ticks than the check walks
  // (fw::kMaxTrajectoryTicks): refused as too long, the block unchanged.
  delta::BlendedFourierTrajectory slow = path1_as_custom(1.0);
  slow.fourier.base_frequency_hz = 0.05;
  slow.periods = 100;
  EXPECT_EQ(client.write_many(mb::kCustomFirst, delta::custom_trajectory_block(slow)), EMBXILVAL);
  EXPECT_EQ(client.input("trajectory_check"), static_cast<int>(fw::TrajectoryFault::kTooLong));
  EXPECT_EQ(client.input("trajectory_check_tick"), static_cast<int>(fw::kMaxTrajectoryTicks) + 1);
  ASSERT_EQ(modbus_read_registers(client.ctx(), mb::kCustomFirst, mb::kCustomCount, back.data()),
            mb::kCustomCount);
  EXPECT_EQ(back, good);

  // Registers out of range name themselves.
  EXPECT_EQ(client.write(mb::kCustomHarmonics, 7), EMBXILVAL);
  EXPECT_EQ(client.input("last_rejection"), static_cast<int>(mb::Rejection::kOutOfRange));
  EXPECT_EQ(client.input("last_rejection_register"), mb::kCustomHarmonics.address);
  EXPECT_EQ(client.write(mb::kCustomBaseFrequency, 0), EMBXILVAL);
  EXPECT_EQ(client.write(mb::kCustomBlend, 60001), EMBXILVAL);
}

TEST(RegisterMapTest, DocsModbusMdListsEveryRegisterAsTheMapDefinesIt) {
  std::ifstream in("docs/modbus.md");
  ASSERT_TRUE(in.good()) << "run from the source directory";
  const std::string doc((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::size_t rows = 0;
  for (const mb::Register& r : mb::kRegisters) {
    const bool input = r.table == mb::Table::kInput;
    const char* types[] = {"u16", "i16", "u32", "i32"};
    std::string scale = r.scale_num == 1 && r.scale_den == 1
                            ? (std::string(r.unit).empty() ? "–" : r.unit)
                            : std::string(r.unit) + " × " + std::to_string(r.scale_num) + "/" +
                                  std::to_string(r.scale_den);
    const std::string row = "| " + std::to_string((input ? 30001 : 40001) + r.address) + " | " +
                            std::to_string(r.address) + " | `" + r.name + "` | " +
                            types[static_cast<int>(r.type)] + " | " + scale + " | " +
                            r.description + " |";
    EXPECT_NE(doc.find(row), std::string::npos) << "docs/modbus.md lacks or differs on:\n" << row;
    ++rows;
  }
  EXPECT_EQ(rows, mb::kRegisters.size());
}

TEST(RegisterMapTest, RegistersDoNotOverlapAndFitTheirTables) {
  for (std::size_t i = 0; i < mb::kRegisters.size(); ++i) {
    const mb::Register& a = mb::kRegisters[i];
    EXPECT_NE(std::string(a.name), "");
    for (std::size_t k = 0; k < i; ++k) {
      const mb::Register& b = mb::kRegisters[k];
      EXPECT_NE(std::string(a.name), b.name);
      if (a.table != b.table) continue;
      const bool apart =
          a.address + mb::width(a.type) <= b.address || b.address + mb::width(b.type) <= a.address;
      EXPECT_TRUE(apart) << a.name << " overlaps " << b.name;
    }
  }
  std::vector<std::uint16_t> regs(mb::kInputCount);
  mb::encode(mb::named("q1"), -123456, regs.data());
  EXPECT_EQ(mb::decode(mb::named("q1"), regs.data()), -123456);
  mb::encode(mb::named("cycle_counter"), 0x12345678, regs.data());
  EXPECT_EQ(regs[6], 0x1234) << "high word first";
  EXPECT_EQ(regs[7], 0x5678);
}

}  // namespace
}  // namespace fw_linux
