// The bring-up of one drive by SDO, in order (docs/protocol.md): what the
// master reads and writes, written once for the master and for the check
// of a drive's EDS against it (config.cpp).
#pragma once

#include <cstdint>
#include <span>

#include "delta/can/cia402.hpp"

namespace fw_linux {

enum BringUpStep : unsigned {
  kReadDeviceType,
  kReadVendorId,
  kReadProductCode,
  kReadRevisionNumber,
  kReadSerialNumber,
  kReadRatedCurrent,
  kReadRatedTorque,
  kReadEncoderIncrements,
  kWriteMode,
  // With sync_counter_overflow > 0 only (CiA 301: 0x1019 is written while
  // 0x1006 is 0):
  kClearCyclePeriod,
  kWriteSyncCounter,
  kWriteCyclePeriod,
  kWriteHeartbeat,
  kWriteConsumerHeartbeat,
  kWritePdoMapping,  // the writes of kPdoMapping, one after the other
  kWriteTpdo2,
  kWriteSyncPdoMapping,  // with sync_counter_overflow > 0 only: kSyncPdoMapping
  kBringUpStepCount,
};

// The steps that only a SYNC counter needs.
constexpr bool sync_counter_step(unsigned step) {
  return step == kClearCyclePeriod || step == kWriteSyncCounter || step == kWriteSyncPdoMapping;
}

struct BringUpObject {
  delta::can::od::Object object;
  bool write;
  const char* what;
};

inline constexpr BringUpObject kBringUp[kBringUpStepCount] = {
    {delta::can::od::kDeviceType, false, "device type"},
    {delta::can::od::kVendorId, false, "vendor ID"},
    {delta::can::od::kProductCode, false, "product code"},
    {delta::can::od::kRevisionNumber, false, "revision number"},
    {delta::can::od::kSerialNumber, false, "serial number"},
    {delta::can::od::kMotorRatedCurrent, false, "motor rated current"},
    {delta::can::od::kMotorRatedTorque, false, "motor rated torque"},
    {delta::can::od::kEncoderIncrements, false, "encoder increments"},
    {delta::can::od::kModesOfOperation, true, "modes of operation"},
    {delta::can::od::kCommunicationCycle, true, "communication cycle period (0 first)"},
    {delta::can::od::kSyncCounterOverflow, true, "synchronous counter overflow value"},
    {delta::can::od::kCommunicationCycle, true, "communication cycle period"},
    {delta::can::od::kProducerHeartbeat, true, "producer heartbeat time"},
    {delta::can::od::kConsumerHeartbeat, true, "consumer heartbeat time"},
    {{0x1600, 0}, true, "PDO mapping"},  // see kPdoMapping
    {delta::can::od::kTpdo2CobId, true, "TPDO2 COB-ID"},
    {{0x1A02, 0}, true, "TPDO3 mapping"},  // see kSyncPdoMapping
};

// The PDOs' mapping, written in CiA 301's order for each PDO: off (bit 31
// of its COB-ID), no entries, the entries, their count, on. TPDO2 is left
// off here; kWriteTpdo2 turns it on when velocity_pdo is set. The layout
// is docs/protocol.md's, whatever the drive's own default mapping.
struct PdoMappingWrite {
  delta::can::od::Object object;
  std::uint32_t value;  // + the node ID when node_relative
  std::uint8_t size;
  bool node_relative;
};

inline constexpr PdoMappingWrite kPdoMapping[] = {
    {{0x1400, 1}, 0x80000200, 4, true},  // RPDO1 off
    {{0x1600, 0}, 0, 1, false},
    {{0x1600, 1}, 0x60400010, 4, false},  // controlword
    {{0x1600, 2}, 0x60710010, 4, false},  // target torque
    {{0x1600, 3}, 0x607A0020, 4, false},  // target position
    {{0x1600, 0}, 3, 1, false},
    {{0x1400, 1}, 0x00000200, 4, true},  // RPDO1 on
    {{0x1800, 1}, 0x80000180, 4, true},  // TPDO1 off
    {{0x1A00, 0}, 0, 1, false},
    {{0x1A00, 1}, 0x60410010, 4, false},  // statusword
    {{0x1A00, 2}, 0x60640020, 4, false},  // position actual value
    {{0x1A00, 3}, 0x60780010, 4, false},  // current actual value
    {{0x1A00, 0}, 3, 1, false},
    {{0x1800, 1}, 0x00000180, 4, true},  // TPDO1 on
    {{0x1801, 1}, 0x80000280, 4, true},  // TPDO2 off
    {{0x1A01, 0}, 0, 1, false},
    {{0x1A01, 1}, 0x606C0020, 4, false},  // velocity actual value
    {{0x1A01, 0}, 1, 1, false},
};
inline constexpr unsigned kPdoMappingWrites = sizeof kPdoMapping / sizeof kPdoMapping[0];

// With a SYNC counter, TPDO3 carries the counter of the SYNC the drive's
// sample answers (0x2019, the product's drive profile), after TPDO1 and
// TPDO2: the master takes a cycle's TPDOs only when it matches.
inline constexpr PdoMappingWrite kSyncPdoMapping[] = {
    {{0x1802, 1}, 0x80000380, 4, true},  // TPDO3 off
    {{0x1A02, 0}, 0, 1, false},
    {{0x1A02, 1}, 0x20190008, 4, false},  // SYNC counter of the sample
    {{0x1A02, 0}, 1, 1, false},
    {{0x1802, 1}, 0x00000380, 4, true},  // TPDO3 on
};

// The mapping writes of a step (kWritePdoMapping, kWriteSyncPdoMapping).
constexpr std::span<const PdoMappingWrite> mapping_writes(unsigned step) {
  return step == kWriteSyncPdoMapping ? std::span<const PdoMappingWrite>(kSyncPdoMapping)
                                      : std::span<const PdoMappingWrite>(kPdoMapping);
}
constexpr bool mapping_step(unsigned step) {
  return step == kWritePdoMapping || step == kWriteSyncPdoMapping;
}

// The objects the fixed PDOs carry (docs/protocol.md): they must be
// mappable in a drive's EDS.
inline constexpr delta::can::od::Object kPdoObjects[] = {
    delta::can::od::kControlword,
    {0x6071, 0},  // RPDO1: controlword, target torque
    delta::can::od::kStatusword,
    {0x6064, 0},  // TPDO1: statusword, position,
    {0x6078, 0},  // current actual value
    {0x606C, 0},  // TPDO2: velocity actual value
};

}  // namespace fw_linux
