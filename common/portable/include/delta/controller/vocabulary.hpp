// The controller's shared vocabulary: its states, its fault codes and why a
// trajectory was refused, with their names. The firmware reports them, the
// Modbus map and host_id read them back, and docs/firmware.md lists them.
// Stable numbers: never renumber; add at the end.
#pragma once

#include <array>
#include <cstdint>
#include <string_view>

namespace delta::controller {

// boot -> configuring -> ready -> running -> stopping -> ready; any fault
// -> fault, until a reset starts again at boot (docs/firmware.md).
enum class State : std::uint8_t {
  kBoot = 0,
  kConfiguring = 1,
  kReady = 2,
  kRunning = 3,
  kStopping = 4,
  kFault = 5,
};

enum class Fault : std::uint16_t {
  kNone = 0,
  kEStop = 1,               // the e-stop input opened
  kDriveFault = 2,          // a drive reported a fault
  kHeartbeatLost = 3,       // a drive's heartbeat or feedback stopped
  kJointLimit = 4,          // a measured joint angle left its limits
  kVelocityLimit = 5,       // a measured joint velocity exceeded its limit
  kTrackingError = 6,       // |q_ref - q| exceeded the tracking limit
  kTrajectoryRejected = 7,  // the trajectory breaks a limit (see TrajectoryFault)
  kConfigInvalid = 8,       // the configuration is inconsistent
  kLogOverflow = 9,         // the log sink refused a record
  kDriveConfigFailed = 10,  // the drives did not reach operation enabled
  kFeedbackMalformed = 11,  // a drive's feedback frame had the wrong length
  kCanBusError = 12,        // the CAN controller went error-passive or bus-off
  kFeedbackLate = 13,       // a drive's feedback kept arriving after the cycle's deadline
  kCollision = 14,          // a joint's torque residual passed its threshold (fw/collision.hpp)
};

// Why a trajectory check refused a trajectory.
enum class TrajectoryFault : std::uint8_t {
  kOk = 0,
  kInvalidConfig = 1,  // zero harmonics, too few waypoints, zero period...
  kJointLimit = 2,
  kVelocityLimit = 3,
  kAccelerationLimit = 4,
  kOutsideWorkspace = 5,  // IK or FK has no solution at some tick
  kTooLong = 6,           // more than kMaxTrajectoryTicks
  kFeedForwardLimit = 7,  // the feed-forward would ask for more than the max torque
};

// The last tick a trajectory may have: 10 minutes at the default 1 ms tick.
// The controller walks every tick against its limits before it runs a
// trajectory (about 0.7 us a tick on a desktop x86), while its Modbus
// server waits; a longer one is refused (TrajectoryFault::kTooLong).
inline constexpr std::uint32_t kMaxTrajectoryTicks = 600000;

// The excitation trajectories the controller knows, by id (the Modbus
// holding register `trajectory`, docs/modbus.md); the firmware's catalogue
// defines each (docs/firmware.md).
enum class TrajectoryId : std::uint16_t {
  kPath1 = 0,         // 5-harmonic Fourier at 0.2 Hz, for fitting
  kPath2 = 1,         // 5-harmonic Fourier at 0.25 Hz, for validation
  kPickAndPlace = 2,  // the default pick-and-place cycle
  kCustom = 3,        // the Fourier trajectory of the custom_* holding registers
};

// The names, indexed by the enumerators' values.
inline constexpr std::array<std::string_view, 6> kStateNames{"boot",    "configuring", "ready",
                                                             "running", "stopping",    "fault"};
inline constexpr std::array<std::string_view, 15> kFaultNames{"none",
                                                              "e-stop",
                                                              "drive fault",
                                                              "heartbeat lost",
                                                              "joint limit",
                                                              "velocity limit",
                                                              "tracking error",
                                                              "trajectory rejected",
                                                              "configuration invalid",
                                                              "log overflow",
                                                              "drive configuration failed",
                                                              "feedback malformed",
                                                              "CAN bus error",
                                                              "feedback late",
                                                              "collision"};
inline constexpr std::array<std::string_view, 8> kTrajectoryFaultNames{
    "ok",
    "invalid configuration",
    "joint limit",
    "velocity limit",
    "acceleration limit",
    "outside the workspace",
    "too long",
    "feed-forward over the max torque"};

inline constexpr std::array<std::string_view, 4> kTrajectoryNames{"path1", "path2",
                                                                  "pick-and-place", "custom"};

namespace detail {
template <std::size_t N>
constexpr const char* name_at(const std::array<std::string_view, N>& names, unsigned index) {
  // Every name is a string literal, so data() is NUL-terminated.
  return index < N ? names[index].data() : "unknown";
}
}  // namespace detail

// Short names for logs, messages and the status display: "heartbeat lost".
constexpr const char* state_name(State s) {
  return detail::name_at(kStateNames, static_cast<unsigned>(s));
}
constexpr const char* fault_name(Fault f) {
  return detail::name_at(kFaultNames, static_cast<unsigned>(f));
}
constexpr const char* trajectory_fault_name(TrajectoryFault f) {
  return detail::name_at(kTrajectoryFaultNames, static_cast<unsigned>(f));
}

constexpr const char* trajectory_name(TrajectoryId id) {
  return detail::name_at(kTrajectoryNames, static_cast<unsigned>(id));
}
// The id of a trajectory's name; false when there is none of that name.
constexpr bool trajectory_id(std::string_view name, TrajectoryId& id) {
  for (unsigned i = 0; i < kTrajectoryNames.size(); ++i) {
    if (kTrajectoryNames[i] == name) {
      id = static_cast<TrajectoryId>(i);
      return true;
    }
  }
  return false;
}

static_assert(kStateNames.size() == static_cast<unsigned>(State::kFault) + 1);
static_assert(kTrajectoryNames.size() == static_cast<unsigned>(TrajectoryId::kCustom) + 1);
static_assert(kFaultNames.size() == static_cast<unsigned>(Fault::kCollision) + 1);
static_assert(kTrajectoryFaultNames.size() ==
              static_cast<unsigned>(TrajectoryFault::kFeedForwardLimit) + 1);

}  // namespace delta::controller
