#include "fw_linux/bus_load.hpp"

#include <iomanip>
#include <sstream>

#include "delta/can/protocol.hpp"

namespace fw_linux {

namespace {

// A heartbeat (1 data byte) from each of the three drives and from the
// controller every heartbeat_ms.
double heartbeat_bits_per_s(const PortConfig& c) {
  namespace p = delta::can::protocol;
  return 4.0 * p::worst_case_frame_bits(1) * 1000.0 / c.heartbeat_ms;
}

double percent_at(const PortConfig& c, std::uint32_t bits_per_cycle, std::uint32_t period_us) {
  const double bits_per_s = bits_per_cycle * 1e6 / period_us + heartbeat_bits_per_s(c);
  return 100.0 * bits_per_s / c.can_bitrate;
}

// The shortest period that divides one second (as period_us must) and
// keeps the load at or under the limit; 0 where none does.
std::uint32_t shortest_period_within_limit(const PortConfig& c, std::uint32_t bits_per_cycle) {
  for (std::uint32_t period_us = c.period_us; period_us <= 1000000; ++period_us) {
    if (1000000 % period_us != 0) continue;
    if (percent_at(c, bits_per_cycle, period_us) <= kBusLoadLimitPercent) return period_us;
  }
  return 0;
}

// `value` with `decimals` digits after the point.
std::string fixed(double value, int decimals) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(decimals) << value;
  return out.str();
}

}  // namespace

BusLoad bus_load(const PortConfig& c) {
  BusLoad load;
  load.bits_per_cycle = delta::can::protocol::cycle_bits(
      c.velocity_pdo, true, c.sync_counter_overflow != 0, c.arm_encoders);
  load.percent = percent_at(c, load.bits_per_cycle, c.period_us);
  return load;
}

std::string describe_bus_load(const PortConfig& c) {
  const BusLoad load = bus_load(c);
  return "bus load: " + fixed(load.percent, 1) + " % of " + fixed(c.can_bitrate / 1e3, 0) +
         " kbit/s (can_bitrate), " + std::to_string(load.bits_per_cycle) + " bits per cycle at " +
         fixed(1e6 / c.period_us, 0) + " Hz and the heartbeats' " +
         fixed(100.0 * heartbeat_bits_per_s(c) / c.can_bitrate, 1) + " %";
}

std::optional<std::string> bus_load_warning(const PortConfig& c) {
  const BusLoad load = bus_load(c);
  if (load.percent <= kBusLoadLimitPercent) return std::nullopt;
  std::string w = describe_bus_load(c) + ": above the " + fixed(kBusLoadLimitPercent, 0) +
                  " % a classical CAN bus carries with margin, the drives' TPDOs come late on a "
                  "real bus and their cycles are left out as stale. ";
  const std::uint32_t period = shortest_period_within_limit(c, load.bits_per_cycle);
  w += period != 0 ? "Set period_us = " + std::to_string(period) + " (" + fixed(1e6 / period, 0) +
                         " Hz) or longer"
                   : std::string("No period brings it under");
  return w +
         ", or leave out what costs it (velocity_pdo, sync_counter_overflow, arm_encoders; "
         "docs/protocol.md, \"Bus load\")";
}

}  // namespace fw_linux
