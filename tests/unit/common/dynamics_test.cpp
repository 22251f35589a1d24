#include "delta/dynamics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace delta {
namespace {

TEST(DynamicsTest, StaticTorqueAtHomePoseWorkedByHand) {
  // theta = 0, at rest: tau_i = -G + m_p g [J^T z]_i. By symmetry each joint
  // carries a third of the platform: J (1,1,1) = (0,0,-a) so [J^T z]_i = -a/3.
  // Holding against gravity needs negative (upward) torque.
  const Geometry g = kDefaultGeometry;
  const LumpedParameters p = default_lumped_parameters();
  Joint3 tau{};
  ASSERT_EQ(inverse_dynamics(g, p, JointState{}, tau), KinematicsStatus::kOk);
  const double expected = -0.441 - 0.40 * 9.81 * 0.2 / 3.0;
  for (double t : tau) EXPECT_NEAR(t, expected, 1e-12);
}

TEST(DynamicsTest, ForwardDynamicsInvertsInverseDynamics) {
  const Geometry g = kDefaultGeometry;
  const LumpedParameters p = default_lumped_parameters();
  const JointState s{{0.3, 0.1, 0.6}, {0.8, -1.2, 0.4}, {3.0, -5.0, 2.0}};
  Joint3 tau{};
  ASSERT_EQ(inverse_dynamics(g, p, s, tau), KinematicsStatus::kOk);
  Joint3 qdd{};
  ASSERT_EQ(forward_dynamics(g, p, s.q_rad, s.qd_rad_s, tau, qdd), KinematicsStatus::kOk);
  for (unsigned i = 0; i < 3; ++i) EXPECT_NEAR(qdd[i], s.qdd_rad_s2[i], 1e-10);
}

// Total energy of the frictionless model: arms, platform and gravity.
double energy(const Geometry& g, const LumpedParameters& p, const Joint3& q, const Joint3& qd) {
  const auto fk = forward_kinematics(g, q);
  const auto vk = velocity_kinematics(g, q, qd, fk.position_m);
  const Vec3<double> pd = vk.jacobian * Vec3<double>{qd[0], qd[1], qd[2]};
  double e = 0.5 * p.platform_mass_kg * pd.squared_norm() +
             p.platform_mass_kg * p.gravity_m_s2 * fk.position_m.z;
  for (unsigned i = 0; i < 3; ++i) {
    // tau = ... - G cos(q) is the gradient of the potential -G sin(q).
    e += 0.5 * p.arm_inertia_kg_m2[i] * qd[i] * qd[i] - p.arm_gravity_moment_Nm[i] * std::sin(q[i]);
  }
  return e;
}

TEST(DynamicsTest, FreeMotionWithoutFrictionConservesEnergy) {
  // An independent check of the whole model, the Jdot qdot term included:
  // integrate the unforced, frictionless robot with RK4 for 0.5 s.
  const Geometry g = kDefaultGeometry;
  LumpedParameters p = default_lumped_parameters();
  p.viscous_friction_Nm_s_per_rad = {};
  p.coulomb_friction_Nm = {};
  // Hold it up with a constant torque that balances gravity at the start so
  // it oscillates instead of falling through the workspace.
  Joint3 q{0.4, 0.2, 0.5};
  Joint3 qd{1.0, -0.5, 0.3};
  Joint3 tau_hold{};
  ASSERT_EQ(inverse_dynamics(g, p, JointState{q, {}, {}}, tau_hold), KinematicsStatus::kOk);
  // A constant torque is conservative too: its potential is -tau . q.
  const auto total = [&](const Joint3& qq, const Joint3& vv) {
    return energy(g, p, qq, vv) - (tau_hold[0] * qq[0] + tau_hold[1] * qq[1] + tau_hold[2] * qq[2]);
  };
  const double e0 = total(q, qd);
  const double dt = 1e-4;
  double max_drift = 0.0;
  for (int step = 0; step < 5000; ++step) {
    ASSERT_EQ(integrate_rk4(g, p, tau_hold, dt, 1, q, qd), KinematicsStatus::kOk);
    max_drift = std::max(max_drift, std::abs(total(q, qd) - e0));
  }
  // The motion is lively (kinetic energy ~ 1e-2 J); RK4 drift stays tiny.
  EXPECT_LT(max_drift, 1e-9);
  EXPECT_GT(std::abs(q[0] - 0.4) + std::abs(q[1] - 0.2), 0.05);
}

TEST(DynamicsTest, BasisReportsUnreachablePose) {
  DynamicsBasis b;
  const Geometry short_forearms{0.2, 0.1, 0.1, 0.035};
  EXPECT_EQ(dynamics_basis(short_forearms, JointState{}, 9.81, 0.01, b),
            KinematicsStatus::kUnreachable);
}

}  // namespace
}  // namespace delta
