// The firmware's Modbus server (libmodbus) against the real control loop,
// for firmware_modbus_tests: the controller, the CANopen master and the
// emulator closed in-process and stepped by a loop thread, with the run
// coordinator and the control panel of delta_fw; a libmodbus TCP client on
// loopback, and the fixture that starts them.
#pragma once

#include <gtest/gtest.h>
#include <modbus/modbus.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <sstream>
#include <thread>
#include <vector>

#include "delta/modbus/register_map.hpp"
#include "delta/trajectory_file.hpp"
#include "fw_linux/control_panel.hpp"
#include "fw_linux/modbus_server.hpp"
#include "fw_linux/run_coordinator.hpp"
#include "in_process_rig.hpp"

namespace fw_linux::modbus_test {

// The loop thread: cycles the in-process rig like run_port's loop, about
// every 50 us, until destroyed.
class LoopThread {
 public:
  explicit LoopThread(ControlPanel& panel);
  ~LoopThread();
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
  void cycle();

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

// The rig's configuration with Modbus TCP on a port the kernel chooses and
// a 100 ms byte timeout.
PortConfig modbus_config();

class Client {
 public:
  explicit Client(int port);
  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;
  bool connected() const { return connected_; }
  // The whole input table; empty on an error.
  std::vector<std::uint16_t> inputs();
  std::int64_t input(const char* name);
  // 0 on success, else errno (EMBX* for a Modbus exception).
  int write(const delta::modbus::Register& r, std::uint16_t v);
  int write_many(int first, const std::vector<std::uint16_t>& v);
  modbus_t* ctx() { return ctx_; }

 private:
  modbus_t* ctx_;
  bool connected_{false};
};

// Polls the input registers until `done` holds or 20 s pass.
template <class Pred>
bool poll_until(Client& c, Pred done) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < deadline) {
    const auto r = c.inputs();
    if (!r.empty() && done(r.data())) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return false;
}

// The named register's value in the input table `regs`.
std::int64_t value(const std::uint16_t* regs, const char* name);

// path1's Fourier excitation as a custom trajectory, its amplitudes scaled.
delta::BlendedFourierTrajectory path1_as_custom(double scale);

// The program the registers describe: its version, and that delta_boot
// started it after a new program crashed on trial.
inline const ProgramFacts kFacts{{3, 14, 15}, fw::update::RevertReason::kCrashed};

// The server, the loop and a connected client, with the controller ready.
struct Fixture : ::testing::Test {
  Fixture();
  void SetUp() override;
  ControlPanel panel;
  ModbusServer server;
  LoopThread loop;
  Client client;
};

}  // namespace fw_linux::modbus_test
