// The delta's lumped-mass dynamic model, written once for `host_id simulate`,
// the identification models and the emulator's plant.
//
// With the forearm constraint forces resolved at every sample (lambda is not a
// constant), the joint torques are
//
//   tau_i = I_i qdd_i - G_i cos(q_i) + m_p [J^T (pdd - g)]_i
//           + Fv_i qd_i + Fc_i tanh(qd_i / w) + o_i
//
// with g = (0, 0, -gravity). Every parameter enters linearly: tau is a sum of
// parameter * basis term, and the basis terms are computed here.
#pragma once

#include <array>

#include "delta/geometry.hpp"
#include "delta/kinematics.hpp"

namespace delta {

using Joint3 = std::array<double, 3>;

// Physical parameters of the lumped model. Angles and torques are at the
// joint (after the gearbox), as in the contract.
struct LumpedParameters {
  // Arm inertia about the motor axis, including the reflected rotor inertia
  // and the forearm mass lumped at the elbow.
  Joint3 arm_inertia_kg_m2{};
  // Gravity moment of the arm at theta = 0: gravity * (arm mass * its centre
  // of mass distance + elbow mass * upper_arm_length).
  Joint3 arm_gravity_moment_Nm{};
  // Equivalent platform mass: platform, payload and the forearm mass lumped at
  // the platform.
  double platform_mass_kg{};
  Joint3 viscous_friction_Nm_s_per_rad{};
  Joint3 coulomb_friction_Nm{};
  Joint3 torque_offset_Nm{};
  // The Coulomb term's sign is smoothed as tanh(qd / width) near zero speed.
  double coulomb_smoothing_rad_s{0.01};
  double gravity_m_s2{9.81};
};

// The basis terms of joint i: tau_i = sum of parameter * term.
struct DynamicsBasis {
  Joint3 inertia{};   // qdd_i                    [rad/s^2], times arm_inertia
  Joint3 gravity{};   // -cos(q_i)                [-],       times arm_gravity_moment
  Joint3 platform{};  // [J^T (pdd - g)]_i        [m^2/s^2/rad], times platform_mass
  Joint3 viscous{};   // qd_i                     [rad/s],   times viscous friction
  Joint3 coulomb{};   // tanh(qd_i / width)       [-],       times Coulomb friction
};

struct JointState {
  Joint3 q_rad{};
  Joint3 qd_rad_s{};
  Joint3 qdd_rad_s2{};
};

// Computes the basis terms at one sample. Returns kUnreachable or kSingular
// where the pose has no forward kinematics or a singular Jacobian.
KinematicsStatus dynamics_basis(const Geometry& g, const JointState& s, double gravity_m_s2,
                                double coulomb_smoothing_rad_s, DynamicsBasis& out);

// tau = basis . parameters.
Joint3 torque_from_basis(const DynamicsBasis& b, const LumpedParameters& p);

// Inverse dynamics: the joint torques that produce s.
KinematicsStatus inverse_dynamics(const Geometry& g, const LumpedParameters& p, const JointState& s,
                                  Joint3& tau_Nm);

// Forward dynamics: the joint accelerations under tau at (q, qd):
//   (diag(I) + m_p J^T J) qdd = tau - [-G cos q + m_p J^T (Jdot qd - g) + friction + o].
KinematicsStatus forward_dynamics(const Geometry& g, const LumpedParameters& p, const Joint3& q_rad,
                                  const Joint3& qd_rad_s, const Joint3& tau_Nm, Joint3& qdd_rad_s2);

// Advances (q, qd) by dt under the constant torque tau: classical RK4 over
// `substeps` equal sub-steps (the emulator's plant and the tests). Stops and
// returns the status at the first pose without kinematics.
KinematicsStatus integrate_rk4(const Geometry& g, const LumpedParameters& p, const Joint3& tau_Nm,
                               double dt_s, int substeps, Joint3& q_rad, Joint3& qd_rad_s);

// Parameters of the default robot (kDefaultGeometry): a plausible small delta
// with 0.2 m arms, used by `host_id simulate` and the emulator's plant.
LumpedParameters default_lumped_parameters();

}  // namespace delta
