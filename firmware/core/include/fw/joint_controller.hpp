// Joint control in fixed point: PID per joint plus a feed-forward torque
// (fw/feed_forward.hpp),
//   tau = Kp e + Kd e' + integral + feed_forward,
// saturated at +/- max torque. Anti-windup: the integral only grows while
// the output is not saturated in the direction of the error, and is clamped.
#pragma once

#include <array>
#include <cstdint>

#include "fw/trajectory.hpp"

namespace fw {

using delta::fx::Q12_19;
using delta::fx::Q16_15;

struct JointGains {
  Q16_15 kp_Nm_per_rad{Q16_15::from(60.0)};
  Q12_19 kd_Nm_s_per_rad{Q12_19::from(1.5)};
  Q16_15 ki_Nm_per_rad_s{Q16_15::from(0.0)};  // 0: PD
  Q12_19 max_torque_Nm{Q12_19::from(8.0)};
  Q12_19 integral_limit_Nm{Q12_19::from(1.0)};
};

class JointController {
 public:
  JointController(const JointGains& gains, std::uint32_t tick_period_us)
      : gains_(gains), tick_period_q32_((std::uint64_t{tick_period_us} << 32) / 1000000u) {}

  // One control update; `saturated` tells whether a joint hit max torque.
  std::array<Q12_19, 3> update(const JointReference& ref, const JointAnglesQ& q,
                               const std::array<Q10_21, 3>& qd,
                               const std::array<Q12_19, 3>& feed_forward_Nm,
                               std::array<bool, 3>& saturated);
  void reset() { integral_ = {}; }
  const std::array<Q12_19, 3>& integral() const { return integral_; }

 private:
  JointGains gains_;
  std::uint64_t tick_period_q32_;  // the tick period in seconds, Q0.32
  std::array<Q12_19, 3> integral_{};
};

}  // namespace fw
