#include "fw_linux/announcer.hpp"

#include <algorithm>

#include "delta/can/cia402.hpp"
#include "delta/can/protocol.hpp"

namespace fw_linux {

namespace p = delta::can::protocol;

Announcer::Announcer(FrameSink& bus, const PortConfig& c)
    : bus_(bus),
      heartbeat_cycles_(std::max<std::uint32_t>(1, c.heartbeat_ms * 1000u / c.period_us)) {}

void Announcer::after_step(fw::Fault fault, std::uint32_t cycle) {
  if (fault != last_fault_) {
    std::array<std::uint8_t, 8> d{};
    const std::uint16_t code =
        fault == fw::Fault::kNone
            ? delta::can::od::kEmcyErrorReset
            : static_cast<std::uint16_t>(delta::can::od::kEmcyControllerFaultBase +
                                         static_cast<std::uint16_t>(fault));
    const p::Message& m = p::kControllerEmcy;
    p::pack(d, p::kControllerEmcyErrorCode, code);
    p::pack(d, p::kControllerEmcyErrorRegister, fault == fw::Fault::kNone ? 0 : 1);
    p::pack(d, p::kControllerEmcyFaultCode, static_cast<std::uint16_t>(fault));
    p::pack(d, p::kControllerEmcyCycle, cycle);
    send(m.base_id, m.dlc, d);
    last_fault_ = fault;
  }
  if (++since_heartbeat_ >= heartbeat_cycles_) {
    since_heartbeat_ = 0;
    std::array<std::uint8_t, 8> d{};
    d[0] = p::kNmtStateOperational;
    send(p::kControllerHeartbeat.base_id, p::kControllerHeartbeat.dlc, d);
  }
}

void Announcer::send(std::uint32_t id, std::uint8_t dlc, const std::array<std::uint8_t, 8>& data) {
  delta::can::Frame f;
  f.id = id;
  f.dlc = dlc;
  f.data = data;
  bus_.send(f);
}

}  // namespace fw_linux
