// The bring-up of one drive by SDO, in order (docs/protocol.md): what the
// master reads and writes, written once for the master and for the check
// of a drive's EDS against it (config.cpp).
#pragma once

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
  kWriteCyclePeriod,
  kWriteHeartbeat,
  kWriteConsumerHeartbeat,
  kWriteTpdo2,
  kBringUpStepCount,
};

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
    {delta::can::od::kCommunicationCycle, true, "communication cycle period"},
    {delta::can::od::kProducerHeartbeat, true, "producer heartbeat time"},
    {delta::can::od::kConsumerHeartbeat, true, "consumer heartbeat time"},
    {delta::can::od::kTpdo2CobId, true, "TPDO2 COB-ID"},
};

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
