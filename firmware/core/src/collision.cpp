#include "fw/collision.hpp"

#include "delta/fixed/math.hpp"

namespace fw {

using delta::fx::abs;
using delta::fx::mul;
using delta::fx::saturate32;
using delta::fx::shift_round;

Q12_19 collision_threshold(const CollisionConfig& config, unsigned joint, Q10_21 qd_ref,
                           Q14_17 qdd_ref) {
  const CollisionThresholds& t = config.thresholds;
  const Q12_19 raw = t.base_Nm[joint] + mul<Q12_19>(t.per_speed_Nm_s_per_rad[joint], abs(qd_ref)) +
                     mul<Q12_19>(t.per_acceleration_Nm_s2_per_rad[joint], abs(qdd_ref));
  return mul<Q12_19>(config.threshold_scale, raw);
}

bool CollisionDetector::update(const CollisionConfig& config,
                               const std::array<Q12_19, 3>& measured_Nm,
                               const std::array<Q12_19, 3>& model_Nm,
                               const std::array<Q10_21, 3>& qd_ref,
                               const std::array<Q14_17, 3>& qdd_ref, CollisionEvent& event) {
  bool detected = false;
  std::array<Q12_19, 3> threshold{};
  for (unsigned j = 0; j < 3; ++j) {
    const std::int64_t r = std::int64_t{measured_Nm[j].raw()} - model_Nm[j].raw();
    const std::int64_t f = filtered_[j].raw();
    filtered_[j] = Q12_19::from_raw(saturate32(f + shift_round(r - f, config.filter_shift)));
    threshold[j] = collision_threshold(config, j, qd_ref[j], qdd_ref[j]);
    if (!detected && abs(filtered_[j]) > threshold[j]) {
      detected = true;
      event.joint = static_cast<std::uint8_t>(j);
    }
  }
  if (detected) {
    event.residual_Nm = filtered_;
    event.threshold_Nm = threshold;
  }
  return detected;
}

}  // namespace fw
