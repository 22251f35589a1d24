#include "fw/deflection.hpp"

#include "delta/fixed/math.hpp"

namespace fw {

using delta::fx::mul;

void DeflectionCompensation::shift(const std::array<Q1_30, 3>& compliance_rad_per_Nm,
                                   const std::array<Q12_19, 3>& tau_Nm, std::uint32_t ticks_per_s,
                                   bool follow_velocity, JointReference& reference) {
  const bool velocity = primed_ && follow_velocity;
  for (unsigned j = 0; j < 3; ++j) {
    const Q3_28 shift = mul<Q3_28>(compliance_rad_per_Nm[j], tau_Nm[j]);
    reference.q_rad[j] = reference.q_rad[j] + shift;
    if (velocity) {
      // Q3.28 per tick times ticks per second into Q10.21 rad/s.
      const std::int64_t v =
          delta::fx::shift_round(std::int64_t{(shift - shift_rad_[j]).raw()} * ticks_per_s, 7);
      reference.qd_rad_s[j] = reference.qd_rad_s[j] + Q10_21::from_raw(delta::fx::saturate32(v));
    }
    shift_rad_[j] = shift;
  }
  primed_ = true;
}

Q3_28 arm_angle(Q1_30 compliance_rad_per_Nm, Q12_19 tau_Nm, Q3_28 motor_rad) {
  return motor_rad - mul<Q3_28>(compliance_rad_per_Nm, tau_Nm);
}

}  // namespace fw
