// Collision detection (docs/safety.md): each tick, every joint's torque
// residual r = tau_measured - tau_model, where tau_model is the loaded
// model's torque at the reference state (the feed-forward), low-pass
// filtered, against a threshold that grows with the reference's speed and
// acceleration as the model's own residual does:
//   threshold_j = scale (base_j + per_speed_j |qd_ref,j| + per_acceleration_j |qdd_ref,j|).
// A contact's force reaches the residual through the drive: the controller
// holds the reference, so the torque it takes to push against the contact
// is torque the model does not account for. The filter is first order,
//   r_f += (r - r_f) / 2^filter_shift   per tick,
// a time constant of about 2^filter_shift ticks.
//
// Integer only, no heap: the firmware core.
#pragma once

#include <array>
#include <cstdint>

#include "delta/fixed/dynamics.hpp"
#include "delta/fixed/q.hpp"

namespace fw {

using delta::fx::Q10_21;
using delta::fx::Q12_19;
using delta::fx::Q14_17;

// Per joint, the model's own (delta/fixed/dynamics.hpp): they travel with it.
using CollisionThresholds = delta::fx::CollisionThresholdsQ;

struct CollisionConfig {
  bool detect{false};
  Q12_19 threshold_scale{Q12_19::from(1.0)};
  std::uint8_t filter_shift{2};  // 4 ticks
  CollisionThresholds thresholds{};
  friend constexpr bool operator==(const CollisionConfig&, const CollisionConfig&) = default;
};

// The first joint over its threshold, with every joint's filtered residual
// and threshold at that tick.
struct CollisionEvent {
  std::uint8_t joint{0};  // 0..2
  std::array<Q12_19, 3> residual_Nm{};
  std::array<Q12_19, 3> threshold_Nm{};
};

class CollisionDetector {
 public:
  // Clears the filter (a run's start: the residual starts from zero).
  void reset() { filtered_ = {}; }
  // One tick; true (and `event` filled) when a joint's |filtered residual|
  // exceeds its threshold.
  bool update(const CollisionConfig& config, const std::array<Q12_19, 3>& measured_Nm,
              const std::array<Q12_19, 3>& model_Nm, const std::array<Q10_21, 3>& qd_ref,
              const std::array<Q14_17, 3>& qdd_ref, CollisionEvent& event);
  const std::array<Q12_19, 3>& residual_Nm() const { return filtered_; }

 private:
  std::array<Q12_19, 3> filtered_{};
};

// One joint's threshold at a reference speed and acceleration.
Q12_19 collision_threshold(const CollisionConfig& config, unsigned joint, Q10_21 qd_ref,
                           Q14_17 qdd_ref);

}  // namespace fw
