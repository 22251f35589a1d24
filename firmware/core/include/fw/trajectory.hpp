// Excitation trajectories in fixed point, evaluated per control tick:
//   - a Fourier series per joint around q0, with exact derivatives, faded in
//     from rest and out to rest by a quintic window;
//   - a Cartesian pick-and-place cycle of minimum-jerk segments through the
//     inverse kinematics (3 IK per tick: q at t - dt, t, t + dt give qd, qdd).
// Before any motion, check_trajectory() walks every tick against the joint,
// velocity, acceleration and workspace limits.
#pragma once

#include <array>
#include <cstdint>

#include "delta/controller/vocabulary.hpp"
#include "delta/fixed/dynamics.hpp"
#include "delta/fixed/kinematics.hpp"
#include "fw/feed_forward.hpp"

namespace fw {

using delta::KinematicsStatus;
using delta::fx::GeometryQ;
using delta::fx::JointAnglesQ;
using delta::fx::Q10_21;
using delta::fx::Q14_17;
using delta::fx::Q1_30;
using delta::fx::Q3_28;
using delta::fx::Q7_24;
using delta::fx::Vec3Q;

inline constexpr int kMaxHarmonics = 6;
inline constexpr int kMaxWaypoints = 10;
// check_trajectory() refuses a trajectory longer than this (kTooLong)
// rather than walk it for minutes (the controller's vocabulary says why).
using delta::controller::kMaxTrajectoryTicks;

// The minimum-jerk profile w(s) = 10 s^3 - 15 s^4 + 6 s^5 on s in [0, 1]
// and its s-derivatives: the blends, the Cartesian segments and the
// controller's approach all use it.
struct MinJerk {
  Q1_30 w;
  Q1_30 dw;   // 30 s^2 (1 - s)^2, at most 1.875
  Q3_28 ddw;  // 60 s (1 - s)(1 - 2 s), at most 5.8
};
MinJerk min_jerk(Q1_30 s);
// Its w alone, the same value (for the Cartesian segments, whose rates come
// from differences of positions).
Q1_30 min_jerk_position(Q1_30 s);

// The reference the controller tracks at one tick.
using JointReference = delta::fx::JointStateQ;

// q_j(t) = q0_j + sum_k [ A_jk sin(k w t) + B_jk cos(k w t) ],  w = 2 pi f.
struct FourierConfig {
  std::uint32_t base_frequency_mHz{200};
  std::uint8_t harmonics{0};  // 1..kMaxHarmonics
  JointAnglesQ q0_rad{};
  std::array<std::array<Q3_28, kMaxHarmonics>, 3> sin_amplitude_rad{};  // A
  std::array<std::array<Q3_28, kMaxHarmonics>, 3> cos_amplitude_rad{};  // B
  std::uint32_t periods{1};  // whole periods between the blends
};

struct PickAndPlaceConfig {
  std::uint8_t waypoints{0};  // 2..kMaxWaypoints, visited in a cycle
  std::array<Vec3Q, kMaxWaypoints> points{};
  std::uint32_t segment_ticks{400};
  std::uint32_t cycles{1};
};

enum class TrajectoryKind : std::uint8_t { kFourier = 0, kPickAndPlace = 1 };

struct TrajectoryConfig {
  TrajectoryKind kind{TrajectoryKind::kFourier};
  std::uint32_t tick_period_us{1000};  // must divide one second exactly
  std::uint32_t blend_ticks{1000};     // Fourier: fade in and out from rest
  FourierConfig fourier{};
  PickAndPlaceConfig pick_and_place{};
};

struct JointLimits {
  Q3_28 min_rad{Q3_28::from(-1.2)};
  Q3_28 max_rad{Q3_28::from(1.4)};
  Q10_21 max_velocity_rad_s{Q10_21::from(6.0)};
  Q14_17 max_acceleration_rad_s2{Q14_17::from(150.0)};
  friend constexpr bool operator==(const JointLimits&, const JointLimits&) = default;
};

using delta::controller::trajectory_fault_name;
using delta::controller::TrajectoryFault;

struct TrajectoryCheck {
  TrajectoryFault fault{TrajectoryFault::kOk};
  std::uint32_t tick{0};
  int joint{-1};
};

// A positive value as mantissa 2^-exponent, the mantissa in [2^30, 2^31):
// 31 significant bits whatever the value's size.
struct ScaledValue {
  std::int32_t mantissa{0};
  int exponent{0};
};

class Trajectory {
 public:
  Trajectory(const GeometryQ& geometry, const TrajectoryConfig& config);
  // Ticks from the start to the end at rest (the last tick is included).
  std::uint32_t length_ticks() const { return length_ticks_; }
  // The reference at tick (0 <= tick <= length_ticks()); kUnreachable for a
  // Cartesian point outside the workspace. A Cartesian trajectory gives the
  // platform's position and acceleration too (platform_known), unless
  // with_platform is false: only the model's feed-forward uses them.
  KinematicsStatus reference(std::uint32_t tick, JointReference& out,
                             bool with_platform = true) const;
  const TrajectoryConfig& config() const { return config_; }

 private:
  void fourier(std::uint32_t tick, JointReference& out) const;
  KinematicsStatus pick_and_place(std::uint32_t tick, JointReference& out,
                                  bool with_platform) const;
  KinematicsStatus cartesian_ik(std::int64_t tick, JointAnglesQ& q, Vec3Q& platform) const;
  // The platform's acceleration at a pick-and-place tick, from the
  // minimum-jerk profile's second derivative.
  std::array<Q10_21, 3> cartesian_acceleration(std::uint32_t tick) const;

  GeometryQ geometry_;
  TrajectoryConfig config_;
  std::uint32_t length_ticks_{0};
  std::uint32_t ticks_per_second_{0};
  Q10_21 base_omega_rad_s_{};
  // Fourier: each harmonic's amplitudes times k w and (k w)^2, per joint.
  struct HarmonicRates {
    Q10_21 sin_velocity{}, cos_velocity{};          // A k w, B k w
    Q14_17 sin_acceleration{}, cos_acceleration{};  // A (k w)^2, B (k w)^2
  };
  std::array<std::array<HarmonicRates, kMaxHarmonics>, 3> harmonic_rates_{};
  // Fourier: 1 / T_blend and 1 / T_blend^2 in 1/s and 1/s^2 (no division
  // per tick).
  ScaledValue per_blend_{}, per_blend_squared_{};
  delta::fx::Q16_15 segments_per_second_{};  // pick-and-place
  // The IK at ticks centre - 1, centre and centre + 1 of the last
  // pick-and-place reference(): stepping tick by tick, each reference()
  // then solves one new IK instead of three. (Single-threaded use, as
  // everything in the core.)
  struct IkWindow {
    std::int64_t centre{-10};  // none yet
    std::array<KinematicsStatus, 3> status{};
    std::array<JointAnglesQ, 3> q{};
    std::array<Vec3Q, 3> platform{};
  };
  mutable IkWindow ik_window_{};
};

// Walks every tick of the trajectory (a rejected configuration gives
// kInvalidConfig at tick 0; one longer than kMaxTrajectoryTicks, kTooLong
// at tick kMaxTrajectoryTicks + 1, without walking it).
TrajectoryCheck check_trajectory(const GeometryQ& geometry, const TrajectoryConfig& config,
                                 const JointLimits& limits);

// What a run is checked against: the kinematic limits, and the torque the
// feed-forward asks for at every tick, which must stay within max_torque_Nm
// (kFeedForwardLimit names the tick and the joint; a pose where the model
// has no kinematics is kOutsideWorkspace).
struct TrajectoryBounds {
  GeometryQ geometry{};
  JointLimits limits{};
  FeedForwardConfig feed_forward{};
  Q12_19 max_torque_Nm{Q12_19::max()};
  friend constexpr bool operator==(const TrajectoryBounds&, const TrajectoryBounds&) = default;
};
TrajectoryCheck check_trajectory(const TrajectoryBounds& bounds, const TrajectoryConfig& config);

// A trajectory with the result of check_trajectory() against bounds. Only
// check() makes one, so that Controller::start() can arm it without walking
// it again: the walk takes milliseconds and belongs off the control thread
// (the Linux port's Modbus server runs it).
class CheckedTrajectory {
 public:
  static CheckedTrajectory check(const TrajectoryBounds& bounds, const TrajectoryConfig& config) {
    CheckedTrajectory t;
    t.config_ = config;
    t.bounds_ = bounds;
    t.result_ = check_trajectory(bounds, config);
    return t;
  }
  bool ok() const { return result_.fault == TrajectoryFault::kOk; }
  const TrajectoryCheck& result() const { return result_; }
  const TrajectoryConfig& config() const { return config_; }
  bool checked_against(const TrajectoryBounds& bounds) const { return bounds == bounds_; }

 private:
  CheckedTrajectory() = default;
  TrajectoryConfig config_{};
  TrajectoryBounds bounds_{};
  TrajectoryCheck result_{};
};

}  // namespace fw
