// The controller's own CANopen presence on the bus: its heartbeat (0x710,
// every heartbeat_ms of cycles, which the drives supervise through 0x1016)
// and an emergency (0x090) when it enters or leaves a fault, with the fault
// code and cycle.
#pragma once

#include <array>
#include <cstdint>

#include "fw/faults.hpp"
#include "fw_linux/canopen_master.hpp"
#include "fw_linux/config.hpp"

namespace fw_linux {

class Announcer {
 public:
  Announcer(FrameSink& bus, const PortConfig& c);
  // After every control step.
  void after_step(fw::Fault fault, std::uint32_t cycle);

 private:
  void send(std::uint32_t id, std::uint8_t dlc, const std::array<std::uint8_t, 8>& data);
  FrameSink& bus_;
  std::uint32_t heartbeat_cycles_;
  std::uint32_t since_heartbeat_{0};
  fw::Fault last_fault_{fw::Fault::kNone};
};

}  // namespace fw_linux
