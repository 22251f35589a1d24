// Deflection compensation (docs/using-the-model.md, "Elastic gearboxes").
// Behind an elastic gearbox whose encoder sits on the motor, the arm is at
// q_a = theta_m - c tau, with c = 1 / K the gearbox's compliance and tau
// the torque it carries. To put the arm on the reference, the controller
// tracks a motor reference past it by the deflection the model predicts:
//
//   q_m   = q_ref   + c tau_ff
//   qd_m  = qd_ref  + (c tau_ff - c tau_ff of the tick before) / tick
//   qdd_m = qdd_ref
//
// with tau_ff the model's feed-forward torque at the reference. Two
// documented simplifications: tau_ff is the drive's whole torque, of which
// the gearbox carries all but the motor side's small share (the rotor's
// inertia and the motor's own friction); and the deflection's acceleration
// is left out (the rotor's inertia times c tau'' is far below what the
// feedback corrects). The velocity is the first difference of a smooth
// signal (the model along the reference), not a measured one.
#pragma once

#include <array>
#include <cstdint>

#include "fw/trajectory.hpp"

namespace fw {

using delta::fx::Q1_30;

class DeflectionCompensation {
 public:
  // A run starts: the first shift has no velocity.
  void reset() { primed_ = false; }

  // The motor's reference from `reference`, the arm's on entry, with each
  // joint's compliance [rad/(N m)] and the model's torque at the arm's
  // reference; ticks_per_s the control rate. With follow_velocity false
  // (a stop, which holds the reference still at once) the shift's step is
  // not followed as a velocity.
  void shift(const std::array<Q1_30, 3>& compliance_rad_per_Nm, const std::array<Q12_19, 3>& tau_Nm,
             std::uint32_t ticks_per_s, bool follow_velocity, JointReference& reference);

  // The last shift q_m - q_ref.
  const JointAnglesQ& shift_rad() const { return shift_rad_; }

 private:
  JointAnglesQ shift_rad_{};
  bool primed_{false};
};

// The arm's angle for motor angle theta_m where the gearbox carries tau:
// theta_m - c tau (where a run starts from rest).
Q3_28 arm_angle(Q1_30 compliance_rad_per_Nm, Q12_19 tau_Nm, Q3_28 motor_rad);

}  // namespace fw
