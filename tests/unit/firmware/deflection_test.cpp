// The deflection compensation's arithmetic (fw/deflection.hpp) against
// double: the shift c tau and its velocity, for compliances of the stiffest
// to the softest gearbox the record takes and torques over the controller's
// range.
#include "fw/deflection.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "delta/q_conversion.hpp"

namespace fw {
namespace {

using delta::to_double;
using delta::to_q_saturated;

// The motors' reference for arm reference `arm`, following the shift's
// velocity unless `stopping`.
JointReference motor_reference(DeflectionCompensation& d, const std::array<Q1_30, 3>& c,
                               const std::array<Q12_19, 3>& tau, std::uint32_t rate_hz,
                               const JointReference& arm, bool stopping = false) {
  JointReference motor = arm;
  d.shift(c, tau, rate_hz, !stopping, motor);
  return motor;
}

// Within 0.1 % of the configured max torque's deflection (the bar for
// fixed point against double), and in fact to the formats' rounding.
TEST(DeflectionTest, ShiftAndVelocityAgainstDouble) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> torque_Nm(-40.0, 40.0);
  std::uniform_real_distribution<double> stiffness(70.0, 200000.0);
  const double max_torque_Nm = 40.0;
  const std::uint32_t rate_hz = 500;
  double worst_shift = 0.0, worst_velocity = 0.0;
  for (int run = 0; run < 50; ++run) {
    std::array<Q1_30, 3> c{};
    for (auto& v : c) v = to_q_saturated<Q1_30>(1.0 / stiffness(rng));
    DeflectionCompensation d;
    JointReference arm;
    std::array<double, 3> last{};
    for (int tick = 0; tick < 40; ++tick) {
      std::array<Q12_19, 3> tau{};
      for (unsigned j = 0; j < 3; ++j) {
        tau[j] = to_q_saturated<Q12_19>(torque_Nm(rng) * (tick % 2 == 0 ? 1.0 : 0.01));
        arm.q_rad[j] = to_q_saturated<Q3_28>(0.3 * j);
        arm.qd_rad_s[j] = to_q_saturated<Q10_21>(0.5 - 0.2 * j);
      }
      const JointReference m = motor_reference(d, c, tau, rate_hz, arm);
      for (unsigned j = 0; j < 3; ++j) {
        const double shift = to_double(c[j]) * to_double(tau[j]);
        const double velocity = tick == 0 ? 0.0 : (shift - last[j]) * rate_hz;
        last[j] = shift;
        const double tolerance = 1e-3 * max_torque_Nm * to_double(c[j]);
        const double e_shift = std::abs(to_double(m.q_rad[j]) - to_double(arm.q_rad[j]) - shift);
        const double e_velocity =
            std::abs(to_double(m.qd_rad_s[j]) - to_double(arm.qd_rad_s[j]) - velocity);
        EXPECT_LT(e_shift, tolerance);
        EXPECT_LT(e_velocity, tolerance * rate_hz);
        worst_shift = std::max(worst_shift, e_shift);
        worst_velocity = std::max(worst_velocity, e_velocity);
        EXPECT_EQ(d.shift_rad()[j].raw(), (m.q_rad[j] - arm.q_rad[j]).raw());
      }
    }
  }
  std::printf("worst against double: shift %.3g rad, velocity %.3g rad/s\n", worst_shift,
              worst_velocity);
  EXPECT_LT(worst_shift, 1e-8);
  EXPECT_LT(worst_velocity, 1e-5);
}

// A run starts without a velocity step: the first shift has none, nor has
// a stop's; the arm's angle at rest is the motor's less the deflection.
TEST(DeflectionTest, TheFirstTickAndAStopHaveNoVelocityAndTheArmIsBehindTheMotor) {
  DeflectionCompensation d;
  const std::array<Q1_30, 3> c{Q1_30::from(1.0 / 2000), Q1_30::from(1.0 / 2000),
                               Q1_30::from(1.0 / 2000)};
  const std::array<Q12_19, 3> tau{Q12_19::from(2.0), Q12_19::from(-1.0), Q12_19::from(0.0)};
  JointReference arm;
  const JointReference m = motor_reference(d, c, tau, 1000, arm);
  EXPECT_EQ(m.qd_rad_s[0].raw(), 0);
  EXPECT_NEAR(to_double(m.q_rad[0]), 1e-3, 1e-8);
  EXPECT_NEAR(to_double(m.q_rad[1]), -5e-4, 1e-8);
  EXPECT_NEAR(to_double(arm_angle(c[0], tau[0], Q3_28::from(0.5))), 0.499, 1e-8);
  const JointReference second = motor_reference(d, c, {}, 1000, arm);
  EXPECT_NEAR(to_double(second.qd_rad_s[0]), -1.0, 1e-5);  // 1 mrad back in 1 ms
  // A stop: the shift follows the torque, its step is no velocity.
  const JointReference stopped = motor_reference(d, c, tau, 1000, arm, true);
  EXPECT_NEAR(to_double(stopped.q_rad[0]), 1e-3, 1e-8);
  EXPECT_EQ(stopped.qd_rad_s[0].raw(), 0);
  d.reset();
  EXPECT_EQ(motor_reference(d, c, tau, 1000, arm).qd_rad_s[0].raw(), 0);
}

}  // namespace
}  // namespace fw
