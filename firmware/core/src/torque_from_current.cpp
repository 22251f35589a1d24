#include "fw/torque_from_current.hpp"

namespace fw {

using delta::fx::div;
using delta::fx::mul;

namespace {

// gear_ratio * k_t * efficiency [N m / A at the joint], in Q7.24 so that a
// small k_t keeps its precision.
Q7_24 joint_gain(const JointTorqueConfig& c) {
  return mul<Q7_24>(mul<Q7_24>(c.gear_ratio, c.torque_constant_Nm_per_A), c.efficiency);
}

}  // namespace

TorqueFromCurrent::TorqueFromCurrent(const JointTorqueConfig& c)
    : gain_(joint_gain(c)), inverted_(c.inverted), offset_Nm_(c.offset_Nm) {}

Q12_19 torque_from_current(const JointTorqueConfig& c, Q12_19 current_A) {
  return TorqueFromCurrent(c)(current_A);
}

Q12_19 current_from_torque(const JointTorqueConfig& c, Q12_19 torque_Nm) {
  const Q7_24 gain = joint_gain(c);
  if (gain.raw() == 0) return Q12_19::zero();
  const Q12_19 i = div<Q12_19>(torque_Nm - c.offset_Nm, gain);
  return c.inverted ? -i : i;
}

}  // namespace fw
