// CiA 402 (drive profile) power state machine and the CiA 301 objects,
// written once for both sides: the controller (firmware) and the drives
// (the emulator). Integer only, constexpr, no heap.
#pragma once

#include <array>
#include <cstdint>

#include "delta/can/sdo.hpp"

namespace delta::can::cia402 {

enum class State : std::uint8_t {
  kNotReadyToSwitchOn,
  kSwitchOnDisabled,
  kReadyToSwitchOn,
  kSwitchedOn,
  kOperationEnabled,
  kQuickStopActive,
  kFaultReactionActive,
  kFault,
};

// Controlword values (object 0x6040) of the device-control commands.
inline constexpr std::uint16_t kShutdown = 0x0006;
inline constexpr std::uint16_t kSwitchOn = 0x0007;  // also "disable operation"
inline constexpr std::uint16_t kEnableOperation = 0x000F;
inline constexpr std::uint16_t kDisableVoltage = 0x0000;
inline constexpr std::uint16_t kQuickStop = 0x0002;
inline constexpr std::uint16_t kFaultReset = 0x0080;

// The state a statusword (object 0x6041) shows.
constexpr State decode_statusword(std::uint16_t sw) {
  if ((sw & 0x4F) == 0x08) return State::kFault;
  if ((sw & 0x4F) == 0x0F) return State::kFaultReactionActive;
  if ((sw & 0x4F) == 0x40) return State::kSwitchOnDisabled;
  if ((sw & 0x6F) == 0x21) return State::kReadyToSwitchOn;
  if ((sw & 0x6F) == 0x23) return State::kSwitchedOn;
  if ((sw & 0x6F) == 0x27) return State::kOperationEnabled;
  if ((sw & 0x6F) == 0x07) return State::kQuickStopActive;
  return State::kNotReadyToSwitchOn;
}

// The statusword bits 0-6 a drive shows in a state (bit 4, voltage enabled,
// set from ready-to-switch-on on).
constexpr std::uint16_t encode_statusword(State s) {
  switch (s) {
    case State::kNotReadyToSwitchOn:
      return 0x0000;
    case State::kSwitchOnDisabled:
      return 0x0040;
    case State::kReadyToSwitchOn:
      return 0x0031;
    case State::kSwitchedOn:
      return 0x0033;
    case State::kOperationEnabled:
      return 0x0037;
    case State::kQuickStopActive:
      return 0x0017;
    case State::kFaultReactionActive:
      return 0x001F;
    case State::kFault:
      return 0x0018;
  }
  return 0;
}

// The drive's side: the next state for a controlword. `previous_controlword`
// detects the fault-reset rising edge (bit 7).
constexpr State drive_transition(State s, std::uint16_t cw, std::uint16_t previous_controlword) {
  const bool fault_reset_edge = (cw & 0x80) && !(previous_controlword & 0x80);
  const bool disable_voltage = (cw & 0x02) == 0;
  const bool quick_stop = (cw & 0x06) == 0x02;
  const bool shutdown = (cw & 0x87) == 0x06;
  const bool switch_on = (cw & 0x8F) == 0x07;
  const bool enable = (cw & 0x8F) == 0x0F;
  switch (s) {
    case State::kNotReadyToSwitchOn:
      return State::kSwitchOnDisabled;  // self-test done
    case State::kSwitchOnDisabled:
      return shutdown ? State::kReadyToSwitchOn : s;
    case State::kReadyToSwitchOn:
      if (disable_voltage || quick_stop) return State::kSwitchOnDisabled;
      if (switch_on) return State::kSwitchedOn;
      if (enable) return State::kOperationEnabled;  // 3 + 4 in one go, as most drives allow
      return s;
    case State::kSwitchedOn:
      if (disable_voltage || quick_stop) return State::kSwitchOnDisabled;
      if (shutdown) return State::kReadyToSwitchOn;
      if (enable) return State::kOperationEnabled;
      return s;
    case State::kOperationEnabled:
      if (disable_voltage) return State::kSwitchOnDisabled;
      if (quick_stop) return State::kQuickStopActive;
      if (shutdown) return State::kReadyToSwitchOn;
      if (switch_on) return State::kSwitchedOn;
      return s;
    case State::kQuickStopActive:
      if (disable_voltage) return State::kSwitchOnDisabled;
      if (enable) return State::kOperationEnabled;
      return s;
    case State::kFaultReactionActive:
      return State::kFault;  // reaction done
    case State::kFault:
      return fault_reset_edge ? State::kSwitchOnDisabled : s;
  }
  return s;
}

// The controller's side: the controlword that moves a drive one step
// towards operation enabled (enable = true) or towards switch-on disabled.
// From fault, it alternates 0 and the fault-reset bit to make the edge.
constexpr std::uint16_t controlword_towards(State s, bool enable,
                                            std::uint16_t previous_controlword) {
  if (!enable) return kDisableVoltage;
  switch (s) {
    case State::kFault:
      return (previous_controlword & 0x80) ? 0x0000 : kFaultReset;
    case State::kSwitchOnDisabled:
      return kShutdown;
    case State::kReadyToSwitchOn:
      return kSwitchOn;
    case State::kSwitchedOn:
    case State::kOperationEnabled:
    case State::kQuickStopActive:
      return kEnableOperation;
    case State::kNotReadyToSwitchOn:
    case State::kFaultReactionActive:
      return kDisableVoltage;  // wait
  }
  return kDisableVoltage;
}

// Modes of operation (object 0x6060).
inline constexpr std::int8_t kModeProfileTorque = 4;
inline constexpr std::int8_t kModeCyclicSynchronousPosition = 8;
inline constexpr std::int8_t kModeCyclicSynchronousTorque = 10;

}  // namespace delta::can::cia402

// The object dictionary entries the controller configures or reads on a
// drive, and the emergency codes used on this bus (CiA 301 / CiA 402).
namespace delta::can::od {

struct Object {
  std::uint16_t index;
  std::uint8_t subindex;
};

inline constexpr Object kDeviceType{0x1000, 0};           // u32, 0x00020192 for a CiA 402 servo
inline constexpr Object kErrorRegister{0x1001, 0};        // u8
inline constexpr Object kCommunicationCycle{0x1006, 0};   // u32 us, the SYNC period
inline constexpr Object kConsumerHeartbeat{0x1016, 1};    // u32: node << 16 | timeout ms, 0 = off
inline constexpr Object kProducerHeartbeat{0x1017, 0};    // u16 ms, 0 = off
inline constexpr Object kVendorId{0x1018, 1};             // u32
inline constexpr Object kProductCode{0x1018, 2};          // u32
inline constexpr Object kRevisionNumber{0x1018, 3};       // u32: major << 16 | minor
inline constexpr Object kSerialNumber{0x1018, 4};         // u32
inline constexpr Object kSyncCounterOverflow{0x1019, 0};  // u8: 0 no counter, else 2..240
inline constexpr Object kTpdo2CobId{0x1801, 1};           // u32, bit 31 set = PDO off
inline constexpr Object kTpdo3CobId{0x1802, 1};           // u32, bit 31 set = PDO off
// Manufacturer-specific (the product's drive profile, docs/protocol.md):
// the counter of the SYNC at which the drive took the sample its TPDOs of
// this cycle carry, mapped into TPDO3.
inline constexpr Object kSyncCounterOfSample{0x2019, 0};      // u8, read-only, PDO-mappable
inline constexpr Object kControlword{0x6040, 0};              // u16
inline constexpr Object kStatusword{0x6041, 0};               // u16
inline constexpr Object kModesOfOperation{0x6060, 0};         // i8
inline constexpr Object kModesOfOperationDisplay{0x6061, 0};  // i8
inline constexpr Object kMaxCurrent{0x6073, 0};               // u16, per mille of rated current
inline constexpr Object kMotorRatedCurrent{0x6075, 0};        // u32 mA
inline constexpr Object kMotorRatedTorque{0x6076, 0};         // u32 mN m
inline constexpr Object kEncoderIncrements{0x608F, 1};        // u32 counts per motor revolution
inline constexpr Object kEncoderMotorRevolutions{0x608F, 2};  // u32, 1

inline constexpr std::uint32_t kDeviceTypeServo = 0x00020192;  // CiA 402, servo drive
inline constexpr std::uint32_t kPdoInvalid = 0x80000000u;      // COB-ID bit 31

// The value of 0x1016:1 that watches `node` with a timeout (0 ms: off),
// and its two fields.
constexpr std::uint32_t consumer_heartbeat(std::uint8_t node, std::uint16_t timeout_ms) {
  return std::uint32_t{node} << 16 | timeout_ms;
}
constexpr std::uint8_t consumer_heartbeat_node(std::uint32_t v) {
  return static_cast<std::uint8_t>((v >> 16) & 0xFF);
}
constexpr std::uint16_t consumer_heartbeat_timeout_ms(std::uint32_t v) {
  return static_cast<std::uint16_t>(v & 0xFFFF);
}

// Emergency error codes (EMCY error_code).
inline constexpr std::uint16_t kEmcyErrorReset = 0x0000;
inline constexpr std::uint16_t kEmcyOvercurrent = 0x2310;  // continuous over-current
inline constexpr std::uint16_t kEmcyHeartbeat = 0x8130;    // life guard / heartbeat error
inline constexpr std::uint16_t kEmcyPdoLength = 0x8210;    // PDO not processed: length error
inline constexpr std::uint16_t kEmcySyncLength = 0x8240;   // unexpected SYNC data length
// The controller's faults: 0xFF00 + the firmware's fault code (docs/firmware.md).
inline constexpr std::uint16_t kEmcyControllerFaultBase = 0xFF00;
// The controller's: delta_boot rolled a new program back (the fault code
// field holds why, fw::update::RevertReason; docs/flashing.md).
inline constexpr std::uint16_t kEmcyUpdateRolledBack = 0x6200;  // user software

}  // namespace delta::can::od
