#include "delta/dynamics.hpp"

#include <cmath>

namespace delta {

namespace {

template <class T>
struct PoseKinematics {
  Vec3<T> p{};
  VelocityKinematics<T> vk{};
};

// The joint angles' cosines and sines, computed once per sample for the
// kinematics and the dynamics terms alike.
template <class T>
struct JointTrig {
  JointVector<T> cos_q{}, sin_q{};
};

JointTrig<double> trig_of(const Joint3& q) {
  JointTrig<double> t;
  for (unsigned i = 0; i < 3; ++i) {
    t.cos_q[i] = std::cos(q[i]);
    t.sin_q[i] = std::sin(q[i]);
  }
  return t;
}

template <class T>
KinematicsStatus pose_kinematics(const BasicGeometry<T>& g, const JointTrig<T>& t,
                                 const JointVector<T>& qd, PoseKinematics<T>& out) {
  const auto fk = forward_kinematics(g, t.cos_q, t.sin_q);
  if (fk.status != KinematicsStatus::kOk) return fk.status;
  out.p = fk.position_m;
  out.vk = velocity_kinematics(g, t.cos_q, t.sin_q, qd, out.p);
  return out.vk.status;
}

template <class T>
JointVector<T> transpose_times(const Mat3<T>& J, const Vec3<T>& v) {
  const Vec3<T> r = J.transposed() * v;
  return {r.x, r.y, r.z};
}

// The rods' coupling term psi_i = J_i . sum_k Bdd_k + e_i . pdd of the
// higher-fidelity model (docs/model.md). The elbow
// B_k = (R + a cos q) u_k - a sin q z moves with e_k = dB_k/dq_k =
// -a (sin q u_k + cos q z), and accelerates at Bdd_k = e_k qdd_k + f_k qd_k^2
// with f_k = de_k/dq_k = a (-cos q u_k + sin q z).
template <class T>
JointVector<T> coupling_term(const BasicGeometry<T>& g, const JointVector<T>& qd,
                             const JointVector<T>& qdd, const JointTrig<T>& t, const Mat3<T>& J,
                             const Vec3<T>& pdd) {
  const T a = g.upper_arm_length_m;
  Vec3<T> e[3];
  Vec3<T> elbow_acceleration_sum{};
  for (unsigned k = 0; k < 3; ++k) {
    const T c = t.cos_q[k];
    const T sn = t.sin_q[k];
    const Vec3<T> u{T(kChainCos[k]), T(kChainSin[k]), T(0.0)};
    e[k] = Vec3<T>{-a * sn * u.x, -a * sn * u.y, -a * c};
    const Vec3<T> f{-a * c * u.x, -a * c * u.y, a * sn};
    elbow_acceleration_sum = elbow_acceleration_sum + e[k] * qdd[k] + f * (qd[k] * qd[k]);
  }
  const JointVector<T> jt = transpose_times(J, elbow_acceleration_sum);
  return {jt[0] + e[0].dot(pdd), jt[1] + e[1].dot(pdd), jt[2] + e[2].dot(pdd)};
}

// The basis terms that need the pose's kinematics: J^T pdd, J^T (0, 0,
// gravity) and the coupling.
template <class T>
struct PoseTerms {
  JointVector<T> platform_inertial{}, platform_weight{}, coupling{};
};

template <class T>
KinematicsStatus pose_terms(const BasicGeometry<T>& g, const JointTrig<T>& t,
                            const JointVector<T>& qd, const JointVector<T>& qdd, T gravity_m_s2,
                            PoseTerms<T>& out) {
  PoseKinematics<T> pk;
  const auto status = pose_kinematics(g, t, qd, pk);
  if (status != KinematicsStatus::kOk) return status;
  const Vec3<T> qdd_v{qdd[0], qdd[1], qdd[2]};
  const Mat3<T>& J = pk.vk.jacobian;
  const Vec3<T> pdd = J * qdd_v + pk.vk.jacobian_dot_qdot;
  out.platform_inertial = transpose_times(J, pdd);
  // -g with g = (0, 0, -gravity).
  out.platform_weight = transpose_times(J, Vec3<T>{T(0.0), T(0.0), gravity_m_s2});
  out.coupling = coupling_term(g, qd, qdd, t, J, pdd);
  return KinematicsStatus::kOk;
}

// The basis at sample s from its trigonometry and pose terms; the joints'
// own terms (friction's shape included) computed here.
void complete_basis(const JointState& s, const JointTrig<double>& t, const PoseTerms<double>& pose,
                    double coulomb_smoothing_rad_s, double stribeck_velocity_rad_s,
                    DynamicsBasis& out) {
  out.platform_inertial = pose.platform_inertial;
  out.platform_weight = pose.platform_weight;
  out.coupling = pose.coupling;
  for (unsigned i = 0; i < 3; ++i) {
    out.platform[i] = out.platform_inertial[i] + out.platform_weight[i];
    out.inertia[i] = s.qdd_rad_s2[i];
    out.gravity[i] = -t.cos_q[i];
    out.gravity_sin[i] = t.sin_q[i];
    out.viscous[i] = s.qd_rad_s[i];
    const FrictionShapeTerms shape =
        friction_shape_terms(s.qd_rad_s[i], coulomb_smoothing_rad_s, stribeck_velocity_rad_s);
    out.coulomb[i] = shape.coulomb;
    if (stribeck_velocity_rad_s > 0.0) out.stribeck[i] = shape.stribeck;
  }
}

}  // namespace

FrictionShapeTerms friction_shape_terms(double qd_rad_s, double coulomb_smoothing_rad_s,
                                        double stribeck_velocity_rad_s) {
  FrictionShapeTerms t;
  t.coulomb = std::tanh(qd_rad_s / coulomb_smoothing_rad_s);
  if (stribeck_velocity_rad_s > 0.0) {
    const double v = qd_rad_s / stribeck_velocity_rad_s;
    t.stribeck = std::exp(-v * v) * t.coulomb;
  }
  return t;
}

KinematicsStatus dynamics_basis(const Geometry& g, const JointState& s, double gravity_m_s2,
                                double coulomb_smoothing_rad_s, DynamicsBasis& out,
                                double stribeck_velocity_rad_s) {
  const JointTrig<double> t = trig_of(s.q_rad);
  PoseTerms<double> pose;
  const auto status = pose_terms(g, t, s.qd_rad_s, s.qdd_rad_s2, gravity_m_s2, pose);
  if (status != KinematicsStatus::kOk) return status;
  complete_basis(s, t, pose, coulomb_smoothing_rad_s, stribeck_velocity_rad_s, out);
  return KinematicsStatus::kOk;
}

Joint3 torque_from_basis(const DynamicsBasis& b, const LumpedParameters& p) {
  Joint3 tau{};
  for (unsigned i = 0; i < 3; ++i) {
    tau[i] = p.arm_inertia_kg_m2[i] * b.inertia[i] + p.arm_gravity_moment_Nm[i] * b.gravity[i] +
             p.platform_mass_kg * b.platform[i] +
             p.viscous_friction_Nm_s_per_rad[i] * b.viscous[i] +
             p.coulomb_friction_Nm[i] * b.coulomb[i] + p.torque_offset_Nm[i];
  }
  return tau;
}

Joint3 torque_from_basis(const DynamicsBasis& b, const HighFidelityParameters& p) {
  Joint3 tau{};
  for (unsigned i = 0; i < 3; ++i) {
    tau[i] = p.arm_inertia_kg_m2[i] * b.inertia[i] + p.arm_gravity_cos_Nm[i] * b.gravity[i] +
             p.arm_gravity_sin_Nm[i] * b.gravity_sin[i] +
             p.platform_inertial_mass_kg * b.platform_inertial[i] +
             p.platform_weight_mass_kg * b.platform_weight[i] +
             p.forearm_coupling_kg * b.coupling[i] +
             p.viscous_friction_Nm_s_per_rad[i] * b.viscous[i] +
             p.coulomb_friction_Nm[i] * b.coulomb[i] + p.stribeck_friction_Nm[i] * b.stribeck[i] +
             p.torque_offset_Nm[i];
  }
  return tau;
}

KinematicsStatus inverse_dynamics(const Geometry& g, const LumpedParameters& p, const JointState& s,
                                  Joint3& tau_Nm) {
  DynamicsBasis b;
  const auto status = dynamics_basis(g, s, p.gravity_m_s2, p.coulomb_smoothing_rad_s, b);
  if (status != KinematicsStatus::kOk) return status;
  tau_Nm = torque_from_basis(b, p);
  return KinematicsStatus::kOk;
}

HighFidelityParameters to_high_fidelity(const LumpedParameters& p) {
  HighFidelityParameters h;
  h.arm_inertia_kg_m2 = p.arm_inertia_kg_m2;
  h.arm_gravity_cos_Nm = p.arm_gravity_moment_Nm;
  h.arm_gravity_sin_Nm = {0.0, 0.0, 0.0};
  h.platform_inertial_mass_kg = p.platform_mass_kg;
  h.platform_weight_mass_kg = p.platform_mass_kg;
  h.forearm_coupling_kg = 0.0;
  h.viscous_friction_Nm_s_per_rad = p.viscous_friction_Nm_s_per_rad;
  h.coulomb_friction_Nm = p.coulomb_friction_Nm;
  h.torque_offset_Nm = p.torque_offset_Nm;
  h.coulomb_smoothing_rad_s = p.coulomb_smoothing_rad_s;
  h.gravity_m_s2 = p.gravity_m_s2;
  return h;
}

KinematicsStatus inverse_dynamics(const Geometry& g, const HighFidelityParameters& p,
                                  const JointState& s, Joint3& tau_Nm) {
  DynamicsBasis b;
  const auto status =
      dynamics_basis(g, s, p.gravity_m_s2, p.coulomb_smoothing_rad_s, b, p.stribeck_velocity_rad_s);
  if (status != KinematicsStatus::kOk) return status;
  tau_Nm = torque_from_basis(b, p);
  return KinematicsStatus::kOk;
}

KinematicsStatus forward_dynamics(const Geometry& g, const LumpedParameters& p, const Joint3& q_rad,
                                  const Joint3& qd_rad_s, const Joint3& tau_Nm,
                                  Joint3& qdd_rad_s2) {
  // The torque at qdd = 0 is the bias h(q, qd); the mass matrix is
  // diag(I) + m_p J^T J.
  JointState s{q_rad, qd_rad_s, {}};
  DynamicsBasis b;
  const auto status = dynamics_basis(g, s, p.gravity_m_s2, p.coulomb_smoothing_rad_s, b);
  if (status != KinematicsStatus::kOk) return status;
  const Joint3 bias = torque_from_basis(b, p);
  PoseKinematics<double> pk;
  pose_kinematics(g, trig_of(q_rad), qd_rad_s, pk);
  const Mat3<double>& J = pk.vk.jacobian;
  Mat3<double> M{};
  for (unsigned r = 0; r < 3; ++r) {
    Vec3<double> row{};
    const Vec3<double> col_r{J(0, r), J(1, r), J(2, r)};
    row.x = p.platform_mass_kg * col_r.dot(Vec3<double>{J(0, 0), J(1, 0), J(2, 0)});
    row.y = p.platform_mass_kg * col_r.dot(Vec3<double>{J(0, 1), J(1, 1), J(2, 1)});
    row.z = p.platform_mass_kg * col_r.dot(Vec3<double>{J(0, 2), J(1, 2), J(2, 2)});
    M.row[r] = row;
  }
  M.row[0].x += p.arm_inertia_kg_m2[0];
  M.row[1].y += p.arm_inertia_kg_m2[1];
  M.row[2].z += p.arm_inertia_kg_m2[2];
  const double det = M.determinant();
  if (!(std::abs(det) > 0.0) || !std::isfinite(det)) return KinematicsStatus::kSingular;
  const Vec3<double> rhs{tau_Nm[0] - bias[0], tau_Nm[1] - bias[1], tau_Nm[2] - bias[2]};
  const Vec3<double> qdd = (M.adjugate() * rhs) * (1.0 / det);
  qdd_rad_s2 = {qdd.x, qdd.y, qdd.z};
  return KinematicsStatus::kOk;
}

KinematicsStatus integrate_rk4(const Geometry& g, const LumpedParameters& p, const Joint3& tau_Nm,
                               double dt_s, int substeps, Joint3& q_rad, Joint3& qd_rad_s) {
  const double h = dt_s / substeps;
  const auto add = [](const Joint3& x, const Joint3& y, double s) {
    return Joint3{x[0] + s * y[0], x[1] + s * y[1], x[2] + s * y[2]};
  };
  for (int i = 0; i < substeps; ++i) {
    Joint3 k1v{}, k2v{}, k3v{}, k4v{};
    const Joint3 k1q = qd_rad_s;
    auto st = forward_dynamics(g, p, q_rad, qd_rad_s, tau_Nm, k1v);
    if (st != KinematicsStatus::kOk) return st;
    const Joint3 k2q = add(qd_rad_s, k1v, h / 2);
    st = forward_dynamics(g, p, add(q_rad, k1q, h / 2), k2q, tau_Nm, k2v);
    if (st != KinematicsStatus::kOk) return st;
    const Joint3 k3q = add(qd_rad_s, k2v, h / 2);
    st = forward_dynamics(g, p, add(q_rad, k2q, h / 2), k3q, tau_Nm, k3v);
    if (st != KinematicsStatus::kOk) return st;
    const Joint3 k4q = add(qd_rad_s, k3v, h);
    st = forward_dynamics(g, p, add(q_rad, k3q, h), k4q, tau_Nm, k4v);
    if (st != KinematicsStatus::kOk) return st;
    for (unsigned j = 0; j < 3; ++j) {
      q_rad[j] += h / 6 * (k1q[j] + 2 * k2q[j] + 2 * k3q[j] + k4q[j]);
      qd_rad_s[j] += h / 6 * (k1v[j] + 2 * k2v[j] + 2 * k3v[j] + k4v[j]);
    }
  }
  return KinematicsStatus::kOk;
}

LumpedParameters default_lumped_parameters() {
  LumpedParameters p;
  // Arm: 0.35 kg aluminium tube over 0.2 m (I = m a^2 / 3 = 4.7e-3), elbow
  // share of two forearms 0.05 kg (2e-3), reflected rotor 5e-4 kg m^2.
  p.arm_inertia_kg_m2 = {7.2e-3, 7.2e-3, 7.2e-3};
  // 9.81 * (0.35 * 0.1 + 0.05 * 0.2) = 0.441 N m.
  p.arm_gravity_moment_Nm = {0.441, 0.441, 0.441};
  // Platform 0.25 kg plus the forearms' platform share 0.15 kg.
  p.platform_mass_kg = 0.40;
  p.viscous_friction_Nm_s_per_rad = {0.020, 0.025, 0.018};
  p.coulomb_friction_Nm = {0.060, 0.050, 0.070};
  p.torque_offset_Nm = {0.0, 0.0, 0.0};
  p.coulomb_smoothing_rad_s = 0.01;
  p.gravity_m_s2 = 9.81;
  return p;
}

}  // namespace delta
