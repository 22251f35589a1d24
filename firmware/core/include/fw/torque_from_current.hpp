// Joint torque from a drive's measured motor current, in fixed point:
//   tau = sign * gear_ratio * k_t * efficiency * i + offset   [N m at the joint]
#pragma once

#include <array>

#include "delta/fixed/q.hpp"

namespace fw {

using delta::fx::Q12_19;
using delta::fx::Q1_30;
using delta::fx::Q7_24;

struct JointTorqueConfig {
  Q12_19 gear_ratio{Q12_19::from(1.0)};              // motor turns per joint turn
  Q7_24 torque_constant_Nm_per_A{Q7_24::from(0.1)};  // at the motor
  Q1_30 efficiency{Q1_30::from(1.0)};                // of the gearbox, (0, 1]
  bool inverted{false};  // the drive's positive current turns the joint negative
  Q12_19 offset_Nm{};    // added at the joint
};

// tau = gain * i (negated when inverted) + offset, with the gain
// gear_ratio * k_t * efficiency worked out once, not every cycle. The same
// arithmetic as torque_from_current(), bit for bit.
class TorqueFromCurrent {
 public:
  explicit TorqueFromCurrent(const JointTorqueConfig& c);
  Q12_19 operator()(Q12_19 current_A) const {
    const Q12_19 t = delta::fx::mul<Q12_19>(gain_, current_A);
    return (inverted_ ? -t : t) + offset_Nm_;
  }

 private:
  Q7_24 gain_;  // N m / A at the joint
  bool inverted_;
  Q12_19 offset_Nm_;
};

Q12_19 torque_from_current(const JointTorqueConfig& c, Q12_19 current_A);

// The motor current that produces a joint torque (the inverse, for drives
// commanded in current); zero when the gain is zero.
Q12_19 current_from_torque(const JointTorqueConfig& c, Q12_19 torque_Nm);

}  // namespace fw
