// Who may move the robot over Modbus TCP (modbus.allow, docs/security.md),
// with the real programs on vcan and two loopback source addresses: the
// default allow list (127.0.0.1 and ::1) serves a client from 127.0.0.2
// reads but refuses its writes with exception 1 and logs it, and the
// client from 127.0.0.1 still selects a trajectory and starts a run.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <optional>

#include "child_process.hpp"
#include "pipeline_programs.hpp"
#include "raw_modbus.hpp"

namespace {

using namespace std::chrono_literals;

constexpr int kPort = 15031;
// Holding registers trajectory (0) and command (4); input register run_id
// (11): docs/modbus.md.
constexpr std::uint16_t kTrajectory = 0;
constexpr std::uint16_t kCommand = 4;
constexpr std::uint16_t kRunId = 11;

std::optional<std::uint16_t> run_id(hil::RawModbus& client) {
  const auto r = client.read_input(kRunId, 1);
  return r ? std::optional<std::uint16_t>((*r)[0]) : std::nullopt;
}

TEST(ModbusAllowList, WritesFromAnotherAddressAreRefusedAndLoggedTheAllowedClientStartsARun) {
  hil::Child emu = hil::start_emulator({"--plant", "lumped"});
  hil::Child fw = hil::start_firmware_with_modbus(kPort);
  hil::RawModbus other(kPort, "127.0.0.2");
  ASSERT_TRUE(other.connected());
  ASSERT_EQ(run_id(other), std::optional<std::uint16_t>(0)) << "reads are served to anyone";
  const auto refused = other.write(kCommand, 1);  // start
  ASSERT_TRUE(refused.has_value());
  EXPECT_EQ((*refused)[0], 0x86) << "an exception answer to function 6";
  EXPECT_EQ((*refused)[1], 1) << "exception 1, illegal function";
  // The whole line: the output may arrive in pieces.
  EXPECT_TRUE(
      fw.wait_for_output("refused a write (function 0x6) from 127.0.0.2: not in "
                         "modbus.allow = 127.0.0.1/32,::1/128",
                         10s))
      << fw.err();
  EXPECT_EQ(run_id(other), std::optional<std::uint16_t>(0)) << "nothing started";
  hil::RawModbus allowed(kPort, "127.0.0.1");
  ASSERT_TRUE(allowed.connected());
  const auto selected = allowed.write(kTrajectory, 2);  // pick-and-place
  ASSERT_TRUE(selected.has_value());
  EXPECT_EQ((*selected)[0], 6) << "the echo of function 6";
  const auto started = allowed.write(kCommand, 1);
  ASSERT_TRUE(started.has_value());
  EXPECT_EQ((*started)[0], 6);
  EXPECT_TRUE(fw.wait_for_output("delta_fw: running", 30s)) << fw.err();
  EXPECT_EQ(run_id(allowed), std::optional<std::uint16_t>(1)) << "the allowed client's start";
  EXPECT_EQ(allowed.write(kCommand, 2).value_or(std::array<std::uint8_t, 2>{})[0], 6);  // stop
  fw.terminate(30s);
  emu.terminate(30s);
}

}  // namespace
