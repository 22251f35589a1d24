// The narrow interfaces through which the core meets the hardware. The
// controller is a template over a Hardware type that provides these calls
// (moteus-style: the Linux port, the Cortex-M port and the tests' fakes each
// implement them; no virtual dispatch on the real-time path).
//
//   DriveConfigProgress configure_drives();   // step the drives' bring-up
//   void enable_drives(bool on);              // CiA 402 enable / disable
//   void quick_stop_drives();                 // CiA 402 quick stop, then disabled
//   void read_feedback(std::array<DriveFeedback, 3>&);
//   void command_torque(const std::array<Q12_19, 3>& joint_torque_Nm);
//   void command_reference(const JointAnglesQ& arm_reference_rad);  // a run's
//   bool estop_open();                        // debounced e-stop input
//   void set_outputs(const SafetyOutputs&);   // enable, brake, status lines
//   bool log(const LogRecord&);               // false: the sink is full
#pragma once

#include <array>
#include <cstdint>

#include "delta/fixed/kinematics.hpp"

namespace fw {

using delta::fx::JointAnglesQ;
using delta::fx::Q10_21;
using delta::fx::Q12_19;
using delta::fx::Q3_28;

enum class DriveConfigProgress : std::uint8_t { kInProgress = 0, kDone = 1, kFailed = 2 };

// What went wrong with a drive's feedback this cycle, as the port saw it.
enum class FeedbackProblem : std::uint8_t {
  kNone = 0,
  kMalformed = 1,  // a frame with the wrong length: faults at once
  kBusError = 2,   // the bus went error-passive or bus-off: faults at once
  kLate = 3,       // the sample came after the deadline: counts as not fresh
};

struct DriveFeedback {
  Q3_28 position_rad{};      // at the joint
  Q10_21 velocity_rad_s{};   // at the joint
  Q12_19 current_A{};        // motor current
  Q3_28 arm_position_rad{};  // the arm-side encoder at the joint (arm_encoders only)
  bool fresh{false};         // a new sample arrived this cycle (heartbeat/PDO alive)
  bool fault{false};         // the drive reports a fault
  FeedbackProblem problem{FeedbackProblem::kNone};
};

struct SafetyOutputs {
  bool drive_enable{false};   // drive-enable line
  bool brake_release{false};  // energised = released; de-energised = braked (fail-safe)
  bool status_ok{false};      // status lamp / PLC input
};

// One record per control cycle, for the CAN log frames.
struct LogRecord {
  std::uint32_t seq{0};
  JointAnglesQ q_rad{};
  std::array<Q12_19, 3> tau_Nm{};
  JointAnglesQ qa_rad{};  // the arm-side encoders (logged with arm_encoders only)
  // A drive's feedback was missing this cycle: q and tau hold its last
  // values, so the record is not a sample (its seq is still used).
  bool stale{false};
};

}  // namespace fw
