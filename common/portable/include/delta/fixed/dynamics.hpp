// The identified dynamic model in fixed point: the torques of the `delta`
// model that `host_id fit` identifies (docs/model.md), with the
// constraint forces resolved at every state through the forward
// kinematics, the Jacobian J and J'q' (lambda is not a constant):
//
//   tau_i = I_i qdd_i - Gc_i cos q_i + Gs_i sin q_i + m_in [J^T pdd]_i
//           + m_w [J^T (0, 0, g)]_i + B' psi_i
//           + Fv_i qd_i + Fc_i tanh(qd_i / w)
//           + Fs_i exp(-(qd_i / vs)^2) tanh(qd_i / w) + o_i
//
// with pdd = J qdd + J'q' and psi_i the forearm rods' coupling term. The
// `lumped` model is the case Gs = 0, B' = 0, m_in = m_w. J is never formed
// for the torques: the platform's terms are J^T F for one force F, and J^T
// = diag(a n_k . e_k) N^-T with N the forearms' directions, so they take
// one solve with N's adjugate, the constraint forces (lambda) at this
// pose. Every Q format is
// in the types; the figures against the double model are in
// docs/design/fixed-point-core.md (tests/unit/common/fixed_dynamics_test.cpp measures them).
#pragma once

#include <array>
#include <cstdint>

#include "delta/fixed/kinematics.hpp"

namespace delta::fx {

// Which model the parameters came from (the controller shows it; the
// equations are the same).
enum class ModelKind : std::uint8_t { kNone = 0, kDelta = 1, kLumped = 2 };

using Joint3Q12_19 = std::array<Q12_19, 3>;

struct ModelParametersQ {
  ModelKind kind{ModelKind::kNone};
  std::array<Q7_24, 3> arm_inertia_kg_m2{};
  Joint3Q12_19 arm_gravity_cos_Nm{};
  Joint3Q12_19 arm_gravity_sin_Nm{};
  Q7_24 platform_inertial_mass_kg{};
  Q7_24 platform_weight_mass_kg{};
  Q7_24 forearm_coupling_kg{};
  Joint3Q12_19 viscous_friction_Nm_s_per_rad{};
  Joint3Q12_19 coulomb_friction_Nm{};
  Joint3Q12_19 stribeck_friction_Nm{};
  Joint3Q12_19 torque_offset_Nm{};
  Q10_21 coulomb_smoothing_rad_s{Q10_21::from(0.01)};  // > 0
  Q10_21 stribeck_velocity_rad_s{};                    // 0: no Stribeck term
  Q7_24 gravity_m_s2{Q7_24::from(9.81)};
  // The drive train (host_id fit's torque gains and load friction,
  // docs/model.md): the drive's torque for the model's y is
  //   y / (1 - gap_j - mu_j tanh(qd_j / w) sign y),
  // the divisor held at kSmallestDriveGain at least. Zero: the drive
  // converts exactly and its gear loses nothing with load (y as it is).
  std::array<Q1_30, 3> torque_gain_gap{};  // |gap| < 1/2; joint 1's is 0 (the unit)
  std::array<Q1_30, 3> load_friction{};    // in [0, 1/2)
  // Each gearbox's compliance 1 / K [rad/(N m)] (`host_id fit --elastic`,
  // or a given stiffness): the controller's deflection compensation
  // (fw/deflection.hpp). Zero: rigid. In [0, 1/64).
  std::array<Q1_30, 3> gearbox_compliance_rad_per_Nm{};
  friend constexpr bool operator==(const ModelParametersQ&, const ModelParametersQ&) = default;
};

// How far each joint's measured torque may stray from the model's before
// it is a collision (the controller's detector, docs/safety.md): the
// threshold base + per_speed |qd| + per_acceleration |qdd|, per joint.
// `host_id fit` derives them from the fit's own residual; they travel with
// the model.
struct CollisionThresholdsQ {
  Joint3Q12_19 base_Nm{};
  Joint3Q12_19 per_speed_Nm_s_per_rad{};
  Joint3Q12_19 per_acceleration_Nm_s2_per_rad{};
  friend constexpr bool operator==(const CollisionThresholdsQ&,
                                   const CollisionThresholdsQ&) = default;
};

// A joint-space state: the reference the controller tracks. Where the
// platform's position and acceleration at this state are known already (a
// Cartesian trajectory has them), the model takes them instead of solving
// the forward kinematics and J qdd + J'q' again.
struct JointStateQ {
  JointAnglesQ q_rad{};
  std::array<Q10_21, 3> qd_rad_s{};
  std::array<Q14_17, 3> qdd_rad_s2{};
  bool platform_known{false};
  Vec3Q platform_m{};
  std::array<Q10_21, 3> platform_acceleration_m_s2{};
};

// The velocity kinematics at one pose, as the double version computes them
// (delta/kinematics.hpp): pd = J qd, pdd = J qdd + J'q'.
struct VelocityKinematicsQ {
  KinematicsStatus status{KinematicsStatus::kSingular};
  std::array<std::array<Q7_24, 3>, 3> jacobian_m_per_rad{};  // [row x, y, z][joint]
  std::array<Q10_21, 3> jacobian_dot_qdot_m_s2{};
};

// The forearms' normalised directions must keep |det| >= this: closer to
// the parallel singularity the terms leave their formats (kSingular). The
// workspace's own limit (min_transmission 0.05) lies well inside it.
inline constexpr Q1_30 kMinForearmDeterminant = Q1_30::from(1.0 / 64.0);

VelocityKinematicsQ velocity_kinematics(const GeometryQ& g, const JointAnglesQ& q,
                                        const std::array<Q10_21, 3>& qd, const Vec3Q& p);

// A model ready to run: its parameters, the geometry it was fitted for, and
// what model_torque() would otherwise work out at every state (reciprocals
// and products of the parameters). Only prepare_model() makes one: a
// parameter changed afterwards would leave those stale.
struct ModelQ {
  GeometryQ geometry{};
  ModelParametersQ parameters{};
  Q7_24 inverse_forearm_per_m{};         // 1 / b
  Q10_21 inverse_smoothing_s_per_rad{};  // 1 / w
  Q10_21 inverse_stribeck_s_per_rad{};   // 1 / vs; 0 without the Stribeck term
  Q7_24 coupling_moment_kg_m{};          // m_c a
  Q12_19 platform_weight_N{};            // m_w g
  friend constexpr bool operator==(const ModelQ&, const ModelQ&) = default;
};

// The smallest divisor of the drive train's torque (as host_id fit's model
// holds it): the torque stays finite.
inline constexpr Q1_30 kSmallestDriveGain = Q1_30::from(0.05);

// The smallest smoothing and Stribeck velocities prepare_model() takes
// (their reciprocals must fit Q10.21).
inline constexpr Q10_21 kMinFrictionVelocity = Q10_21::from(1.0 / 1000.0);

// Prepares m for geometry g. The caller checks the values' ranges first
// (smoothing and Stribeck velocities of at least kMinFrictionVelocity, a
// forearm longer than 1/128 m).
ModelQ prepare_model(const GeometryQ& g, const ModelParametersQ& m);

// The model's joint torques at state s. kUnreachable or kSingular where the
// pose has no kinematics (tau is then zero).
KinematicsStatus model_torque(const ModelQ& model, const JointStateQ& s, Joint3Q12_19& tau_Nm);

}  // namespace delta::fx
