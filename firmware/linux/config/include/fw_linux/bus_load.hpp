// The cyclic traffic a configuration puts on the bus (docs/protocol.md,
// "Bus load"): each control cycle's frames at their worst-case length with
// bit stuffing, and the heartbeats, as a share of can_bitrate.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "fw_linux/config.hpp"

namespace fw_linux {

// Above this share a classical CAN bus has too little margin for the
// drives' TPDOs to come within the response window (docs/protocol.md).
inline constexpr double kBusLoadLimitPercent = 70.0;

struct BusLoad {
  std::uint32_t bits_per_cycle{0};  // SYNC, PDOs and log frames of one cycle
  double percent{0.0};              // of can_bitrate, the heartbeats included
};

BusLoad bus_load(const PortConfig& c);

// The load, for --check-config: "bus load: 64.0 % of 1000 kbit/s (...)".
std::string describe_bus_load(const PortConfig& c);

// Where the load is above kBusLoadLimitPercent: what it is and what to do
// (the shortest period that brings it under, the PDOs that cost it).
std::optional<std::string> bus_load_warning(const PortConfig& c);

}  // namespace fw_linux
