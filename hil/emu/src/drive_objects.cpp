// The emulated drive's object dictionary as its SDO server (common's
// delta::can::sdo::Server) sees it: the CiA 301 communication objects and
// the CiA 402 objects the product uses, with their sizes, access and value
// checks. The protocol (lengths, segments, blocks, aborts) is the server's.
#include "drive_objects.hpp"

#include <cmath>
#include <cstring>
#include <string_view>

#include "delta/can/protocol.hpp"

namespace emu {

namespace p = delta::can::protocol;
namespace od = delta::can::od;
namespace sdo = delta::can::sdo;
namespace cia = delta::can::cia402;

namespace {

constexpr std::string_view kHardwareVersion = "vcan";
constexpr std::string_view kEmulatorSoftwareVersion = "delta_drive_emu " DELTA_VERSION;
// CiA 402: bit 9 of 0x6502, cyclic synchronous torque mode; the only one.
constexpr std::uint32_t kSupportedModesCst = 1u << 9;

}  // namespace

// The objects, in index order. Values are their bit patterns, little
// endian on the bus.
auto Emulator::DriveObjects::scalars() -> std::span<const DriveTable::Scalar> {
  constexpr sdo::AbortCode ok = sdo::kNoAbort;
  static const DriveTable::Scalar kObjects[] = {
      {0x1000, 0, 4, [](const DriveContext&) { return od::kDeviceTypeServo; }, nullptr},
      {0x1001, 0, 1,
       [](const DriveContext& c) { return c.d.state == cia::State::kFault ? 1u : 0u; }, nullptr},
      {0x1006, 0, 4, [](const DriveContext& c) { return c.d.cycle_us; },
       [](DriveContext& c, std::uint32_t v) {
         if (v < 100 || v > 1000000) return sdo::kAbortValueRange;
         c.d.cycle_us = v;
         return ok;
       }},
      {0x1016, 0, 1, [](const DriveContext&) { return 1u; }, nullptr},
      {0x1016, 1, 4, [](const DriveContext& c) { return c.d.consumer; },
       [](DriveContext& c, std::uint32_t v) {
         const std::uint8_t node = od::consumer_heartbeat_node(v);
         if ((v >> 24) != 0 ||
             (od::consumer_heartbeat_timeout_ms(v) != 0 && (node == 0 || node > 127)))
           return sdo::kAbortValueRange;
         c.d.consumer = v;
         c.d.consumer_armed = false;
         return ok;
       }},
      {0x1017, 0, 2, [](const DriveContext& c) { return std::uint32_t{c.d.heartbeat_ms}; },
       [](DriveContext& c, std::uint32_t v) {
         c.d.heartbeat_ms = static_cast<std::uint16_t>(v);
         c.d.next_heartbeat_sim_us = c.e.sim_us_;
         return ok;
       }},
      {0x1018, 0, 1, [](const DriveContext&) { return 4u; }, nullptr},
      {0x1018, 1, 4, [](const DriveContext& c) { return c.e.identity_.vendor_id; }, nullptr},
      {0x1018, 2, 4, [](const DriveContext& c) { return c.e.identity_.product_code; }, nullptr},
      {0x1018, 3, 4, [](const DriveContext& c) { return c.e.identity_.revision; }, nullptr},
      {0x1018, 4, 4, [](const DriveContext& c) { return 0x00010000u + c.d.node; }, nullptr},
      // RPDO1 and TPDO1: fixed (docs/protocol.md); synchronous.
      {0x1400, 0, 1, [](const DriveContext&) { return 2u; }, nullptr},
      {0x1400, 1, 4,
       [](const DriveContext& c) { return std::uint32_t{p::cob_id(p::kRpdo1, c.d.node)}; },
       nullptr},
      {0x1400, 2, 1, [](const DriveContext&) { return 1u; }, nullptr},
      {0x1800, 0, 1, [](const DriveContext&) { return 2u; }, nullptr},
      {0x1800, 1, 4,
       [](const DriveContext& c) { return std::uint32_t{p::cob_id(p::kTpdo1, c.d.node)}; },
       nullptr},
      {0x1800, 2, 1, [](const DriveContext&) { return 1u; }, nullptr},
      {0x1801, 0, 1, [](const DriveContext&) { return 2u; }, nullptr},
      {0x1801, 1, 4, [](const DriveContext& c) { return c.d.tpdo2_cob; },
       [](DriveContext& c, std::uint32_t v) {
         if ((v & 0x7FF) != p::cob_id(p::kTpdo2, c.d.node)) return sdo::kAbortValueRange;
         c.d.tpdo2_cob = v;
         return ok;
       }},
      {0x1801, 2, 1, [](const DriveContext&) { return 1u; }, nullptr},  // every SYNC
      {0x6040, 0, 2, [](const DriveContext& c) { return std::uint32_t{c.d.controlword}; },
       [](DriveContext& c, std::uint32_t v) {
         c.e.apply_controlword(c.d, static_cast<std::uint16_t>(v));
         return ok;
       }},
      {0x6041, 0, 2,
       [](const DriveContext& c) { return std::uint32_t{cia::encode_statusword(c.d.state)}; },
       nullptr},
      {0x6060, 0, 1,
       [](const DriveContext& c) { return std::uint32_t{static_cast<std::uint8_t>(c.d.mode)}; },
       [](DriveContext& c, std::uint32_t v) {
         const auto mode = static_cast<std::int8_t>(v & 0xFF);
         if (mode != cia::kModeCyclicSynchronousTorque) return sdo::kAbortValueRange;
         c.d.mode = mode;
         return ok;
       }},
      {0x6061, 0, 1,
       [](const DriveContext& c) { return std::uint32_t{static_cast<std::uint8_t>(c.d.mode)}; },
       nullptr},
      {0x6064, 0, 4,
       [](const DriveContext& c) {
         const unsigned j = c.d.node - p::kFirstDriveNode;
         return static_cast<std::uint32_t>(c.e.position_counts(c.d, c.e.plant_->state().q_rad[j]));
       },
       nullptr},
      {0x606C, 0, 4,
       [](const DriveContext& c) {
         const unsigned j = c.d.node - p::kFirstDriveNode;
         return static_cast<std::uint32_t>(
             c.e.velocity_counts_s(c.d, c.e.plant_->state().qd_rad_s[j]));
       },
       nullptr},
      {0x6071, 0, 2,
       [](const DriveContext& c) {
         return std::uint32_t{static_cast<std::uint16_t>(c.d.target_torque_pm)};
       },
       [](DriveContext& c, std::uint32_t v) {
         c.d.target_torque_pm = static_cast<std::int16_t>(static_cast<std::uint16_t>(v));
         return ok;
       }},
      {0x6073, 0, 2, [](const DriveContext& c) { return std::uint32_t{c.d.max_current_pm}; },
       [](DriveContext& c, std::uint32_t v) {
         if (v == 0 || v > 0x7FFF) return sdo::kAbortValueRange;
         c.d.max_current_pm = static_cast<std::uint16_t>(v);
         return ok;
       }},
      {0x6075, 0, 4,
       [](const DriveContext& c) {
         return static_cast<std::uint32_t>(std::lround(c.d.model.rated_current_A * 1000.0));
       },
       nullptr},
      {0x6076, 0, 4,
       [](const DriveContext& c) {
         return static_cast<std::uint32_t>(std::lround(c.d.model.rated_torque_Nm * 1000.0));
       },
       nullptr},
      {0x6078, 0, 2,
       [](const DriveContext& c) {
         const long pm = std::lround(c.d.current_A / c.d.model.rated_current_A * 1000.0);
         return std::uint32_t{
             static_cast<std::uint16_t>(pm < -32768 ? -32768 : (pm > 32767 ? 32767 : pm))};
       },
       nullptr},
      {0x608F, 0, 1, [](const DriveContext&) { return 2u; }, nullptr},
      {0x608F, 1, 4, [](const DriveContext& c) { return c.d.model.counts_per_rev; }, nullptr},
      {0x608F, 2, 4, [](const DriveContext&) { return 1u; }, nullptr},
      {0x6502, 0, 4, [](const DriveContext&) { return kSupportedModesCst; }, nullptr},
  };
  return kObjects;
}

auto Emulator::DriveObjects::texts() -> std::span<const DriveTable::Text> {
  static const DriveTable::Text kTexts[] = {
      {0x1008, 0, [](const DriveContext& c) { return c.e.identity_.device_name; }},
      {0x1009, 0, [](const DriveContext&) { return std::string(kHardwareVersion); }},
      {0x100A, 0, [](const DriveContext&) { return std::string(kEmulatorSoftwareVersion); }},
  };
  return kTexts;
}

EmulatedIdentity identity_of(const delta::canopen::Eds& eds) {
  EmulatedIdentity id;
  id.vendor_id = eds.identity.vendor_id;
  id.product_code = eds.identity.product_code;
  id.revision = eds.identity.revision;
  if (const delta::canopen::EdsVariable* name = eds.find(0x1008, 0); name != nullptr) {
    id.device_name = name->default_text;
  }
  return id;
}

std::string Emulator::eds_mismatch(const delta::canopen::Eds& eds) {
  return objects_[0]->mismatch(eds, "the emulated drive");
}

}  // namespace emu
