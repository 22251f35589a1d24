#include "fw/joint_controller.hpp"

#include "delta/fixed/math.hpp"

namespace fw {

using delta::fx::mul;
using delta::fx::saturate32;
using delta::fx::shift_round;

std::array<Q12_19, 3> JointController::update(const JointReference& ref, const JointAnglesQ& q,
                                              const std::array<Q10_21, 3>& qd,
                                              const std::array<Q12_19, 3>& feed_forward_Nm,
                                              std::array<bool, 3>& saturated) {
  std::array<Q12_19, 3> tau{};
  for (unsigned j = 0; j < 3; ++j) {
    const Q3_28 e = ref.q_rad[j] - q[j];
    const Q10_21 ed = ref.qd_rad_s[j] - qd[j];
    const Q12_19 pd =
        mul<Q12_19>(gains_.kp_Nm_per_rad, e) + mul<Q12_19>(gains_.kd_Nm_s_per_rad, ed);
    const Q12_19 unsat = pd + integral_[j] + feed_forward_Nm[j];
    const Q12_19 lim = gains_.max_torque_Nm;
    Q12_19 out = unsat;
    saturated[j] = false;
    if (out > lim) {
      out = lim;
      saturated[j] = true;
    } else if (out < -lim) {
      out = -lim;
      saturated[j] = true;
    }
    // Integrate Ki e dt unless that would push further into saturation.
    const bool pushing_out =
        saturated[j] && ((unsat > lim && e.raw() > 0) || (unsat < -lim && e.raw() < 0));
    if (gains_.ki_Nm_per_rad_s.raw() != 0 && !pushing_out) {
      const Q12_19 rate = mul<Q12_19>(gains_.ki_Nm_per_rad_s, e);  // N m per second
      const Q12_19 step = Q12_19::from_raw(saturate32(
          shift_round(std::int64_t{rate.raw()} * static_cast<std::int64_t>(tick_period_q32_), 32)));
      Q12_19 i = integral_[j] + step;
      if (i > gains_.integral_limit_Nm) i = gains_.integral_limit_Nm;
      if (i < -gains_.integral_limit_Nm) i = -gains_.integral_limit_Nm;
      integral_[j] = i;
    }
    tau[j] = out;
  }
  return tau;
}

}  // namespace fw
