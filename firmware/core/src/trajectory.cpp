#include "fw/trajectory.hpp"

#include "delta/fixed/math.hpp"

namespace fw {

using delta::fx::convert;
using delta::fx::div;
using delta::fx::kTwoPi;
using delta::fx::mul;
using delta::fx::narrow;
using delta::fx::Q16_15;
using delta::fx::saturate32;
using delta::fx::shift_round;
using delta::fx::sincos;
using delta::fx::SinCos;
using i64 = std::int64_t;
using u64 = std::uint64_t;

namespace {

constexpr u64 kNanoPerSecondMilli = 1000000000ull;  // mHz * us = 1e-9 turns

bool fourier_valid(const TrajectoryConfig& c) {
  const auto& f = c.fourier;
  return f.harmonics >= 1 && f.harmonics <= kMaxHarmonics && f.base_frequency_mHz > 0 &&
         f.base_frequency_mHz <= 10000 && f.periods >= 1 && c.blend_ticks >= 1;
}

bool pick_and_place_valid(const TrajectoryConfig& c) {
  const auto& p = c.pick_and_place;
  return p.waypoints >= 2 && p.waypoints <= kMaxWaypoints && p.segment_ticks >= 2 && p.cycles >= 1;
}

bool config_valid(const TrajectoryConfig& c) {
  if (c.tick_period_us == 0 || c.tick_period_us > 100000 || 1000000 % c.tick_period_us != 0) {
    return false;
  }
  return c.kind == TrajectoryKind::kFourier ? fourier_valid(c) : pick_and_place_valid(c);
}

// a * b, or UINT64_MAX where that would not fit.
u64 saturating_mul(u64 a, u64 b) {
  return a != 0 && b > UINT64_MAX / a ? UINT64_MAX : a * b;
}

// The last tick of a valid configuration, in 64 bits and saturating: a long
// one would wrap 32 bits, and the core's counts (periods, cycles) can make
// it wrap 64. Fourier: whole periods of the base frequency, rounded to
// ticks, plus the blends.
u64 length_ticks_of(const TrajectoryConfig& c) {
  if (c.kind == TrajectoryKind::kFourier) {
    const auto& f = c.fourier;
    const u64 period_ticks_e3 =
        kNanoPerSecondMilli * 1000 / (u64{f.base_frequency_mHz} * c.tick_period_us);
    const u64 periods_e3 = saturating_mul(period_ticks_e3, f.periods);
    // Rounded to the nearest tick; at most 2^64 / 1000 + 2^33: no wrap.
    return 2 * u64{c.blend_ticks} + periods_e3 / 1000 + (periods_e3 % 1000 >= 500 ? 1 : 0);
  }
  const auto& p = c.pick_and_place;
  return saturating_mul(u64{p.waypoints} * p.segment_ticks, p.cycles);
}

// The base harmonic's phase (tick * f * dt) as a fraction of a turn in
// Q0.32, exactly from integers (floor): it never drifts, however long the
// run.
std::uint32_t base_phase_turns_q32(std::uint32_t tick, std::uint32_t f_mHz, std::uint32_t dt_us) {
  const u64 turns_e9 = (u64{tick} * f_mHz % kNanoPerSecondMilli) * dt_us % kNanoPerSecondMilli;
  return static_cast<std::uint32_t>((turns_e9 << 32) / kNanoPerSecondMilli);
}

// A phase in Q0.32 turns as an angle in (-pi, pi].
Q3_28 phase_angle(std::uint32_t turns_q32) {
  const i64 signed_turns = static_cast<std::int32_t>(turns_q32);  // (-1/2, 1/2] turn
  return Q3_28::from_raw(static_cast<std::int32_t>(shift_round(signed_turns * kTwoPi.raw(), 32)));
}

// The sine and cosine of the angle a + b from theirs, each with one
// rounding.
SinCos angle_sum(const SinCos& a, const SinCos& b) {
  const auto unit = [](i64 v) { return Q1_30::from_raw(saturate32(shift_round(v, 30))); };
  return {unit(i64{a.sin.raw()} * b.cos.raw() + i64{a.cos.raw()} * b.sin.raw()),
          unit(i64{a.cos.raw()} * b.cos.raw() - i64{a.sin.raw()} * b.sin.raw())};
}

// x * ticks_per_second, saturating: the second of the two multiplies that
// take a second difference per tick^2 to per s^2 (the tick period divides
// one second exactly). After the first, x can reach 2^54, and the second
// could leave 64 bits: inputs beyond 2^40 saturate. Real motion stays far
// below. (A first difference needs no check: |d1| * 10^6 < 2^53.)
i64 per_second(i64 x, std::uint32_t ticks_per_second) {
  constexpr i64 kLimit = i64{1} << 40;  // * (at most 1e6 ticks/s) < 2^60
  if (x > kLimit) return INT64_MAX;
  if (x < -kLimit) return INT64_MIN;
  return x * ticks_per_second;
}

// num / den (both > 0, the quotient below 2^30) as m 2^-e with m in
// [2^30, 2^31), rounded: once per trajectory.
ScaledValue scaled_ratio(u64 num, u64 den) {
  int e = 0;
  while (num < (den << 30)) {  // den < 2^32: no wrap
    num <<= 1;
    ++e;
  }
  u64 m = (num + den / 2) / den;
  if (m >= (u64{1} << 31)) {
    m >>= 1;
    --e;
  }
  return {static_cast<std::int32_t>(m), e};
}

// The square of a scaled value, in the same form.
ScaledValue squared(ScaledValue v) {
  u64 m = (u64{static_cast<std::uint32_t>(v.mantissa)} * static_cast<std::uint32_t>(v.mantissa) +
           (u64{1} << 30)) >>
          31;
  int e = 2 * v.exponent - 31;
  if (m < (u64{1} << 30)) {
    m <<= 1;
    ++e;
  }
  return {static_cast<std::int32_t>(m), e};
}

// x (raw, fraction bits from) times a scaled value, to a raw value with
// fraction bits to; rounded, saturated.
std::int32_t times_scaled(std::int32_t x, int from, ScaledValue v, int to) {
  return saturate32(shift_round(i64{x} * v.mantissa, from + v.exponent - to));
}

}  // namespace

namespace {

// w = s^3 (10 - 15 s + 6 s^2), from s and s^2.
Q1_30 min_jerk_w(Q1_30 s, Q1_30 s2) {
  const Q1_30 s3 = mul<Q1_30>(s2, s);
  // 10 - 15 s + 6 s^2 lies in [0.625, 10]: in Q7.24.
  const Q7_24 poly =
      Q7_24::from(10.0) - mul<Q7_24>(Q7_24::from(15.0), s) + mul<Q7_24>(Q7_24::from(6.0), s2);
  return mul<Q1_30>(s3, poly);
}

// d2w/ds2 = 60 s (1 - s)(1 - 2 s), at most 5.8.
Q3_28 min_jerk_ddw(Q1_30 s) {
  const Q1_30 one = Q1_30::from(1.0);
  return mul<Q3_28>(mul<Q7_24>(Q7_24::from(60.0), mul<Q1_30>(s, one - s)), one - s.scaled_by(2));
}

}  // namespace

Q1_30 min_jerk_position(Q1_30 s) {
  return min_jerk_w(s, mul<Q1_30>(s, s));
}

MinJerk min_jerk(Q1_30 s) {
  const Q1_30 one = Q1_30::from(1.0);
  const Q1_30 s2 = mul<Q1_30>(s, s);
  const Q1_30 u = one - s;
  MinJerk r;
  r.w = min_jerk_w(s, s2);
  r.dw = mul<Q1_30>(mul<Q7_24>(Q7_24::from(30.0), s2), mul<Q1_30>(u, u));
  r.ddw = min_jerk_ddw(s);
  return r;
}

Trajectory::Trajectory(const GeometryQ& geometry, const TrajectoryConfig& config)
    : geometry_(geometry), config_(config) {
  if (!config_valid(config_)) return;
  const u64 length = length_ticks_of(config_);
  if (length > kMaxTrajectoryTicks) return;  // check_trajectory: kTooLong
  length_ticks_ = static_cast<std::uint32_t>(length);
  ticks_per_second_ = 1000000u / config_.tick_period_us;
  if (config_.kind == TrajectoryKind::kFourier) {
    // w = 2 pi f: Q3.28 * mHz / 1000 -> Q10.21.
    base_omega_rad_s_ = Q10_21::from_raw(
        saturate32(shift_round(i64{kTwoPi.raw()} * config_.fourier.base_frequency_mHz, 7) / 1000));
    const auto& f = config_.fourier;
    for (unsigned k = 1; k <= f.harmonics; ++k) {
      const Q10_21 kw = base_omega_rad_s_.scaled_by(static_cast<std::int32_t>(k));
      for (unsigned j = 0; j < 3; ++j) {
        HarmonicRates& r = harmonic_rates_[j][k - 1];
        r.sin_velocity = mul<Q10_21>(f.sin_amplitude_rad[j][k - 1], kw);
        r.cos_velocity = mul<Q10_21>(f.cos_amplitude_rad[j][k - 1], kw);
        r.sin_acceleration = mul<Q14_17>(r.sin_velocity, kw);
        r.cos_acceleration = mul<Q14_17>(r.cos_velocity, kw);
      }
    }
    per_blend_ = scaled_ratio(ticks_per_second_, config_.blend_ticks);
    per_blend_squared_ = squared(per_blend_);
  } else {
    // Segments per second, saturated (beyond 65536 the accelerations are
    // far over any joint limit, which check_trajectory() refuses).
    segments_per_second_ = Q16_15::from_raw(
        saturate32((i64{ticks_per_second_} << 15) / config_.pick_and_place.segment_ticks));
  }
}

KinematicsStatus Trajectory::reference(std::uint32_t tick, JointReference& out,
                                       bool with_platform) const {
  if (length_ticks_ == 0) return KinematicsStatus::kUnreachable;
  if (tick > length_ticks_) tick = length_ticks_;
  if (config_.kind == TrajectoryKind::kFourier) {
    fourier(tick, out);
    return KinematicsStatus::kOk;
  }
  return pick_and_place(tick, out, with_platform);
}

void Trajectory::fourier(std::uint32_t tick, JointReference& out) const {
  const auto& f = config_.fourier;
  out.platform_known = false;  // joint space: the model solves it
  // Harmonic k's sine and cosine, in Q1.28 (so that the twelve products of
  // a sum stay below 2^63); harmonic 1's from sincos(), harmonic k's from
  // k - 1's by the angle sum (within 2e-8 of those of k times the phase).
  // Each product is a 32-bit value times one of at most 2^28: below 2^59,
  // so 2 kMaxHarmonics of them stay below 2^63 while that is at most 16.
  static_assert(2 * kMaxHarmonics <= 16, "the Fourier sums of products would leave 64 bits");
  const SinCos base =
      sincos(phase_angle(base_phase_turns_q32(tick, f.base_frequency_mHz, config_.tick_period_us)));
  std::array<std::int32_t, kMaxHarmonics> sin_q28{}, cos_q28{};
  SinCos sc = base;
  for (unsigned k = 0; k < f.harmonics; ++k) {
    if (k > 0) sc = angle_sum(sc, base);
    sin_q28[k] = delta::fx::shift_round32(sc.sin.raw(), 2);
    cos_q28[k] = delta::fx::shift_round32(sc.cos.raw(), 2);
  }
  // delta(t), delta'(t), delta''(t): each a sum of products rounded once.
  std::array<Q3_28, 3> d{};
  std::array<Q10_21, 3> dd{};
  std::array<Q14_17, 3> ddd{};
  for (unsigned j = 0; j < 3; ++j) {
    i64 position = 0, velocity = 0, acceleration = 0;  // Q.56, Q.49, Q.45
    for (unsigned k = 0; k < f.harmonics; ++k) {
      const HarmonicRates& r = harmonic_rates_[j][k];
      const i64 s = sin_q28[k], c = cos_q28[k];
      position += f.sin_amplitude_rad[j][k].raw() * s + f.cos_amplitude_rad[j][k].raw() * c;
      velocity += r.sin_velocity.raw() * c - r.cos_velocity.raw() * s;
      acceleration -= r.sin_acceleration.raw() * s + r.cos_acceleration.raw() * c;
    }
    d[j] = Q3_28::from_raw(narrow<28>(position));
    dd[j] = Q10_21::from_raw(narrow<28>(velocity));
    ddd[j] = Q14_17::from_raw(narrow<28>(acceleration));
  }
  // The window: rising over the first blend, falling over the last.
  const std::uint32_t nb = config_.blend_ticks;
  Q1_30 w = Q1_30::from(1.0);
  Q10_21 dw_dt{};
  Q14_17 ddw_dt2{};
  const bool rising = tick < nb;
  const bool falling = tick + nb > length_ticks_;
  if (rising || falling) {
    const std::uint32_t n = rising ? tick : length_ticks_ - tick;
    const MinJerk win = min_jerk(delta::fx::ratio(n, nb));
    // d/dt = (d/ds) / T_blend; d2/dt2 = (d2/ds2) / T_blend^2.
    const std::int32_t dw = times_scaled(win.dw.raw(), 30, per_blend_, 21);
    w = win.w;
    dw_dt = falling && !rising ? -Q10_21::from_raw(dw) : Q10_21::from_raw(dw);
    ddw_dt2 = Q14_17::from_raw(times_scaled(win.ddw.raw(), 28, per_blend_squared_, 17));
  }
  for (unsigned j = 0; j < 3; ++j) {
    out.q_rad[j] = f.q0_rad[j] + mul<Q3_28>(w, d[j]);
    out.qd_rad_s[j] = mul<Q10_21>(w, dd[j]) + mul<Q10_21>(dw_dt, d[j]);
    out.qdd_rad_s2[j] = mul<Q14_17>(w, ddd[j]) + mul<Q14_17>(dw_dt, dd[j]).scaled_by(2) +
                        mul<Q14_17>(ddw_dt2, d[j]);
  }
}

KinematicsStatus Trajectory::cartesian_ik(std::int64_t tick, JointAnglesQ& q,
                                          Vec3Q& platform) const {
  const auto& p = config_.pick_and_place;
  if (tick < 0) tick = 0;
  if (tick > length_ticks_) tick = length_ticks_;
  const auto t = static_cast<std::uint32_t>(tick);
  const std::uint32_t seg = (t / p.segment_ticks) % p.waypoints;
  const std::uint32_t in_seg = t % p.segment_ticks;
  const Q1_30 s = delta::fx::ratio(in_seg, p.segment_ticks);
  const Q1_30 f = min_jerk_position(s);
  const Vec3Q& a = p.points[seg];
  const Vec3Q& b = p.points[(seg + 1) % p.waypoints];
  const Vec3Q pos{a.x_m + mul<Q7_24>(b.x_m - a.x_m, f), a.y_m + mul<Q7_24>(b.y_m - a.y_m, f),
                  a.z_m + mul<Q7_24>(b.z_m - a.z_m, f)};
  const auto ik = delta::fx::inverse_kinematics(geometry_, pos);
  q = ik.theta_rad;
  platform = pos;
  return ik.status;
}

std::array<Q10_21, 3> Trajectory::cartesian_acceleration(std::uint32_t tick) const {
  const auto& p = config_.pick_and_place;
  const std::uint32_t seg = (tick / p.segment_ticks) % p.waypoints;
  const Q1_30 s = delta::fx::ratio(tick % p.segment_ticks, p.segment_ticks);
  const Q3_28 ddw = min_jerk_ddw(s);  // per segment^2
  const Vec3Q& a = p.points[seg];
  const Vec3Q& b = p.points[(seg + 1) % p.waypoints];
  const auto per_s2 = [&](Q7_24 from, Q7_24 to) {
    const Q10_21 per_segment = mul<Q10_21>(mul<Q10_21>(to - from, ddw), segments_per_second_);
    return mul<Q10_21>(per_segment, segments_per_second_);
  };
  return {per_s2(a.x_m, b.x_m), per_s2(a.y_m, b.y_m), per_s2(a.z_m, b.z_m)};
}

KinematicsStatus Trajectory::pick_and_place(std::uint32_t tick, JointReference& out,
                                            bool with_platform) const {
  IkWindow& w = ik_window_;
  const i64 centre = tick;
  if (centre == w.centre + 1) {  // the next tick: one new IK
    w.q[0] = w.q[1];
    w.q[1] = w.q[2];
    w.platform[0] = w.platform[1];
    w.platform[1] = w.platform[2];
    w.status[0] = w.status[1];
    w.status[1] = w.status[2];
    w.status[2] = cartesian_ik(centre + 1, w.q[2], w.platform[2]);
  } else if (centre != w.centre) {
    for (unsigned k = 0; k < 3; ++k) {
      w.status[k] = cartesian_ik(centre - 1 + k, w.q[k], w.platform[k]);
    }
  }
  w.centre = centre;
  for (const KinematicsStatus st : w.status) {
    if (st != KinematicsStatus::kOk) return st;
  }
  const JointAnglesQ& before = w.q[0];
  const JointAnglesQ& now = w.q[1];
  const JointAnglesQ& after = w.q[2];
  const std::uint32_t rate = ticks_per_second_;
  out.platform_known = with_platform;
  if (with_platform) {
    out.platform_m = w.platform[1];
    out.platform_acceleration_m_s2 = cartesian_acceleration(tick);
  }
  for (unsigned j = 0; j < 3; ++j) {
    out.q_rad[j] = now[j];
    // Central differences: Q3.28 per tick -> Q10.21 per second (and Q14.17).
    // |d1|, |d2| < 2^34 and rate <= 10^6: d1 * rate and d2 * rate fit 64
    // bits; only the second multiply of d2 needs per_second's check.
    const i64 d1 = i64{after[j].raw()} - before[j].raw();
    const i64 d2 = i64{after[j].raw()} - 2 * i64{now[j].raw()} + before[j].raw();
    out.qd_rad_s[j] = Q10_21::from_raw(narrow<8>(d1 * rate));
    out.qdd_rad_s2[j] = Q14_17::from_raw(narrow<11>(per_second(d2 * rate, rate)));
  }
  return KinematicsStatus::kOk;
}

namespace {

// The first joint limit ref breaks, or kOk (joint: the joint, else -1).
TrajectoryFault joint_limit_fault(const JointReference& ref, const JointLimits& limits,
                                  int& joint) {
  for (unsigned j = 0; j < 3; ++j) {
    joint = static_cast<int>(j);
    if (ref.q_rad[j] < limits.min_rad || ref.q_rad[j] > limits.max_rad) {
      return TrajectoryFault::kJointLimit;
    }
    if (delta::fx::abs(ref.qd_rad_s[j]) > limits.max_velocity_rad_s) {
      return TrajectoryFault::kVelocityLimit;
    }
    if (delta::fx::abs(ref.qdd_rad_s2[j]) > limits.max_acceleration_rad_s2) {
      return TrajectoryFault::kAccelerationLimit;
    }
  }
  joint = -1;
  return TrajectoryFault::kOk;
}

// Whether the feed-forward at ref stays within the max torque.
TrajectoryFault feed_forward_fault(const TrajectoryBounds& b, const JointReference& ref,
                                   int& joint) {
  Joint3Q12_19 tau{};
  joint = -1;
  if (feed_forward_torque(b.feed_forward, ref, tau) != KinematicsStatus::kOk) {
    return TrajectoryFault::kOutsideWorkspace;
  }
  for (unsigned j = 0; j < 3; ++j) {
    if (delta::fx::abs(tau[j]) > b.max_torque_Nm) {
      joint = static_cast<int>(j);
      return TrajectoryFault::kFeedForwardLimit;
    }
  }
  return TrajectoryFault::kOk;
}

}  // namespace

namespace {

// The walk of check_trajectory(), with the feed-forward's torques checked
// where bounds are given.
TrajectoryCheck walk(const GeometryQ& geometry, const TrajectoryConfig& config,
                     const JointLimits& limits, const TrajectoryBounds* bounds) {
  TrajectoryCheck c;
  if (!config_valid(config)) {
    c.fault = TrajectoryFault::kInvalidConfig;
    return c;
  }
  if (length_ticks_of(config) > kMaxTrajectoryTicks) {
    c.fault = TrajectoryFault::kTooLong;
    c.tick = kMaxTrajectoryTicks + 1;  // the first tick past what may be walked
    return c;
  }
  const Trajectory traj(geometry, config);
  JointReference ref;
  for (std::uint32_t tick = 0; tick <= traj.length_ticks(); ++tick) {
    c.tick = tick;
    if (traj.reference(tick, ref) != KinematicsStatus::kOk) {
      c.fault = TrajectoryFault::kOutsideWorkspace;
      return c;
    }
    c.fault = joint_limit_fault(ref, limits, c.joint);
    if (c.fault != TrajectoryFault::kOk) return c;
    if (config.kind == TrajectoryKind::kFourier &&
        delta::fx::forward_kinematics(geometry, ref.q_rad).status != KinematicsStatus::kOk) {
      c.fault = TrajectoryFault::kOutsideWorkspace;
      return c;
    }
    if (bounds != nullptr) {
      c.fault = feed_forward_fault(*bounds, ref, c.joint);
      if (c.fault != TrajectoryFault::kOk) return c;
    }
  }
  c.tick = 0;
  return c;
}

}  // namespace

TrajectoryCheck check_trajectory(const GeometryQ& geometry, const TrajectoryConfig& config,
                                 const JointLimits& limits) {
  return walk(geometry, config, limits, nullptr);
}

TrajectoryCheck check_trajectory(const TrajectoryBounds& bounds, const TrajectoryConfig& config) {
  return walk(bounds.geometry, config, bounds.limits, &bounds);
}

}  // namespace fw
