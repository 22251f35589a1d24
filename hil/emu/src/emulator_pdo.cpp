// The emulated drives' PDOs and EDS: RPDO1 applied and the TPDOs sent as
// mapped, CiA 301's rules for the PDOs' COB-IDs and mappings, and a drive
// that behaves as its EDS file describes.
#include <algorithm>
#include <cmath>

#include "delta/can/emcy.hpp"
#include "delta/can/protocol.hpp"
#include "drive_objects.hpp"
#include "eds_objects.hpp"
#include "emu/emulator.hpp"

namespace emu {

namespace p = delta::can::protocol;
namespace od = delta::can::od;
namespace sdo = delta::can::sdo;
namespace cia = delta::can::cia402;
using delta::can::Frame;

// A frame that is a drive's RPDO (RPDO1, or RPDO5 where the EDS has it),
// taken; false if it is none.
bool Emulator::take_rpdo(const Frame& f) {
  bool taken = false;
  for (unsigned j = 0; j < 3; ++j) {
    for (const unsigned pdo : {0u, 5u}) {
      if (drives_[j].pdos[pdo].valid && !drives_[j].silent && f.id == pdo_cob_id(drives_[j], pdo)) {
        handle_rpdo(j, pdo, f);
        taken = true;
      }
    }
  }
  return taken;
}

// An RPDO as mapped: each entry written to its object, in order (the
// controlword applies its transition). A frame shorter than the mapping is
// not processed: EMCY 0x8210 (CiA 301).
void Emulator::handle_rpdo(unsigned j, unsigned pdo, const Frame& f) {
  Drive& d = drives_[j];
  const PdoMapping& m = d.pdos[pdo];
  if (d.nmt != p::kNmtStateOperational || !m.valid) return;
  unsigned bytes = 0;
  for (unsigned i = 0; i < m.count; ++i) bytes += (m.entries[i] & 0xFF) / 8;
  if (f.dlc < bytes) {
    std::array<std::uint8_t, 8> data{};
    p::pack(data, p::kEmcyErrorCode, od::kEmcyPdoLength);
    send(p::cob_id(p::kEmcy, d.node), 8, data);
    return;
  }
  unsigned at = 0;
  for (unsigned i = 0; i < m.count; ++i) {
    const std::uint32_t e = m.entries[i];
    const unsigned n = (e & 0xFF) / 8;
    dictionary(j).write(static_cast<std::uint16_t>(e >> 16), static_cast<std::uint8_t>(e >> 8), 0,
                        std::span<const std::uint8_t>(f.data).subspan(at, n), true);
    at += n;
  }
  track_arm(j, m);
}

void Emulator::track_arm(unsigned j, const PdoMapping& m) {
  const Drive& d = drives_[j];
  if (d.state != cia::State::kOperationEnabled) return end_arm_run(j);
  const bool reference = std::any_of(m.entries.begin(), m.entries.begin() + m.count,
                                     [](std::uint32_t e) { return e >> 16 == 0x607A; });
  if (!reference) return;
  if (!arm_tracking_) {
    const double cycle_s = (d.cycle_us != 0 ? d.cycle_us : 2000u) * 1e-6;
    arm_tracking_.emplace(static_cast<std::uint32_t>(std::lround(config_.approach_s / cycle_s)),
                          static_cast<std::uint32_t>(std::lround(config_.stop_s / cycle_s)));
  }
  arm_tracking_->add(j, joint_angle_rad(d, d.target_position) - plant_->arm_state().q_rad[j]);
}

void Emulator::end_arm_run(unsigned j) {
  if (!arm_tracking_ || !arm_tracking_->running(j)) return;
  const auto line = arm_tracking_->end(j);
  if (line && config_.report) config_.report(*line);
}

// A TPDO as mapped, each entry read from its object, when its
// transmission type says this SYNC.
void Emulator::send_tpdo(unsigned j, unsigned pdo) {
  Drive& d = drives_[j];
  const PdoMapping& m = d.pdos[pdo];
  if (!m.valid || m.count == 0) return;
  std::array<std::uint8_t, 8> data{};
  unsigned at = 0;
  for (unsigned i = 0; i < m.count; ++i) {
    const std::uint32_t e = m.entries[i];
    const unsigned n = (e & 0xFF) / 8;
    dictionary(j).read(static_cast<std::uint16_t>(e >> 16), static_cast<std::uint8_t>(e >> 8), 0,
                       std::span<std::uint8_t>(data).subspan(at, n));
    at += n;
  }
  std::array<std::uint8_t, 9> payload{};
  std::copy(data.begin(), data.end(), payload.begin());
  payload[8] = static_cast<std::uint8_t>(at);
  if (!tpdo_due(d, pdo, payload)) return;
  auto dlc = static_cast<std::uint8_t>(at);
  if (pdo == 1 && d.corrupt_next) {
    dlc = 5;
    d.corrupt_next = false;
  }
  send(pdo_cob_id(d, pdo), dlc, data, d.delay_us);
}

// CiA 301's transmission types: 1 to 240 every that many SYNCs; 0 at the
// SYNC when the data changed; 254 and 255 event-driven, when the data
// changed (the emulated data change only at SYNCs); 252 and 253 on a
// remote request, which this bus does not use.
bool Emulator::tpdo_due(Drive& d, unsigned pdo, const std::array<std::uint8_t, 9>& payload) {
  const std::uint8_t type = d.pdos[pdo].transmission;
  bool due = false;
  if (type >= 1 && type <= 240) {
    due = ++d.syncs_since[pdo] >= type;
    if (due) d.syncs_since[pdo] = 0;
  } else if (type == 0 || type >= 254) {
    due = payload != d.last_sent[pdo];
  }
  if (due) d.last_sent[pdo] = payload;
  return due;
}

std::uint32_t Emulator::pdo_cob_id(const Drive& d, unsigned pdo) const {
  if (pdo >= 5) return d.pdos[pdo].id + (d.pdos[pdo].id_plus_node ? d.node : 0u);
  if (pdo == 4) return 0x480u + d.node;  // TPDO4, CiA 301's predefined connection set
  static constexpr const p::Message* kMessageOf[kPdoCount - 1] = {&p::kRpdo1, &p::kTpdo1,
                                                                  &p::kTpdo2, &p::kTpdo3};
  return p::cob_id(*kMessageOf[pdo], d.node);
}

bool Emulator::mappable(unsigned j, std::uint16_t index, std::uint8_t subindex) const {
  return eds_objects_[j] ? eds_objects_[j]->mappable(index, subindex)
                         : objects_[j]->mappable(index, subindex);
}

std::size_t Emulator::use_eds(const delta::canopen::Eds& eds) {
  eds_ = std::make_unique<delta::canopen::Eds>(eds);
  set_product(product_of(*eds_));
  for (unsigned j = 0; j < 3; ++j) {
    Drive& d = drives_[j];
    // The rated values and encoder resolution it gives (non-zero).
    const auto given = [&](std::uint16_t index, std::uint8_t sub) -> double {
      const delta::canopen::EdsVariable* v = eds_->find(index, sub);
      const auto value = v != nullptr && !v->opaque ? v->value(d.node) : std::nullopt;
      return value && *value != 0 ? static_cast<double>(*value) : 0.0;
    };
    if (const double mA = given(0x6075, 0); mA != 0) d.model.rated_current_A = mA / 1000.0;
    if (const double mNm = given(0x6076, 0); mNm != 0) d.model.rated_torque_Nm = mNm / 1000.0;
    if (const double counts = given(0x608F, 1); counts != 0) {
      d.model.counts_per_rev = static_cast<std::uint32_t>(counts);
    }
    vendor_objects_[j] =
        std::make_unique<DriveTable>(DriveContext{*this, d}, DriveObjects::vendor_scalars(),
                                     std::span<const DriveTable::Text>());
    eds_objects_[j] = std::make_unique<EdsObjects>(
        *eds_, d.node,
        std::vector<sdo::ObjectDictionary*>{vendor_objects_[j].get(), objects_[j].get()});
    eds_objects_[j]->apply_defaults();
    sdo_servers_[j] = std::make_unique<sdo::Server>(*eds_objects_[j]);
  }
  return eds_objects_[0]->behaviour_count();
}

void Emulator::commission(const CommissionedDrives& c) {
  for (unsigned j = 0; j < 3; ++j) drives_[j].model = c.applied(j, drives_[j].model);
  if (c.torque_unit) {
    config_.torque_unit = *c.torque_unit == "mA"    ? TorqueUnit::kMilliamp
                          : *c.torque_unit == "mNm" ? TorqueUnit::kMilliNewtonMetre
                                                    : TorqueUnit::kPerMille;
  }
}

// The COB-ID's ID is the predefined one (it cannot move), RPDO5's and
// TPDO5's any 11-bit ID, moved while the PDO is off (CiA 301); bit 31
// turns the PDO off and on; bit 30 (no remote request) is taken either way.
sdo::AbortCode Emulator::set_pdo_cob_id(Drive& d, unsigned pdo, std::uint32_t v) {
  if (pdo >= 5 && (v & 0x3FFFF800) == 0 && (v & 0x7FF) != 0 &&
      (!d.pdos[pdo].valid || (v & 0x7FF) == pdo_cob_id(d, pdo))) {
    d.pdos[pdo].id = static_cast<std::uint16_t>(v & 0x7FF);
    d.pdos[pdo].id_plus_node = false;
  }
  if ((v & 0x3FFFFFFF) != pdo_cob_id(d, pdo)) return sdo::kAbortValueRange;
  d.pdos[pdo].valid = (v & od::kPdoInvalid) == 0;
  return sdo::kNoAbort;
}

// CiA 301's rules for a mapping: only while the PDO is off; entries only
// while sub-index 0 is 0; each entry an existing, mappable object of its
// whole size (readable for a TPDO, writable for an RPDO); at most 8 bytes.
sdo::AbortCode Emulator::set_mapping(Drive& d, unsigned pdo, unsigned sub, std::uint32_t v) {
  PdoMapping& m = d.pdos[pdo];
  if (m.valid) return sdo::kAbortValueRange;
  if (sub != 0) {
    if (m.count != 0) return sdo::kAbortValueRange;
    if (v != 0) {
      if (const sdo::AbortCode c = check_mapping_entry(d, pdo, v); c != sdo::kNoAbort) return c;
    }
    m.entries[sub - 1] = v;
    return sdo::kNoAbort;
  }
  if (v > m.entries.size()) return sdo::kAbortValueRange;
  unsigned bits = 0;
  for (unsigned i = 0; i < v; ++i) {
    if (const sdo::AbortCode c = check_mapping_entry(d, pdo, m.entries[i]); c != sdo::kNoAbort) {
      return c;
    }
    bits += m.entries[i] & 0xFF;
  }
  if (bits > 64) return sdo::kAbortPdoLength;
  m.count = static_cast<std::uint8_t>(v);
  return sdo::kNoAbort;
}

sdo::AbortCode Emulator::check_mapping_entry(const Drive& d, unsigned pdo, std::uint32_t entry) {
  const auto index = static_cast<std::uint16_t>(entry >> 16);
  const auto sub = static_cast<std::uint8_t>(entry >> 8);
  const unsigned j = d.node - p::kFirstDriveNode;
  sdo::ObjectInfo info;
  if (const sdo::AbortCode c = dictionary(j).find(index, sub, info); c != sdo::kNoAbort) return c;
  const bool usable = receive_pdo(pdo) ? info.writable : info.readable;
  if (!mappable(j, index, sub) || !usable) return sdo::kAbortNotMappable;
  if ((entry & 0xFF) != info.size * 8) return sdo::kAbortParameterIncompatible;
  return sdo::kNoAbort;
}

}  // namespace emu
