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

// The visible strings: device name, hardware and software version.
std::string_view string_object(std::uint16_t index, const EmulatedIdentity& identity) {
  switch (index) {
    case 0x1008:
      return identity.device_name;
    case 0x1009:
      return kHardwareVersion;
    case 0x100A:
      return kEmulatorSoftwareVersion;
    default:
      return {};
  }
}

}  // namespace

const Emulator::DriveObjects::Object* Emulator::DriveObjects::lookup(std::uint16_t index,
                                                                     std::uint8_t subindex,
                                                                     sdo::AbortCode& code) {
  code = sdo::kAbortObjectDoesNotExist;
  for (const Object& o : objects()) {
    if (o.index != index) continue;
    if (o.subindex == subindex) {
      code = sdo::kNoAbort;
      return &o;
    }
    code = sdo::kAbortSubindexDoesNotExist;
  }
  return nullptr;
}

// The objects, in index order. Values are their bit patterns, little
// endian on the bus.
std::span<const Emulator::DriveObjects::Object> Emulator::DriveObjects::objects() {
  constexpr sdo::AbortCode ok = sdo::kNoAbort;
  static const Object kObjects[] = {
      {0x1000, 0, 4, [](const Emulator&, const Drive&) { return od::kDeviceTypeServo; }, nullptr},
      {0x1001, 0, 1,
       [](const Emulator&, const Drive& d) { return d.state == cia::State::kFault ? 1u : 0u; },
       nullptr},
      {0x1006, 0, 4, [](const Emulator&, const Drive& d) { return d.cycle_us; },
       [](Emulator&, Drive& d, std::uint32_t v) {
         if (v < 100 || v > 1000000) return sdo::kAbortValueRange;
         d.cycle_us = v;
         return ok;
       }},
      {0x1016, 0, 1, [](const Emulator&, const Drive&) { return 1u; }, nullptr},
      {0x1016, 1, 4, [](const Emulator&, const Drive& d) { return d.consumer; },
       [](Emulator&, Drive& d, std::uint32_t v) {
         const std::uint8_t node = od::consumer_heartbeat_node(v);
         if ((v >> 24) != 0 ||
             (od::consumer_heartbeat_timeout_ms(v) != 0 && (node == 0 || node > 127)))
           return sdo::kAbortValueRange;
         d.consumer = v;
         d.consumer_armed = false;
         return ok;
       }},
      {0x1017, 0, 2, [](const Emulator&, const Drive& d) { return std::uint32_t{d.heartbeat_ms}; },
       [](Emulator& e, Drive& d, std::uint32_t v) {
         d.heartbeat_ms = static_cast<std::uint16_t>(v);
         d.next_heartbeat_sim_us = e.sim_us_;
         return ok;
       }},
      {0x1018, 0, 1, [](const Emulator&, const Drive&) { return 4u; }, nullptr},
      {0x1018, 1, 4, [](const Emulator& e, const Drive&) { return e.identity_.vendor_id; },
       nullptr},
      {0x1018, 2, 4, [](const Emulator& e, const Drive&) { return e.identity_.product_code; },
       nullptr},
      {0x1018, 3, 4, [](const Emulator& e, const Drive&) { return e.identity_.revision; }, nullptr},
      {0x1018, 4, 4, [](const Emulator&, const Drive& d) { return 0x00010000u + d.node; }, nullptr},
      // RPDO1 and TPDO1: fixed (docs/protocol.md); synchronous.
      {0x1400, 0, 1, [](const Emulator&, const Drive&) { return 2u; }, nullptr},
      {0x1400, 1, 4,
       [](const Emulator&, const Drive& d) { return std::uint32_t{p::cob_id(p::kRpdo1, d.node)}; },
       nullptr},
      {0x1400, 2, 1, [](const Emulator&, const Drive&) { return 1u; }, nullptr},
      {0x1800, 0, 1, [](const Emulator&, const Drive&) { return 2u; }, nullptr},
      {0x1800, 1, 4,
       [](const Emulator&, const Drive& d) { return std::uint32_t{p::cob_id(p::kTpdo1, d.node)}; },
       nullptr},
      {0x1800, 2, 1, [](const Emulator&, const Drive&) { return 1u; }, nullptr},
      {0x1801, 0, 1, [](const Emulator&, const Drive&) { return 2u; }, nullptr},
      {0x1801, 1, 4, [](const Emulator&, const Drive& d) { return d.tpdo2_cob; },
       [](Emulator&, Drive& d, std::uint32_t v) {
         if ((v & 0x7FF) != p::cob_id(p::kTpdo2, d.node)) return sdo::kAbortValueRange;
         d.tpdo2_cob = v;
         return ok;
       }},
      {0x1801, 2, 1, [](const Emulator&, const Drive&) { return 1u; }, nullptr},  // every SYNC
      {0x6040, 0, 2, [](const Emulator&, const Drive& d) { return std::uint32_t{d.controlword}; },
       [](Emulator& e, Drive& d, std::uint32_t v) {
         e.apply_controlword(d, static_cast<std::uint16_t>(v));
         return ok;
       }},
      {0x6041, 0, 2,
       [](const Emulator&, const Drive& d) {
         return std::uint32_t{cia::encode_statusword(d.state)};
       },
       nullptr},
      {0x6060, 0, 1,
       [](const Emulator&, const Drive& d) {
         return std::uint32_t{static_cast<std::uint8_t>(d.mode)};
       },
       [](Emulator&, Drive& d, std::uint32_t v) {
         const auto mode = static_cast<std::int8_t>(v & 0xFF);
         if (mode != cia::kModeCyclicSynchronousTorque) return sdo::kAbortValueRange;
         d.mode = mode;
         return ok;
       }},
      {0x6061, 0, 1,
       [](const Emulator&, const Drive& d) {
         return std::uint32_t{static_cast<std::uint8_t>(d.mode)};
       },
       nullptr},
      {0x6064, 0, 4,
       [](const Emulator& e, const Drive& d) {
         const unsigned j = d.node - p::kFirstDriveNode;
         return static_cast<std::uint32_t>(e.position_counts(d, e.plant_->state().q_rad[j]));
       },
       nullptr},
      {0x606C, 0, 4,
       [](const Emulator& e, const Drive& d) {
         const unsigned j = d.node - p::kFirstDriveNode;
         return static_cast<std::uint32_t>(e.velocity_counts_s(d, e.plant_->state().qd_rad_s[j]));
       },
       nullptr},
      {0x6071, 0, 2,
       [](const Emulator&, const Drive& d) {
         return std::uint32_t{static_cast<std::uint16_t>(d.target_torque_pm)};
       },
       [](Emulator&, Drive& d, std::uint32_t v) {
         d.target_torque_pm = static_cast<std::int16_t>(static_cast<std::uint16_t>(v));
         return ok;
       }},
      {0x6073, 0, 2,
       [](const Emulator&, const Drive& d) { return std::uint32_t{d.max_current_pm}; },
       [](Emulator&, Drive& d, std::uint32_t v) {
         if (v == 0 || v > 0x7FFF) return sdo::kAbortValueRange;
         d.max_current_pm = static_cast<std::uint16_t>(v);
         return ok;
       }},
      {0x6075, 0, 4,
       [](const Emulator&, const Drive& d) {
         return static_cast<std::uint32_t>(std::lround(d.model.rated_current_A * 1000.0));
       },
       nullptr},
      {0x6076, 0, 4,
       [](const Emulator&, const Drive& d) {
         return static_cast<std::uint32_t>(std::lround(d.model.rated_torque_Nm * 1000.0));
       },
       nullptr},
      {0x6078, 0, 2,
       [](const Emulator&, const Drive& d) {
         const long pm = std::lround(d.current_A / d.model.rated_current_A * 1000.0);
         return std::uint32_t{
             static_cast<std::uint16_t>(pm < -32768 ? -32768 : (pm > 32767 ? 32767 : pm))};
       },
       nullptr},
      {0x608F, 0, 1, [](const Emulator&, const Drive&) { return 2u; }, nullptr},
      {0x608F, 1, 4, [](const Emulator&, const Drive& d) { return d.model.counts_per_rev; },
       nullptr},
      {0x608F, 2, 4, [](const Emulator&, const Drive&) { return 1u; }, nullptr},
      {0x6502, 0, 4, [](const Emulator&, const Drive&) { return kSupportedModesCst; }, nullptr},
  };
  return kObjects;
}

Emulator::DriveObjects::DriveObjects(Emulator& emulator, Drive& drive)
    : emulator_(emulator), drive_(drive) {}

sdo::AbortCode Emulator::DriveObjects::find(std::uint16_t index, std::uint8_t subindex,
                                            sdo::ObjectInfo& info) {
  if (const std::string_view s = string_object(index, emulator_.identity_); !s.empty()) {
    if (subindex != 0) return sdo::kAbortSubindexDoesNotExist;
    info = sdo::ObjectInfo{static_cast<std::uint32_t>(s.size()), 0, true, false, true};
    return sdo::kNoAbort;
  }
  sdo::AbortCode code = sdo::kNoAbort;
  const Object* o = lookup(index, subindex, code);
  if (o == nullptr) return code;
  info = sdo::ObjectInfo{o->size, o->size, true, o->set != nullptr, false};
  return sdo::kNoAbort;
}

sdo::AbortCode Emulator::DriveObjects::read(std::uint16_t index, std::uint8_t subindex,
                                            std::uint32_t offset, std::span<std::uint8_t> out) {
  if (const std::string_view s = string_object(index, emulator_.identity_); !s.empty()) {
    std::memcpy(out.data(), s.data() + offset, out.size());
    return sdo::kNoAbort;
  }
  sdo::AbortCode code = sdo::kNoAbort;
  const Object* o = lookup(index, subindex, code);
  if (o == nullptr) return code;
  const std::uint32_t v = o->get(emulator_, drive_);
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i] = static_cast<std::uint8_t>(v >> (8 * (offset + i)));
  }
  return sdo::kNoAbort;
}

sdo::AbortCode Emulator::DriveObjects::write(std::uint16_t index, std::uint8_t subindex,
                                             std::uint32_t offset,
                                             std::span<const std::uint8_t> data, bool last) {
  sdo::AbortCode code = sdo::kNoAbort;
  const Object* o = lookup(index, subindex, code);
  if (o == nullptr || o->set == nullptr) return o == nullptr ? code : sdo::kAbortReadOnly;
  if (offset == 0) staged_ = 0;
  for (std::size_t i = 0; i < data.size(); ++i) {
    staged_ |= std::uint32_t{data[i]} << (8 * (offset + i));
  }
  return last ? o->set(emulator_, drive_, staged_) : sdo::kNoAbort;
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
  return DriveObjects::mismatch(*objects_[0], eds);
}

// Both ways: each EDS variable against the drive, then each of the drive's
// objects against the EDS.
std::string Emulator::DriveObjects::mismatch(DriveObjects& drive, const delta::canopen::Eds& eds) {
  char at[64];
  for (const auto& [key, v] : eds.variables) {
    std::snprintf(at, sizeof at, ":%d: 0x%04X:%02X (", v.line, v.index, v.subindex);
    const std::string where = eds.path + at + v.name + ")";
    sdo::ObjectInfo info;
    if (drive.find(v.index, v.subindex, info) != sdo::kNoAbort) {
      return where + " is not an object of the emulated drive";
    }
    if (v.size_bytes() != (info.variable_length ? 0 : info.size)) {
      return where + " has " + std::to_string(v.size_bytes()) +
             " bytes; the emulated drive's has " + std::to_string(info.size);
    }
    if (delta::canopen::writable(v.access) != info.writable) {
      return where + (info.writable ? " is writable" : " is read-only") + " in the emulated drive";
    }
  }
  for (const Object& o : objects()) {
    if (eds.find(o.index, o.subindex) == nullptr) {
      std::snprintf(at, sizeof at, "0x%04X:%02X", o.index, o.subindex);
      return eds.path + ": the emulated drive has object " + at + ", which the EDS does not list";
    }
  }
  for (const std::uint16_t index :
       {std::uint16_t{0x1008}, std::uint16_t{0x1009}, std::uint16_t{0x100A}}) {
    if (eds.find(index, 0) == nullptr) {
      std::snprintf(at, sizeof at, "0x%04X:00", index);
      return eds.path + ": the emulated drive has object " + at + ", which the EDS does not list";
    }
  }
  return "";
}

}  // namespace emu
