// The Modbus server runs the controller: identity and live values, a run
// to its end, stop, the e-stop and reset, refusals and their reasons, and
// the custom trajectory's block.
#include <gtest/gtest.h>
#include <modbus/modbus.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <optional>
#include <thread>
#include <vector>

#include "delta/custom_trajectory_block.hpp"
#include "delta/model_q.hpp"
#include "fw_linux/trajectories.hpp"
#include "host_id/cli.hpp"
#include "modbus_fixture.hpp"

namespace fw_linux {
namespace {

namespace mb = delta::modbus;
using modbus_test::Client;
using modbus_test::Fixture;
using modbus_test::modbus_config;
using modbus_test::path1_as_custom;
using modbus_test::poll_until;
using modbus_test::value;

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
  EXPECT_EQ(value(r.data(), "collision_detect"), 0);  // off by default
  EXPECT_EQ(value(r.data(), "collision_joint"), 0);
  EXPECT_NE(out.str().find("  collision  detector off\n"), std::string::npos) << out.str();
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

// The custom trajectory's block as the server holds it equals `block`.
void expect_custom_block(Client& client, const std::vector<std::uint16_t>& block) {
  std::vector<std::uint16_t> back(mb::kCustomCount);
  ASSERT_EQ(modbus_read_registers(client.ctx(), mb::kCustomFirst, mb::kCustomCount, back.data()),
            mb::kCustomCount);
  EXPECT_EQ(back, block);
}

// The controller's trajectory is the one uploaded: the same check as the
// core's on the same coefficients converted directly.
void expect_uploaded_as_converted_directly(const std::vector<std::uint16_t>& block,
                                           const delta::BlendedFourierTrajectory& trajectory) {
  const PortConfig config = modbus_config();
  const fw::FourierConfig uploaded = fw_linux::custom_trajectory(block.data(), config).fourier;
  const fw::FourierConfig direct = fw_linux::fourier_config(trajectory, config.period_us).fourier;
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
}

// Five times the amplitude leaves the joint range (the check's first
// finding, before the velocity limit): the write is refused and the block
// keeps the good trajectory.
void expect_too_large_refused(Client& client, const std::vector<std::uint16_t>& good) {
  const std::vector<std::uint16_t> fast = delta::custom_trajectory_block(path1_as_custom(5.0));
  EXPECT_EQ(client.write_many(mb::kCustomFirst, fast), EMBXILVAL);
  const auto r = client.inputs();
  ASSERT_FALSE(r.empty());
  EXPECT_EQ(value(r.data(), "last_rejection"), static_cast<int>(mb::Rejection::kTrajectoryLimit));
  EXPECT_EQ(value(r.data(), "trajectory_check"),
            static_cast<int>(fw::TrajectoryFault::kJointLimit));
  EXPECT_GT(value(r.data(), "trajectory_check_tick"), 0);
  EXPECT_GE(value(r.data(), "trajectory_check_joint"), 1);
  ASSERT_NO_FATAL_FAILURE(expect_custom_block(client, good));
}

// 100 periods at 50 mHz last 2000 s, more ticks than the check walks
// (fw::kMaxTrajectoryTicks): refused as too long, the block unchanged.
void expect_too_long_refused(Client& client, const std::vector<std::uint16_t>& good) {
  delta::BlendedFourierTrajectory slow = path1_as_custom(1.0);
  slow.fourier.base_frequency_hz = 0.05;
  slow.periods = 100;
  EXPECT_EQ(client.write_many(mb::kCustomFirst, delta::custom_trajectory_block(slow)), EMBXILVAL);
  EXPECT_EQ(client.input("trajectory_check"), static_cast<int>(fw::TrajectoryFault::kTooLong));
  EXPECT_EQ(client.input("trajectory_check_tick"), static_cast<int>(fw::kMaxTrajectoryTicks) + 1);
  ASSERT_NO_FATAL_FAILURE(expect_custom_block(client, good));
}

// The custom trajectory (3): its block uploaded in one write multiple,
// read back as written, checked by the controller when it is selected (or
// rewritten while selected), refused with the reason, tick and joint.
TEST_F(Fixture, ACustomTrajectoryIsUploadedCheckedAndRefusedByItsLimit) {
  // Nothing uploaded yet: selecting it is refused as an invalid trajectory.
  EXPECT_EQ(client.write(mb::kTrajectory, 3), EMBXILVAL);
  EXPECT_EQ(client.input("last_rejection"), static_cast<int>(mb::Rejection::kTrajectoryLimit));
  EXPECT_EQ(client.input("trajectory_check"),
            static_cast<int>(fw::TrajectoryFault::kInvalidConfig));

  const std::vector<std::uint16_t> good = delta::custom_trajectory_block(path1_as_custom(1.0));
  ASSERT_EQ(good.size(), mb::kCustomCount);
  ASSERT_EQ(client.write_many(mb::kCustomFirst, good), 0);
  ASSERT_NO_FATAL_FAILURE(expect_custom_block(client, good));
  ASSERT_EQ(client.write(mb::kTrajectory, 3), 0);  // checked and accepted
  std::uint16_t trajectory = 0;
  ASSERT_EQ(modbus_read_registers(client.ctx(), mb::kTrajectory.address, 1, &trajectory), 1);
  EXPECT_EQ(trajectory, 3);
  expect_uploaded_as_converted_directly(good, path1_as_custom(1.0));
  ASSERT_NO_FATAL_FAILURE(expect_too_large_refused(client, good));
  ASSERT_NO_FATAL_FAILURE(expect_too_long_refused(client, good));

  // Registers out of range name themselves.
  EXPECT_EQ(client.write(mb::kCustomHarmonics, 7), EMBXILVAL);
  EXPECT_EQ(client.input("last_rejection"), static_cast<int>(mb::Rejection::kOutOfRange));
  EXPECT_EQ(client.input("last_rejection_register"), mb::kCustomHarmonics.address);
  EXPECT_EQ(client.write(mb::kCustomBaseFrequency, 0), EMBXILVAL);
  EXPECT_EQ(client.write(mb::kCustomBlend, 60001), EMBXILVAL);
}

}  // namespace
}  // namespace fw_linux
