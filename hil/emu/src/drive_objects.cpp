// The emulated drive's object dictionary as its SDO server (common's
// delta::can::sdo::Server) sees it: the CiA 301 communication objects and
// the CiA 402 objects the product uses, with their sizes, access and value
// checks. The protocol (lengths, segments, blocks, aborts) is the server's.
#include "drive_objects.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <string_view>
#include <utility>
#include <vector>

#include "delta/can/protocol.hpp"

namespace emu {

namespace p = delta::can::protocol;
namespace od = delta::can::od;
namespace sdo = delta::can::sdo;
namespace cia = delta::can::cia402;

namespace {

constexpr std::string_view kHardwareVersion = "vcan";
constexpr std::string_view kEmulatorSoftwareVersion = "delta_drive_emu " DELTA_VERSION;

// The objects a PDO may carry (PDOMapping=1 in docs/eds/delta_drive_emu.eds).
constexpr std::uint16_t kMappable[] = {0x1001, 0x2019, 0x6040, 0x6041, 0x6060, 0x6061,
                                       0x6064, 0x606C, 0x6071, 0x6078, 0x607A};

}  // namespace

// A PDO's COB-ID (0x1400:1, 0x1800:1 to 0x1803:1) and mapping (0x1600,
// 0x1A00 to 0x1A03): PDO 0 is RPDO1, 1 to 4 TPDO1 to TPDO4.
template <unsigned Pdo>
std::uint32_t Emulator::DriveObjects::cob_id_get(const DriveContext& c) {
  return c.e.pdo_cob_id(c.d, Pdo) | (c.d.pdos[Pdo].valid ? 0u : od::kPdoInvalid);
}

template <unsigned Pdo>
sdo::AbortCode Emulator::DriveObjects::cob_id_set(DriveContext& c, std::uint32_t v) {
  return c.e.set_pdo_cob_id(c.d, Pdo, v);
}

template <unsigned Pdo, std::size_t Sub>
std::uint32_t Emulator::DriveObjects::mapping_get(const DriveContext& c) {
  const PdoMapping& m = c.d.pdos[Pdo];
  return Sub == 0 ? m.count : m.entries[Sub - 1];
}

template <unsigned Pdo, std::size_t Sub>
sdo::AbortCode Emulator::DriveObjects::mapping_set(DriveContext& c, std::uint32_t v) {
  return c.e.set_mapping(c.d, Pdo, Sub, v);
}

template <unsigned Pdo, std::size_t... Sub>
auto Emulator::DriveObjects::mapping_objects(std::uint16_t index, std::index_sequence<Sub...>)
    -> std::array<DriveTable::Scalar, sizeof...(Sub)> {
  return {DriveTable::Scalar{index, static_cast<std::uint8_t>(Sub),
                             static_cast<std::uint8_t>(Sub == 0 ? 1 : 4), &mapping_get<Pdo, Sub>,
                             &mapping_set<Pdo, Sub>}...};
}

// The objects, in index order. Values are their bit patterns, little
// endian on the bus.
auto Emulator::DriveObjects::scalars() -> std::span<const DriveTable::Scalar> {
  constexpr sdo::AbortCode ok = sdo::kNoAbort;
  static const DriveTable::Scalar kFixed[] = {
      {0x1000, 0, 4, [](const DriveContext&) { return od::kDeviceTypeServo; }, nullptr},
      {0x1001, 0, 1,
       [](const DriveContext& c) { return c.d.state == cia::State::kFault ? 1u : 0u; }, nullptr},
      {0x1006, 0, 4, [](const DriveContext& c) { return c.d.cycle_us; },
       [](DriveContext& c, std::uint32_t v) {
         if (v != 0 && (v < 100 || v > 1000000)) return sdo::kAbortValueRange;  // 0: not used
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
      {0x1018, 1, 4, [](const DriveContext& c) { return c.e.product_.vendor_id; }, nullptr},
      {0x1018, 2, 4, [](const DriveContext& c) { return c.e.product_.product_code; }, nullptr},
      {0x1018, 3, 4, [](const DriveContext& c) { return c.e.product_.revision; }, nullptr},
      {0x1018, 4, 4, [](const DriveContext& c) { return 0x00010000u + c.d.node; }, nullptr},
      // CiA 301: 0 or 2..240, written only while 0x1006 is 0.
      {0x1019, 0, 1, [](const DriveContext& c) { return std::uint32_t{c.d.sync_counter_overflow}; },
       [](DriveContext& c, std::uint32_t v) {
         if (c.d.cycle_us != 0) return sdo::kAbortDeviceState;
         if (v == 1 || v > p::kSyncCounterMaxOverflow) return sdo::kAbortValueRange;
         c.d.sync_counter_overflow = static_cast<std::uint8_t>(v);
         return ok;
       }},
      // The PDOs' communication: the predefined COB-IDs, bit 31 turns a PDO
      // off and on; synchronous (transmission type 1).
      {0x1400, 0, 1, [](const DriveContext&) { return 2u; }, nullptr},
      {0x1400, 1, 4, &cob_id_get<0>, &cob_id_set<0>},
      {0x1400, 2, 1, [](const DriveContext&) { return 1u; }, nullptr},
      {0x1800, 0, 1, [](const DriveContext&) { return 2u; }, nullptr},
      {0x1800, 1, 4, &cob_id_get<1>, &cob_id_set<1>},
      {0x1800, 2, 1, [](const DriveContext&) { return 1u; }, nullptr},
      {0x1801, 0, 1, [](const DriveContext&) { return 2u; }, nullptr},
      {0x1801, 1, 4, &cob_id_get<2>, &cob_id_set<2>},
      {0x1801, 2, 1, [](const DriveContext&) { return 1u; }, nullptr},
      {0x1802, 0, 1, [](const DriveContext&) { return 2u; }, nullptr},
      {0x1802, 1, 4, &cob_id_get<3>, &cob_id_set<3>},
      {0x1802, 2, 1, [](const DriveContext&) { return 1u; }, nullptr},
      {0x1803, 0, 1, [](const DriveContext&) { return 2u; }, nullptr},
      {0x1803, 1, 4, &cob_id_get<4>, &cob_id_set<4>},
      {0x1803, 2, 1, [](const DriveContext&) { return 1u; }, nullptr},
      {0x2019, 0, 1, [](const DriveContext& c) { return std::uint32_t{c.d.sync_counter}; },
       nullptr},
      {0x6040, 0, 2, [](const DriveContext& c) { return std::uint32_t{c.d.controlword}; },
       [](DriveContext& c, std::uint32_t v) {
         c.e.apply_controlword(c.d, static_cast<std::uint16_t>(v));
         return ok;
       }},
      {0x6041, 0, 2,
       [](const DriveContext& c) { return std::uint32_t{cia::encode_statusword(c.d.state)}; },
       nullptr},
      // The torque modes the product offers (0x6502) and the emulator has.
      {0x6060, 0, 1,
       [](const DriveContext& c) { return std::uint32_t{static_cast<std::uint8_t>(c.d.mode)}; },
       [](DriveContext& c, std::uint32_t v) {
         const auto mode = static_cast<std::int8_t>(v & 0xFF);
         const std::uint32_t bit = mode == cia::kModeCyclicSynchronousTorque ? kModeBitCst
                                   : mode == cia::kModeProfileTorque             ? kModeBitProfileTorque
                                                                            : 0;
         if ((c.e.product_.supported_modes & bit) == 0) return sdo::kAbortValueRange;
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
      // The arm-side encoder (CiA 402's first additional position actual
      // value) in 0x6064's position units: the arm's angle, behind an
      // elastic gearbox not the motor side's.
      {0x60E4, 0, 1, [](const DriveContext&) { return 1u; }, nullptr},
      {0x60E4, 1, 4,
       [](const DriveContext& c) {
         const unsigned j = c.d.node - p::kFirstDriveNode;
         return static_cast<std::uint32_t>(
             c.e.position_counts(c.d, c.e.plant_->arm_state().q_rad[j]));
       },
       nullptr, true},
      {0x6071, 0, 2,
       [](const DriveContext& c) {
         return std::uint32_t{static_cast<std::uint16_t>(c.d.target_torque_pm)};
       },
       [](DriveContext& c, std::uint32_t v) {
         c.d.target_torque_pm = static_cast<std::int16_t>(static_cast<std::uint16_t>(v));
         return ok;
       }},
      {0x607A, 0, 4,
       [](const DriveContext& c) { return static_cast<std::uint32_t>(c.d.target_position); },
       [](DriveContext& c, std::uint32_t v) {
         c.d.target_position = static_cast<std::int32_t>(v);
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
         return std::uint32_t{static_cast<std::uint16_t>(c.d.current_measured_pm)};
       },
       nullptr},
      {0x608F, 0, 1, [](const DriveContext&) { return 2u; }, nullptr},
      {0x608F, 1, 4, [](const DriveContext& c) { return c.d.model.counts_per_rev; }, nullptr},
      {0x608F, 2, 4, [](const DriveContext&) { return 1u; }, nullptr},
      {0x6502, 0, 4, [](const DriveContext& c) { return c.e.product_.supported_modes; }, nullptr},
  };
  // The mapping objects of RPDO1, TPDO1 to TPDO4: sub-index 0 the count,
  // 1 to 8 the entries.
  static const std::vector<DriveTable::Scalar> kObjects = [] {
    std::vector<DriveTable::Scalar> all(std::begin(kFixed), std::end(kFixed));
    for (const auto& mapping : {mapping_objects<0>(0x1600, std::make_index_sequence<9>()),
                                mapping_objects<1>(0x1A00, std::make_index_sequence<9>()),
                                mapping_objects<2>(0x1A01, std::make_index_sequence<9>()),
                                mapping_objects<3>(0x1A02, std::make_index_sequence<9>()),
                                mapping_objects<4>(0x1A03, std::make_index_sequence<9>())}) {
      all.insert(all.end(), mapping.begin(), mapping.end());
    }
    for (DriveTable::Scalar& o : all) {
      for (const std::uint16_t index : kMappable)
        o.pdo_mappable = o.pdo_mappable || o.index == index;
    }
    std::sort(all.begin(), all.end(), DriveTable::before);  // as the table wants them
    return all;
  }();
  return kObjects;
}

// A PDO's transmission type (0x1400:2, 0x1800:2 to 0x1803:2).
template <unsigned Pdo>
std::uint32_t Emulator::DriveObjects::transmission_get(const DriveContext& c) {
  return c.d.pdos[Pdo].transmission;
}

template <unsigned Pdo>
sdo::AbortCode Emulator::DriveObjects::transmission_set(DriveContext& c, std::uint32_t v) {
  if (v > 240 && v < 252) return sdo::kAbortValueRange;  // CiA 301: reserved
  c.d.pdos[Pdo].transmission = static_cast<std::uint8_t>(v);
  c.d.syncs_since[Pdo] = 0;
  return sdo::kNoAbort;
}

// What vendors' drives have beyond the built-in drive (delta_drive_emu
// --eds only): writable transmission types, RPDO5 and TPDO5, max torque (0x6072),
// torque actual value (0x6077), torque slope (0x6087), the interpolation
// time period (0x60C2, which sets the cycle like 0x1006).
auto Emulator::DriveObjects::vendor_scalars() -> std::span<const DriveTable::Scalar> {
  constexpr sdo::AbortCode ok = sdo::kNoAbort;
  static const DriveTable::Scalar kFixed[] = {
      {0x1400, 2, 1, &transmission_get<0>, &transmission_set<0>},
      {0x1800, 2, 1, &transmission_get<1>, &transmission_set<1>},
      {0x1801, 2, 1, &transmission_get<2>, &transmission_set<2>},
      {0x1802, 2, 1, &transmission_get<3>, &transmission_set<3>},
      {0x1803, 2, 1, &transmission_get<4>, &transmission_set<4>},
      {0x1404, 1, 4, &cob_id_get<5>, &cob_id_set<5>},
      {0x1404, 2, 1, &transmission_get<5>, &transmission_set<5>},
      {0x1804, 1, 4, &cob_id_get<6>, &cob_id_set<6>},
      {0x1804, 2, 1, &transmission_get<6>, &transmission_set<6>},
      {0x6072, 0, 2, [](const DriveContext& c) { return std::uint32_t{c.d.max_torque_pm}; },
       [](DriveContext& c, std::uint32_t v) {
         c.d.max_torque_pm = static_cast<std::uint16_t>(v);
         return ok;
       }},
      // The motor's rated values where a drive lets them be set (the EPOS4's
      // 0x6076): they scale the per-mille torques from then on.
      {0x6075, 0, 4,
       [](const DriveContext& c) {
         return static_cast<std::uint32_t>(std::lround(c.d.model.rated_current_A * 1000.0));
       },
       [](DriveContext& c, std::uint32_t v) {
         if (v == 0) return sdo::kAbortValueRange;
         c.d.model.rated_current_A = v / 1000.0;
         return ok;
       }},
      {0x6076, 0, 4,
       [](const DriveContext& c) {
         return static_cast<std::uint32_t>(std::lround(c.d.model.rated_torque_Nm * 1000.0));
       },
       [](DriveContext& c, std::uint32_t v) {
         if (v == 0) return sdo::kAbortValueRange;
         c.d.model.rated_torque_Nm = v / 1000.0;
         return ok;
       }},
      {0x6077, 0, 2,
       [](const DriveContext& c) {
         return std::uint32_t{static_cast<std::uint16_t>(c.d.torque_measured)};
       },
       nullptr, true},
      {0x6087, 0, 4, [](const DriveContext& c) { return c.d.torque_slope_pm_s; },
       [](DriveContext& c, std::uint32_t v) {
         c.d.torque_slope_pm_s = v;
         return ok;
       }},
      {0x60C2, 1, 1, [](const DriveContext& c) { return std::uint32_t{c.d.interpolation_value}; },
       [](DriveContext& c, std::uint32_t v) {
         c.d.interpolation_value = static_cast<std::uint8_t>(v);
         return c.e.set_interpolation_period(c.d);
       }},
      {0x60C2, 2, 1,
       [](const DriveContext& c) {
         return std::uint32_t{static_cast<std::uint8_t>(c.d.interpolation_index)};
       },
       [](DriveContext& c, std::uint32_t v) {
         c.d.interpolation_index = static_cast<std::int8_t>(v & 0xFF);
         return c.e.set_interpolation_period(c.d);
       }},
  };
  static const std::vector<DriveTable::Scalar> kObjects = [] {
    std::vector<DriveTable::Scalar> all(std::begin(kFixed), std::end(kFixed));
    for (const auto& mapping : {mapping_objects<5>(0x1604, std::make_index_sequence<9>()),
                                mapping_objects<6>(0x1A04, std::make_index_sequence<9>())}) {
      all.insert(all.end(), mapping.begin(), mapping.end());
    }
    std::sort(all.begin(), all.end(), DriveTable::before);  // as the table wants them
    return all;
  }();
  return kObjects;
}

auto Emulator::DriveObjects::texts() -> std::span<const DriveTable::Text> {
  static const DriveTable::Text kTexts[] = {
      {0x1008, 0, [](const DriveContext& c) { return c.e.product_.device_name; }},
      {0x1009, 0, [](const DriveContext&) { return std::string(kHardwareVersion); }},
      {0x100A, 0, [](const DriveContext&) { return std::string(kEmulatorSoftwareVersion); }},
  };
  return kTexts;
}

EmulatedProduct product_of(const delta::canopen::Eds& eds) {
  EmulatedProduct id;
  // What [DeviceInfo] leaves out keeps the built-in value.
  id.vendor_id = eds.identity.vendor_id.value_or(id.vendor_id);
  id.product_code = eds.identity.product_code.value_or(id.product_code);
  id.revision = eds.identity.revision.value_or(id.revision);
  if (const delta::canopen::EdsVariable* name = eds.find(0x1008, 0); name != nullptr) {
    id.device_name = name->default_text;
  }
  // The PDOs' defaults; what the EDS leaves out keeps the built-in value.
  for (unsigned pdo = 0; pdo < kPdoCount; ++pdo) {
    PdoMapping& m = id.pdos[pdo];
    const std::uint16_t communication = kPdoCommunication[pdo];
    const auto mapping = static_cast<std::uint16_t>(communication + 0x200);
    if (const auto* cob = eds.find(communication, 1)) {
      if (const auto v = cob->default_value(1)) m.valid = (*v & od::kPdoInvalid) == 0;
      const auto at0 = cob->default_value(0);
      if (at0 && pdo >= 5) {
        m.id = static_cast<std::uint16_t>(*at0 & 0x7FF);
        m.id_plus_node = cob->default_value(1) != at0;
      }
    }
    if (const auto* type = eds.find(communication, 2)) {
      if (const auto v = type->value(1)) m.transmission = static_cast<std::uint8_t>(*v);
    }
    if (const auto* count = eds.find(mapping, 0)) {
      if (const auto v = count->default_value(1)) m.count = static_cast<std::uint8_t>(*v);
    }
    for (unsigned sub = 1; sub <= m.entries.size(); ++sub) {
      if (const auto* entry = eds.find(mapping, static_cast<std::uint8_t>(sub))) {
        if (const auto v = entry->default_value(1))
          m.entries[sub - 1] = static_cast<std::uint32_t>(*v);
      }
    }
  }
  if (const auto* modes = eds.find(0x6502, 0)) {
    if (const auto v = modes->value(1)) id.supported_modes = static_cast<std::uint32_t>(*v);
  }
  return id;
}

std::string Emulator::eds_mismatch(const delta::canopen::Eds& eds) {
  return objects_[0]->mismatch(eds, "the emulated drive");
}

}  // namespace emu
