#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <numbers>

#include "delta/kinematics.hpp"
#include "delta/q_conversion.hpp"
#include "fw/joint_controller.hpp"
#include "fw/torque_from_current.hpp"
#include "fw/trajectory.hpp"

namespace fw {
namespace {

using delta::to_double;
using delta::to_q_saturated;
using delta::fx::Q7_24;

GeometryQ default_geometry() {
  const delta::Geometry g = delta::kDefaultGeometry;
  return {to_q_saturated<Q7_24>(g.upper_arm_length_m), to_q_saturated<Q7_24>(g.forearm_length_m),
          to_q_saturated<Q7_24>(g.base_radius_m), to_q_saturated<Q7_24>(g.platform_radius_m)};
}

// A pick-and-place trajectory through points [m], one segment each.
TrajectoryConfig pick_and_place(std::initializer_list<std::array<double, 3>> points,
                                std::uint32_t segment_ticks, std::uint32_t cycles) {
  TrajectoryConfig c;
  c.kind = TrajectoryKind::kPickAndPlace;
  auto& p = c.pick_and_place;
  p.waypoints = 0;
  for (const auto& pt : points) {
    p.points[p.waypoints++] = {to_q_saturated<Q7_24>(pt[0]), to_q_saturated<Q7_24>(pt[1]),
                               to_q_saturated<Q7_24>(pt[2])};
  }
  p.segment_ticks = segment_ticks;
  p.cycles = cycles;
  return c;
}

TEST(TorqueFromCurrentTest, GearRatioTorqueConstantEfficiencySignAndOffset) {
  JointTorqueConfig c;
  c.gear_ratio = Q12_19::from(10.0);
  c.torque_constant_Nm_per_A = Q7_24::from(0.05);
  c.efficiency = Q1_30::from(0.9);
  c.offset_Nm = Q12_19::from(0.02);
  // 10 * 0.05 * 0.9 * 2 A + 0.02 = 0.92 N m.
  EXPECT_NEAR(to_double(torque_from_current(c, Q12_19::from(2.0))), 0.92, 4e-6);
  c.inverted = true;
  EXPECT_NEAR(to_double(torque_from_current(c, Q12_19::from(2.0))), -0.88, 4e-6);
  // The inverse gives back the current.
  EXPECT_NEAR(to_double(current_from_torque(c, Q12_19::from(-0.88))), 2.0, 1e-5);
  c.gear_ratio = Q12_19::zero();
  EXPECT_EQ(current_from_torque(c, Q12_19::from(1.0)).raw(), 0);
}

TrajectoryConfig fourier_config() {
  TrajectoryConfig c;
  c.kind = TrajectoryKind::kFourier;
  c.tick_period_us = 1000;
  c.blend_ticks = 1000;
  auto& f = c.fourier;
  f.base_frequency_mHz = 250;
  f.harmonics = 3;
  f.periods = 2;
  f.q0_rad = {to_q_saturated<Q3_28>(0.45), to_q_saturated<Q3_28>(0.45),
              to_q_saturated<Q3_28>(0.45)};
  const double amp[3][3][2] = {{{0.10, 0.05}, {-0.04, 0.03}, {0.02, -0.01}},
                               {{-0.08, 0.06}, {0.05, 0.02}, {-0.01, 0.02}},
                               {{0.07, -0.09}, {0.03, -0.03}, {0.015, 0.01}}};
  for (unsigned j = 0; j < 3; ++j) {
    for (unsigned k = 0; k < 3; ++k) {
      f.sin_amplitude_rad[j][k] = to_q_saturated<Q3_28>(amp[j][k][0]);
      f.cos_amplitude_rad[j][k] = to_q_saturated<Q3_28>(amp[j][k][1]);
    }
  }
  return c;
}

// The same trajectory in double: window * Fourier series.
void fourier_double(const TrajectoryConfig& c, double t, double length_s, double out[3][3]) {
  const auto& f = c.fourier;
  const double w0 = 2.0 * std::numbers::pi * f.base_frequency_mHz / 1000.0;
  const double tb = c.blend_ticks * c.tick_period_us * 1e-6;
  double w = 1, dw = 0, ddw = 0;
  const auto win = [&](double s, double sign) {
    w = s * s * s * (10 - 15 * s + 6 * s * s);
    dw = sign * 30 * s * s * (1 - s) * (1 - s) / tb;
    ddw = 60 * s * (1 - s) * (1 - 2 * s) / (tb * tb);
  };
  if (t < tb) win(t / tb, 1.0);
  if (t > length_s - tb) win((length_s - t) / tb, -1.0);
  for (unsigned j = 0; j < 3; ++j) {
    double d = 0, dd = 0, ddd = 0;
    for (unsigned k = 1; k <= f.harmonics; ++k) {
      const double A = to_double(f.sin_amplitude_rad[j][k - 1]),
                   B = to_double(f.cos_amplitude_rad[j][k - 1]);
      const double kw = k * w0;
      d += A * std::sin(kw * t) + B * std::cos(kw * t);
      dd += kw * (A * std::cos(kw * t) - B * std::sin(kw * t));
      ddd += -kw * kw * (A * std::sin(kw * t) + B * std::cos(kw * t));
    }
    out[j][0] = to_double(f.q0_rad[j]) + w * d;
    out[j][1] = w * dd + dw * d;
    out[j][2] = w * ddd + 2 * dw * dd + ddw * d;
  }
}

// The trajectory against its double evaluation at ticks first, first +
// stride, ... up to last: q within 1e-7 rad, qd 2e-5 rad/s, qdd 2e-4 rad/s^2
// (1 ms ticks).
void expect_fourier_matches_double(const Trajectory& traj, const TrajectoryConfig& c,
                                   std::uint32_t first, std::uint32_t last, std::uint32_t stride) {
  const double length_s = traj.length_ticks() * 1e-3;
  double worst[3] = {0, 0, 0};
  for (std::uint32_t tick = first; tick <= last; tick += stride) {
    JointReference r;
    ASSERT_EQ(traj.reference(tick, r), KinematicsStatus::kOk);
    double d[3][3];
    fourier_double(c, tick * 1e-3, length_s, d);
    for (unsigned j = 0; j < 3; ++j) {
      worst[0] = std::max(worst[0], std::abs(to_double(r.q_rad[j]) - d[j][0]));
      worst[1] = std::max(worst[1], std::abs(to_double(r.qd_rad_s[j]) - d[j][1]));
      worst[2] = std::max(worst[2], std::abs(to_double(r.qdd_rad_s2[j]) - d[j][2]));
    }
  }
  EXPECT_LT(worst[0], 1e-7);  // rad
  EXPECT_LT(worst[1], 2e-5);  // rad/s
  EXPECT_LT(worst[2], 2e-4);  // rad/s^2
}

TEST(TrajectoryTest, FourierMatchesItsDoubleEvaluationWithExactDerivatives) {
  const TrajectoryConfig c = fourier_config();
  const Trajectory traj(default_geometry(), c);
  // 2 blends of 1 s + 2 periods of 4 s.
  ASSERT_EQ(traj.length_ticks(), 10000u);
  expect_fourier_matches_double(traj, c, 0, traj.length_ticks(), 7);
}

// All six harmonics (the sines and cosines of harmonics 2 to 6 come from
// the base's by the angle sum), late in a long run (the base phase from
// integers does not drift): as close to the double evaluation as above.
TEST(TrajectoryTest, FourierSixHarmonicsMatchDoubleLateInALongRun) {
  TrajectoryConfig c = fourier_config();
  auto& f = c.fourier;
  f.base_frequency_mHz = 170;
  f.harmonics = kMaxHarmonics;
  f.periods = 100;  // 588 s, near the longest run (kMaxTrajectoryTicks)
  for (unsigned j = 0; j < 3; ++j) {
    for (unsigned k = 0; k < kMaxHarmonics; ++k) {
      const double sign = (j + k) % 2 == 0 ? 1.0 : -1.0;
      f.sin_amplitude_rad[j][k] = to_q_saturated<Q3_28>(sign * 0.06 / (k + 1));
      f.cos_amplitude_rad[j][k] = to_q_saturated<Q3_28>(-sign * 0.03 / (k + 1));
    }
  }
  const Trajectory traj(default_geometry(), c);
  expect_fourier_matches_double(traj, c, 1500, traj.length_ticks() - 1000, 997);
}

TEST(TrajectoryTest, FourierStartsAndEndsAtRestAtQ0) {
  const TrajectoryConfig c = fourier_config();
  const Trajectory traj(default_geometry(), c);
  for (const std::uint32_t tick : {0u, traj.length_ticks()}) {
    JointReference r;
    ASSERT_EQ(traj.reference(tick, r), KinematicsStatus::kOk);
    for (unsigned j = 0; j < 3; ++j) {
      EXPECT_EQ(r.q_rad[j], c.fourier.q0_rad[j]);
      EXPECT_EQ(r.qd_rad_s[j].raw(), 0);
      EXPECT_EQ(r.qdd_rad_s2[j].raw(), 0);
    }
  }
}

TEST(TrajectoryTest, VelocityIsTheDerivativeOfPositionThroughTheBlends) {
  const TrajectoryConfig c = fourier_config();
  const Trajectory traj(default_geometry(), c);
  JointReference a, b, m;
  double worst = 0;
  for (std::uint32_t tick = 1; tick + 1 < traj.length_ticks(); tick += 13) {
    traj.reference(tick - 1, a);
    traj.reference(tick, m);
    traj.reference(tick + 1, b);
    for (unsigned j = 0; j < 3; ++j) {
      const double fd = (to_double(b.q_rad[j]) - to_double(a.q_rad[j])) / 2e-3;
      worst = std::max(worst, std::abs(fd - to_double(m.qd_rad_s[j])));
    }
  }
  EXPECT_LT(worst, 1e-4);
}

TEST(TrajectoryTest, LimitCheckNamesTheBrokenLimitTickAndJoint) {
  const GeometryQ g = default_geometry();
  TrajectoryConfig c = fourier_config();
  EXPECT_EQ(check_trajectory(g, c, JointLimits{}).fault, TrajectoryFault::kOk);

  JointLimits tight;
  tight.max_rad = to_q_saturated<Q3_28>(0.5);
  TrajectoryCheck r = check_trajectory(g, c, tight);
  EXPECT_EQ(r.fault, TrajectoryFault::kJointLimit);
  EXPECT_GT(r.tick, 0u);
  EXPECT_GE(r.joint, 0);

  JointLimits slow;
  slow.max_velocity_rad_s = to_q_saturated<Q10_21>(0.1);
  EXPECT_EQ(check_trajectory(g, c, slow).fault, TrajectoryFault::kVelocityLimit);

  JointLimits gentle;
  gentle.max_acceleration_rad_s2 = to_q_saturated<Q14_17>(0.2);
  EXPECT_EQ(check_trajectory(g, c, gentle).fault, TrajectoryFault::kAccelerationLimit);

  // Forearms of 0.25 m cannot close over elbows 0.265 m out: no platform pose.
  GeometryQ short_forearms = g;
  short_forearms.forearm_length_m = to_q_saturated<Q7_24>(0.25);
  TrajectoryConfig flat = c;
  for (auto& q : flat.fourier.q0_rad) q = Q3_28::zero();
  const TrajectoryCheck w = check_trajectory(short_forearms, flat, JointLimits{});
  EXPECT_EQ(w.fault, TrajectoryFault::kOutsideWorkspace);
  EXPECT_EQ(w.tick, 0u);

  TrajectoryConfig bad = c;
  bad.fourier.harmonics = 0;
  EXPECT_EQ(check_trajectory(g, bad, JointLimits{}).fault, TrajectoryFault::kInvalidConfig);
  bad = c;
  bad.tick_period_us = 0;
  EXPECT_EQ(check_trajectory(g, bad, JointLimits{}).fault, TrajectoryFault::kInvalidConfig);
}

// The check walks every tick, so a trajectory longer than
// kMaxTrajectoryTicks is refused without being walked: one of exactly that
// length is walked (a limit broken at tick 0 shows it), one tick more is
// not. Lengths past 32 bits are refused too, not wrapped into short ones.
TEST(TrajectoryTest, ATrajectoryLongerThanTheCheckWalksIsRefusedAsTooLong) {
  const GeometryQ g = default_geometry();
  JointLimits above_q0;  // q0 is 0.45 rad: every walk stops at tick 0
  above_q0.min_rad = to_q_saturated<Q3_28>(0.5);
  TrajectoryConfig c = fourier_config();  // 250 mHz: 4000 ticks a period
  c.blend_ticks = 2000;
  c.fourier.periods = 149;  // 2 * 2000 + 149 * 4000 = 600000
  ASSERT_EQ(Trajectory(g, c).length_ticks(), kMaxTrajectoryTicks);
  const TrajectoryCheck longest = check_trajectory(g, c, above_q0);
  EXPECT_EQ(longest.fault, TrajectoryFault::kJointLimit);
  EXPECT_EQ(longest.tick, 0u);

  c.fourier.periods = 150;
  const TrajectoryCheck over = check_trajectory(g, c, above_q0);
  EXPECT_EQ(over.fault, TrajectoryFault::kTooLong);
  EXPECT_EQ(over.tick, kMaxTrajectoryTicks + 1);
  EXPECT_EQ(over.joint, -1);
  EXPECT_STREQ(trajectory_fault_name(over.fault), "too long");
  EXPECT_EQ(Trajectory(g, c).length_ticks(), 0u);  // nothing to arm

  // 1 mHz for 100 periods at 1 us a tick: 10^11 ticks, which 32 bits
  // would have wrapped to 1.2 * 10^9.
  c.tick_period_us = 1;
  c.fourier.base_frequency_mHz = 1;
  c.fourier.periods = 100;
  EXPECT_EQ(check_trajectory(g, c, JointLimits{}).fault, TrajectoryFault::kTooLong);
  // 4 * 10^9 periods of 10^12 / 1000 ticks: past 64 bits, saturated.
  c.fourier.periods = 4000000000u;
  EXPECT_EQ(check_trajectory(g, c, JointLimits{}).fault, TrajectoryFault::kTooLong);
  // 10 waypoints of 2^31 ticks, twice: 32 bits would have wrapped to 0.
  TrajectoryConfig p = pick_and_place({{-0.08, 0.0, -0.48}, {0.08, 0.05, -0.42}}, 1u << 31, 2);
  p.pick_and_place.waypoints = kMaxWaypoints;
  EXPECT_EQ(check_trajectory(g, p, JointLimits{}).fault, TrajectoryFault::kTooLong);
  // 8 waypoints of 2^31 ticks, 2^30 times: 2^64, which 64 bits would have
  // wrapped to 0 (a trajectory of no ticks). Saturated instead.
  p.pick_and_place.waypoints = 8;
  p.pick_and_place.cycles = 1u << 30;
  EXPECT_EQ(check_trajectory(g, p, JointLimits{}).fault, TrajectoryFault::kTooLong);
}

TEST(TrajectoryTest, PickAndPlaceFollowsTheInverseKinematicsOfTheCartesianPath) {
  const GeometryQ g = default_geometry();
  TrajectoryConfig c =
      pick_and_place({{-0.08, 0.0, -0.48}, {0.08, 0.05, -0.42}, {0.0, -0.08, -0.5}}, 500, 2);
  auto& p = c.pick_and_place;
  ASSERT_EQ(check_trajectory(g, c, JointLimits{}).fault, TrajectoryFault::kOk);
  const Trajectory traj(g, c);
  ASSERT_EQ(traj.length_ticks(), 3000u);
  // At a waypoint the robot is at rest on the IK of that point.
  JointReference r;
  ASSERT_EQ(traj.reference(500, r), KinematicsStatus::kOk);
  const auto ik =
      delta::inverse_kinematics(delta::kDefaultGeometry, delta::Vec3<double>{0.08, 0.05, -0.42});
  for (unsigned j = 0; j < 3; ++j) {
    EXPECT_NEAR(to_double(r.q_rad[j]), ik.theta_rad[j], 2e-6);
    EXPECT_NEAR(to_double(r.qd_rad_s[j]), 0.0, 1e-3);
  }
  // Mid-segment: qd is the central difference of q.
  JointReference a, b;
  traj.reference(1249, a);
  traj.reference(1250, r);
  traj.reference(1251, b);
  for (unsigned j = 0; j < 3; ++j) {
    EXPECT_NEAR(to_double(r.qd_rad_s[j]), (to_double(b.q_rad[j]) - to_double(a.q_rad[j])) / 2e-3,
                1e-5);
    EXPECT_GT(std::abs(to_double(r.qd_rad_s[j])), 0.01);
  }
  // A path towards a point out of reach breaks the velocity limit near the
  // singularity before it leaves the workspace: the first broken limit is named.
  p.points[1].z_m = to_q_saturated<Q7_24>(-0.9);
  const TrajectoryCheck towards = check_trajectory(g, c, JointLimits{});
  EXPECT_EQ(towards.fault, TrajectoryFault::kVelocityLimit);
  EXPECT_GT(towards.tick, 0u);  // within segment 0, which heads to point 1
  EXPECT_LT(towards.tick, 500u);
  // Starting out of reach fails at tick 0.
  p.points[0].z_m = to_q_saturated<Q7_24>(-0.9);
  const TrajectoryCheck start = check_trajectory(g, c, JointLimits{});
  EXPECT_EQ(start.fault, TrajectoryFault::kOutsideWorkspace);
  EXPECT_EQ(start.tick, 0u);
}

// The platform's acceleration a pick-and-place reference gives the model:
// the minimum-jerk path's, and the same as J qdd + J'q' of the joint
// reference (double kinematics at the same state) up to that reference's
// own noise: its qdd is a central difference of fixed-point IK solutions
// (about 1e-7 rad each), some 0.2 m/s^2 here. A wrong segment, sign or
// time scale would be off by the size of the acceleration.
TEST(TrajectoryTest, PickAndPlaceGivesThePlatformsAccelerationOfItsPath) {
  const GeometryQ g = default_geometry();
  const std::array<std::array<double, 3>, 2> pts{{{-0.08, 0.0, -0.48}, {0.08, 0.05, -0.42}}};
  const TrajectoryConfig c = pick_and_place({pts[0], pts[1]}, 300, 1);
  const Trajectory traj(g, c);
  double worst_path = 0.0, worst_joints = 0.0, largest = 0.0;
  for (std::uint32_t tick = 0; tick <= traj.length_ticks(); tick += 7) {
    JointReference r;
    ASSERT_EQ(traj.reference(tick, r), KinematicsStatus::kOk);
    ASSERT_TRUE(r.platform_known);
    const std::uint32_t seg = (tick / 300) % 2;
    const double s = (tick % 300) / 300.0;
    const double ddw = 60.0 * s * (1.0 - s) * (1.0 - 2.0 * s) / (0.3 * 0.3);  // per s^2
    delta::JointVector<double> q{}, qd{}, qdd{};
    for (unsigned j = 0; j < 3; ++j) {
      q[j] = to_double(r.q_rad[j]);
      qd[j] = to_double(r.qd_rad_s[j]);
      qdd[j] = to_double(r.qdd_rad_s2[j]);
    }
    const delta::Vec3<double> p{to_double(r.platform_m.x_m), to_double(r.platform_m.y_m),
                                to_double(r.platform_m.z_m)};
    const auto vk = delta::velocity_kinematics(delta::kDefaultGeometry, q, qd, p);
    const double jdq[3] = {vk.jacobian_dot_qdot.x, vk.jacobian_dot_qdot.y, vk.jacobian_dot_qdot.z};
    for (unsigned r3 = 0; r3 < 3; ++r3) {
      const double given = to_double(r.platform_acceleration_m_s2[r3]);
      const double path = (pts[1 - seg][r3] - pts[seg][r3]) * ddw;
      double joints = jdq[r3];
      for (unsigned j = 0; j < 3; ++j) joints += vk.jacobian(r3, j) * qdd[j];
      worst_path = std::max(worst_path, std::abs(given - path));
      worst_joints = std::max(worst_joints, std::abs(given - joints));
      largest = std::max(largest, std::abs(path));
    }
  }
  EXPECT_GT(largest, 1.0);                // m/s^2: the test sees real accelerations
  EXPECT_LT(worst_path, 2e-5 * largest);  // rounding only
  EXPECT_LT(worst_joints, 0.05 * largest);
  std::printf(
      "pick-and-place platform acceleration: largest %.3g m/s^2, from the path within %.2g,"
      " from the joint reference within %.2g\n",
      largest, worst_path, worst_joints);
}

// Without the platform (the nominal feed-forward has no use for it), the
// joints' reference is the same and platform_known says it is not there.
TEST(TrajectoryTest, PickAndPlaceWithoutThePlatformGivesTheSameJoints) {
  const TrajectoryConfig c = pick_and_place({{-0.08, 0.0, -0.48}, {0.08, 0.05, -0.42}}, 300, 1);
  const Trajectory with(default_geometry(), c), without(default_geometry(), c);
  for (std::uint32_t tick = 0; tick <= with.length_ticks(); tick += 13) {
    JointReference a, b;
    ASSERT_EQ(with.reference(tick, a), KinematicsStatus::kOk);
    ASSERT_EQ(without.reference(tick, b, false), KinematicsStatus::kOk);
    EXPECT_TRUE(a.platform_known);
    EXPECT_FALSE(b.platform_known);
    for (unsigned j = 0; j < 3; ++j) {
      EXPECT_EQ(a.q_rad[j], b.q_rad[j]);
      EXPECT_EQ(a.qd_rad_s[j], b.qd_rad_s[j]);
      EXPECT_EQ(a.qdd_rad_s2[j], b.qdd_rad_s2[j]);
    }
  }
}

// reference() keeps the IK of the last three ticks, so that stepping tick by
// tick solves one new IK. The reference must not depend on what was asked
// before: stepping, a scrambled order and a fresh Trajectory per tick agree
// bit for bit, also where the path leaves the workspace.
TEST(TrajectoryTest, PickAndPlaceReferenceDoesNotDependOnTheTicksAskedBefore) {
  const GeometryQ g = default_geometry();
  // The second point is out of reach.
  const TrajectoryConfig c = pick_and_place({{-0.05, 0.02, -0.45}, {0.06, -0.03, -0.9}}, 200, 1);
  const Trajectory stepped(g, c);
  const Trajectory scrambled(g, c);
  const std::uint32_t n = stepped.length_ticks();
  ASSERT_EQ(n, 400u);
  const auto same = [](const JointReference& a, const JointReference& b) {
    for (unsigned j = 0; j < 3; ++j) {
      if (a.q_rad[j] != b.q_rad[j] || a.qd_rad_s[j] != b.qd_rad_s[j] ||
          a.qdd_rad_s2[j] != b.qdd_rad_s2[j] ||
          a.platform_acceleration_m_s2[j] != b.platform_acceleration_m_s2[j]) {
        return false;
      }
    }
    return true;
  };
  int unreachable = 0;
  for (std::uint32_t tick = 0; tick <= n + 2; ++tick) {  // past the end too
    JointReference fresh_ref, stepped_ref;
    const auto fresh_status = Trajectory(g, c).reference(tick, fresh_ref);
    ASSERT_EQ(stepped.reference(tick, stepped_ref), fresh_status) << tick;
    if (fresh_status == KinematicsStatus::kOk) {
      EXPECT_TRUE(same(stepped_ref, fresh_ref)) << tick;
    } else {
      ++unreachable;
    }
    // Scrambled: a stride coprime to n + 1, each tick asked twice, and a
    // step back now and then.
    const std::uint32_t t = tick * 97 % (n + 1);
    for (const std::uint32_t asked : {t, t, t > 0 ? t - 1 : t, t}) {
      JointReference cold, warm;
      const auto cold_status = Trajectory(g, c).reference(asked, cold);
      ASSERT_EQ(scrambled.reference(asked, warm), cold_status) << asked;
      if (cold_status == KinematicsStatus::kOk) {
        EXPECT_TRUE(same(warm, cold)) << asked;
      }
    }
  }
  // The path does leave the workspace, and comes back to the first point:
  // windows across both edges were compared.
  EXPECT_GT(unreachable, 100);
  EXPECT_LT(unreachable, 300);
}

TEST(JointControllerTest, PdWithFeedForwardSaturationAndAntiWindup) {
  JointGains gains;
  gains.kp_Nm_per_rad = Q16_15::from(50.0);
  gains.kd_Nm_s_per_rad = Q12_19::from(2.0);
  gains.ki_Nm_per_rad_s = Q16_15::from(100.0);
  gains.max_torque_Nm = Q12_19::from(3.0);
  gains.integral_limit_Nm = Q12_19::from(0.5);
  const FeedForwardConfig nominal{
      FeedForwardMode::kNominal, NominalDynamics{Q12_19::from(0.01), Q12_19::from(0.4)}, {}};
  JointController ctl(gains, 1000);
  JointReference ref;
  ref.q_rad = {to_q_saturated<Q3_28>(0.30), to_q_saturated<Q3_28>(0.30),
               to_q_saturated<Q3_28>(0.30)};
  ref.qd_rad_s = {to_q_saturated<Q10_21>(0.5), {}, {}};
  ref.qdd_rad_s2 = {to_q_saturated<Q14_17>(10.0), {}, {}};
  const JointAnglesQ q = {to_q_saturated<Q3_28>(0.29), to_q_saturated<Q3_28>(0.30),
                          to_q_saturated<Q3_28>(0.0)};
  const std::array<Q10_21, 3> qd = {to_q_saturated<Q10_21>(0.4), {}, {}};
  std::array<bool, 3> sat{};
  Joint3Q12_19 ff{};
  ASSERT_EQ(feed_forward_torque(nominal, ref, ff), KinematicsStatus::kOk);
  const auto tau = ctl.update(ref, q, qd, ff, sat);
  // Joint 1: 50 * 0.01 + 2 * 0.1 + 0.01 * 10 - 0.4 cos(0.3); the integral
  // (Ki e dt = 1e-3 per cycle) acts from the next cycle on.
  EXPECT_NEAR(to_double(tau[0]), 0.5 + 0.2 + 0.1 - 0.4 * std::cos(0.3), 1e-5);
  EXPECT_NEAR(to_double(ctl.integral()[0]), 0.001, 1e-5);
  EXPECT_FALSE(sat[0]);
  // Joint 3: 50 * 0.3 = 15 N m -> saturated at 3 N m.
  EXPECT_NEAR(to_double(tau[2]), 3.0, 1e-6);
  EXPECT_TRUE(sat[2]);
  // While saturated the integral of joint 3 does not wind up.
  for (int i = 0; i < 1000; ++i) ctl.update(ref, q, qd, ff, sat);
  EXPECT_EQ(ctl.integral()[2].raw(), 0);
  // Joint 1's integral grows, but stops at its limit.
  EXPECT_NEAR(to_double(ctl.integral()[0]), 0.5, 1e-6);
}

}  // namespace
}  // namespace fw
