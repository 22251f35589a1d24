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
#include <cstddef>

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

// The higher-fidelity model's parameters (docs/model.md): the
// lumped model's, with the arm's centre of mass off the arm line (a sin term),
// the platform's mass split into the mass that is accelerated and the mass
// whose weight is carried, and the coupling of the forearm rods' elbow and
// platform ends. Still linear in every parameter:
//
//   tau_i = I qdd_i - Gc cos(q_i) + Gs sin(q_i) + m_in [J^T pdd]_i
//           + m_w [J^T (0, 0, gravity)]_i + B' psi_i
//           + Fv_i qd_i + Fc_i tanh(qd_i / w) + o_i
//
// with psi_i = J_i . sum_k Bdd_k + e_i . pdd, e_k = dB_k/dq_k the elbow's
// velocity per joint speed and Bdd_k the elbow's acceleration.
struct HighFidelityParameters {
  Joint3 arm_inertia_kg_m2{};          // arm about its axis + armature + rods' elbow share
  Joint3 arm_gravity_cos_Nm{};         // holding torque -Gc cos(q): centre along the arm line
  Joint3 arm_gravity_sin_Nm{};         // holding torque +Gs sin(q): centre below the arm line
  double platform_inertial_mass_kg{};  // the mass the platform's acceleration moves
  double platform_weight_mass_kg{};    // the weight carried at the platform joints
  double forearm_coupling_kg{};        // B' = 2 B per chain: elbow-platform coupling of the rods
  Joint3 viscous_friction_Nm_s_per_rad{};
  Joint3 coulomb_friction_Nm{};
  // Friction's shape: the Stribeck excess at rest, decaying with speed as
  // exp(-(qd / stribeck_velocity)^2), and the smoothing of the sign.
  Joint3 stribeck_friction_Nm{};
  double stribeck_velocity_rad_s{0.1};
  Joint3 torque_offset_Nm{};
  double coulomb_smoothing_rad_s{0.01};
  double gravity_m_s2{9.81};
};

// The lumped robot as a higher-fidelity one: no sin term, no coupling, one
// platform mass for inertia and weight.
HighFidelityParameters to_high_fidelity(const LumpedParameters& p);

// The basis terms of joint i: tau_i = sum of parameter * term.
struct DynamicsBasis {
  Joint3 inertia{};   // qdd_i                    [rad/s^2], times arm_inertia
  Joint3 gravity{};   // -cos(q_i)                [-],       times arm_gravity_moment (cos)
  Joint3 platform{};  // [J^T (pdd - g)]_i        [m^2/s^2/rad], times platform_mass
  Joint3 viscous{};   // qd_i                     [rad/s],   times viscous friction
  Joint3 coulomb{};   // tanh(qd_i / width)       [-],       times Coulomb friction
  // The higher-fidelity model's further terms (platform = the sum of the
  // two platform terms):
  Joint3 gravity_sin{};        // sin(q_i)                  [-],  times arm_gravity_sin
  Joint3 platform_inertial{};  // [J^T pdd]_i               [m^2/s^2/rad], times m_in
  Joint3 platform_weight{};    // [J^T (0, 0, gravity)]_i   [m^2/s^2/rad], times m_w
  Joint3 coupling{};           // psi_i                     [m^2/s^2/rad], times B'
  // exp(-(qd_i / vs)^2) tanh(qd_i / w) [-], times the Stribeck friction;
  // computed where a Stribeck velocity vs > 0 is given, else 0.
  Joint3 stribeck{};
};

struct JointState {
  Joint3 q_rad{};
  Joint3 qd_rad_s{};
  Joint3 qdd_rad_s2{};
};

// The terms of one joint that carry the friction's shape: the smoothed
// Coulomb term tanh(qd / w), and the Stribeck term exp(-(qd / vs)^2)
// tanh(qd / w) where vs > 0 (else 0). dynamics_basis uses them, and a fit
// that searches the shape recomputes them alone.
struct FrictionShapeTerms {
  double coulomb{};
  double stribeck{};
};
FrictionShapeTerms friction_shape_terms(double qd_rad_s, double coulomb_smoothing_rad_s,
                                        double stribeck_velocity_rad_s);

// Computes the basis terms at one sample. Returns kUnreachable or kSingular
// where the pose has no forward kinematics or a singular Jacobian.
KinematicsStatus dynamics_basis(const Geometry& g, const JointState& s, double gravity_m_s2,
                                double coulomb_smoothing_rad_s, DynamicsBasis& out,
                                double stribeck_velocity_rad_s = 0.0);

// tau = basis . parameters.
Joint3 torque_from_basis(const DynamicsBasis& b, const LumpedParameters& p);
Joint3 torque_from_basis(const DynamicsBasis& b, const HighFidelityParameters& p);

// Inverse dynamics: the joint torques that produce s.
KinematicsStatus inverse_dynamics(const Geometry& g, const LumpedParameters& p, const JointState& s,
                                  Joint3& tau_Nm);
KinematicsStatus inverse_dynamics(const Geometry& g, const HighFidelityParameters& p,
                                  const JointState& s, Joint3& tau_Nm);

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
