#include "fw/controller.hpp"
#include "fw/faults.hpp"

namespace fw {

const char* fault_name(Fault f) {
  switch (f) {
    case Fault::kNone:
      return "none";
    case Fault::kEStop:
      return "e-stop";
    case Fault::kDriveFault:
      return "drive fault";
    case Fault::kHeartbeatLost:
      return "heartbeat lost";
    case Fault::kJointLimit:
      return "joint limit";
    case Fault::kVelocityLimit:
      return "velocity limit";
    case Fault::kTrackingError:
      return "tracking error";
    case Fault::kTrajectoryRejected:
      return "trajectory rejected";
    case Fault::kConfigInvalid:
      return "configuration invalid";
    case Fault::kLogOverflow:
      return "log overflow";
    case Fault::kDriveConfigFailed:
      return "drive configuration failed";
    case Fault::kFeedbackMalformed:
      return "feedback malformed";
    case Fault::kCanBusError:
      return "CAN bus error";
    case Fault::kFeedbackLate:
      return "feedback late";
  }
  return "unknown";
}

const char* state_name(State s) {
  switch (s) {
    case State::kBoot:
      return "boot";
    case State::kConfiguring:
      return "configuring";
    case State::kReady:
      return "ready";
    case State::kRunning:
      return "running";
    case State::kStopping:
      return "stopping";
    case State::kFault:
      return "fault";
  }
  return "unknown";
}

const char* trajectory_fault_name(TrajectoryFault f) {
  switch (f) {
    case TrajectoryFault::kOk:
      return "ok";
    case TrajectoryFault::kInvalidConfig:
      return "invalid configuration";
    case TrajectoryFault::kJointLimit:
      return "joint limit";
    case TrajectoryFault::kVelocityLimit:
      return "velocity limit";
    case TrajectoryFault::kAccelerationLimit:
      return "acceleration limit";
    case TrajectoryFault::kOutsideWorkspace:
      return "outside the workspace";
  }
  return "unknown";
}

}  // namespace fw
