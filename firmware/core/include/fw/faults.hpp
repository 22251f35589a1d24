// The firmware's fault codes. Stable numbers: Modbus, CAN and the docs
// (docs/firmware.md) report them alike. Never renumber; add at the end.
#pragma once

#include <cstdint>

namespace fw {

enum class Fault : std::uint16_t {
  kNone = 0,
  kEStop = 1,               // the e-stop input opened
  kDriveFault = 2,          // a drive reported a fault
  kHeartbeatLost = 3,       // a drive's heartbeat or feedback stopped
  kJointLimit = 4,          // a measured joint angle left its limits
  kVelocityLimit = 5,       // a measured joint velocity exceeded its limit
  kTrackingError = 6,       // |q_ref - q| exceeded the tracking limit
  kTrajectoryRejected = 7,  // the trajectory breaks a limit (see TrajectoryCheck)
  kConfigInvalid = 8,       // the configuration is inconsistent
  kLogOverflow = 9,         // the log sink refused a record
  kDriveConfigFailed = 10,  // the drives did not reach operation enabled
  kFeedbackMalformed = 11,  // a drive's feedback frame had the wrong length
  kCanBusError = 12,        // the CAN controller went error-passive or bus-off
  kFeedbackLate = 13,       // a drive's feedback kept arriving after the cycle's deadline
};

// A short name for logs and the status display.
const char* fault_name(Fault f);

}  // namespace fw
