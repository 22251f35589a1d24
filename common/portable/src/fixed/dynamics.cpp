#include "delta/fixed/dynamics.hpp"

#include <type_traits>

#include "delta/fixed/math.hpp"

namespace delta::fx {

namespace {

using i64 = std::int64_t;
using Vec3Unit = std::array<Q1_30, 3>;  // a direction: components in [-1, 1]
using Vec3Rate = std::array<Q10_21, 3>;

// sum a_k b_k of raw values, rounded to a value `shift` bits narrower.
template <class A, class B>
i64 dot_raw(const std::array<A, 3>& a, const std::array<B, 3>& b) {
  return i64{a[0].raw()} * b[0].raw() + i64{a[1].raw()} * b[1].raw() + i64{a[2].raw()} * b[2].raw();
}
template <class R, int Shift>
R narrowed(i64 v) {
  return R::from_raw(narrow<Shift>(v));
}

Vec3Unit cross(const Vec3Unit& a, const Vec3Unit& b) {
  const auto c = [](Q1_30 p, Q1_30 q, Q1_30 r, Q1_30 s) {
    return narrowed<Q1_30, 30>(i64{p.raw()} * q.raw() - i64{r.raw()} * s.raw());
  };
  return {c(a[1], b[2], a[2], b[1]), c(a[2], b[0], a[0], b[2]), c(a[0], b[1], a[1], b[0])};
}

// Chain k's elbow moves along e_k = (-sin q u_k, -cos q) per radian of its
// arm (over the arm's length a), and e_k turns along h_k = (-cos q u_k,
// sin q): the elbow's acceleration is a (e_k qdd_k + h_k qd_k^2).
Vec3Unit arm_tangent(unsigned k, const SinCos& t) {
  return {-mul<Q1_30>(t.sin, kChainCosQ[k]), -mul<Q1_30>(t.sin, kChainSinQ[k]), -t.cos};
}
Vec3Unit arm_curvature(unsigned k, const SinCos& t) {
  return {-mul<Q1_30>(t.cos, kChainCosQ[k]), -mul<Q1_30>(t.cos, kChainSinQ[k]), t.sin};
}

// e_k . v for a vector v of any format, in v's format: -(sin q (u_k . v_xy)
// + cos q v_z), with one rounding.
template <class V>
V along_arm(unsigned k, const SinCos& t, const std::array<V, 3>& v) {
  const V radial = narrowed<V, 30>(i64{kChainCosQ[k].raw()} * v[0].raw() +
                                   i64{kChainSinQ[k].raw()} * v[1].raw());
  return narrowed<V, 30>(-(i64{t.sin.raw()} * radial.raw() + i64{t.cos.raw()} * v[2].raw()));
}

// What one pose gives the dynamics: per chain the forearm's direction n_k
// = d_k / b and its transmission t_k = n_k . e_k; the adjugate of N (the
// matrix of rows n_k), whose column k is n_k+1 x n_k+2, and 1 / det N.
// With them J = a adj(N) diag(t) / det N, and J^T F = a t_k (adj(N)^T
// F)_k / det N: the constraint forces (lambda) at this very pose.
struct PoseQ {
  std::array<SinCos, 3> trig{};
  std::array<Vec3Unit, 3> forearm{};
  std::array<Vec3Unit, 3> adjugate_columns{};
  std::array<Q1_30, 3> transmission{};
  Q7_24 inverse_determinant{};              // |.| <= 64
  std::array<Q7_24, 3> jacobian_scale_m{};  // a t_k / det N: J's column k is it times adj column k
};

KinematicsStatus pose_of(const GeometryQ& g, Q7_24 inverse_b, const JointAnglesQ& q,
                         const Vec3Q* position, PoseQ& pose) {
  for (unsigned k = 0; k < 3; ++k) pose.trig[k] = sincos(q[k]);
  Vec3Q p{};
  if (position != nullptr) {
    p = *position;
  } else {
    const ForwardKinematicsQ fk = forward_kinematics(g, pose.trig);
    if (fk.status != KinematicsStatus::kOk) return fk.status;
    p = fk.position;
  }
  auto& n = pose.forearm;
  for (unsigned k = 0; k < 3; ++k) {
    const Vec3Q elbow = elbow_position(g, static_cast<int>(k), pose.trig[k]);
    const Vec3Q d{p.x_m + mul<Q7_24>(g.platform_radius_m, kChainCosQ[k]) - elbow.x_m,
                  p.y_m + mul<Q7_24>(g.platform_radius_m, kChainSinQ[k]) - elbow.y_m,
                  p.z_m - elbow.z_m};
    n[k] = {mul<Q1_30>(d.x_m, inverse_b), mul<Q1_30>(d.y_m, inverse_b),
            mul<Q1_30>(d.z_m, inverse_b)};
  }
  for (unsigned k = 0; k < 3; ++k) {
    pose.adjugate_columns[k] = cross(n[(k + 1) % 3], n[(k + 2) % 3]);
  }
  const Q1_30 det = narrowed<Q1_30, 30>(dot_raw(n[0], pose.adjugate_columns[0]));
  if (abs(det) < kMinForearmDeterminant) return KinematicsStatus::kSingular;
  pose.inverse_determinant = quotient<Q7_24>(Q1_30::from_raw(1 << 30), det);
  const Q7_24 scale_m = mul<Q7_24>(g.upper_arm_length_m, pose.inverse_determinant);
  for (unsigned k = 0; k < 3; ++k) {
    pose.transmission[k] = narrowed<Q1_30, 30>(dot_raw(n[k], arm_tangent(k, pose.trig[k])));
    pose.jacobian_scale_m[k] = mul<Q7_24>(scale_m, pose.transmission[k]);
  }
  return KinematicsStatus::kOk;
}

// J, pd = J qd and J'q' = A^-1 rhs with A = b N, rhs_k = (d_k . h_k) qd_k^2
// - |pd - e_k qd_k|^2.
VelocityKinematicsQ pose_velocity_kinematics(const GeometryQ& g, Q7_24 inverse_b,
                                             const std::array<Q10_21, 3>& qd, const PoseQ& pose) {
  VelocityKinematicsQ vk;
  auto& J = vk.jacobian_m_per_rad;
  for (unsigned k = 0; k < 3; ++k) {
    for (unsigned r = 0; r < 3; ++r) {
      J[r][k] = mul<Q7_24>(pose.jacobian_scale_m[k], pose.adjugate_columns[k][r]);
    }
  }
  Vec3Rate pd{};
  for (unsigned r = 0; r < 3; ++r) pd[r] = narrowed<Q10_21, 24>(dot_raw(J[r], qd));
  const Q7_24 ab = mul<Q7_24>(g.upper_arm_length_m, g.forearm_length_m);
  Vec3Rate rhs{};
  for (unsigned k = 0; k < 3; ++k) {
    const Q14_17 qd_sq = mul<Q14_17>(qd[k], qd[k]);
    const Vec3Unit h = arm_curvature(k, pose.trig[k]);
    const Vec3Unit e = arm_tangent(k, pose.trig[k]);
    const Q7_24 d_dot_h = mul<Q7_24>(ab, narrowed<Q1_30, 30>(dot_raw(pose.forearm[k], h)));
    Vec3Rate d_rate{};
    for (unsigned r = 0; r < 3; ++r) {
      d_rate[r] = pd[r] - mul<Q10_21>(mul<Q7_24>(g.upper_arm_length_m, e[r]), qd[k]);
    }
    rhs[k] = mul<Q10_21>(d_dot_h, qd_sq) - narrowed<Q10_21, 21>(dot_raw(d_rate, d_rate));
  }
  // A^-1 rhs = adj(N) rhs / (b det N).
  for (unsigned r = 0; r < 3; ++r) {
    const std::array<Q1_30, 3> row{pose.adjugate_columns[0][r], pose.adjugate_columns[1][r],
                                   pose.adjugate_columns[2][r]};
    const Q10_21 w = narrowed<Q10_21, 30>(dot_raw(row, rhs));
    vk.jacobian_dot_qdot_m_s2[r] = mul<Q10_21>(mul<Q10_21>(w, pose.inverse_determinant), inverse_b);
  }
  vk.status = KinematicsStatus::kOk;
  return vk;
}

// The platform's acceleration pdd = J qdd + J'q' of a joint-space state.
Vec3Rate platform_acceleration(const GeometryQ& g, Q7_24 inverse_b, const JointStateQ& s,
                               const PoseQ& pose) {
  const VelocityKinematicsQ vk = pose_velocity_kinematics(g, inverse_b, s.qd_rad_s, pose);
  Vec3Rate pdd{};
  for (unsigned r = 0; r < 3; ++r) {
    const i64 jqdd = dot_raw(vk.jacobian_m_per_rad[r], s.qdd_rad_s2);  // Q.41
    pdd[r] = narrowed<Q10_21, 20>(jqdd + (i64{vk.jacobian_dot_qdot_m_s2[r].raw()} << 20));
  }
  return pdd;
}

// The platform's and the rods' torques: J^T F + m_c a e_i . pdd with the
// force F = m_in pdd + m_c a sum_k (e_k qdd_k + h_k qd_k^2) + m_w (0, 0, g).
Joint3Q12_19 platform_torque(const ModelQ& model, const JointStateQ& s, const PoseQ& pose,
                             const Vec3Rate& pdd) {
  // sum_k (e_k qdd_k + h_k qd_k^2) in rad/s^2: with alpha_k = sin qdd + cos
  // qd^2 and beta_k = sin qd^2 - cos qdd, it is (-sum alpha u_x, -sum
  // alpha u_y, sum beta).
  i64 sx = 0, sy = 0, sz = 0;  // Q.47
  for (unsigned k = 0; k < 3; ++k) {
    const SinCos& t = pose.trig[k];
    const Q14_17 qd_sq = mul<Q14_17>(s.qd_rad_s[k], s.qd_rad_s[k]);
    const Q14_17 alpha = narrowed<Q14_17, 30>(i64{t.sin.raw()} * s.qdd_rad_s2[k].raw() +
                                              i64{t.cos.raw()} * qd_sq.raw());
    sx -= i64{alpha.raw()} * kChainCosQ[k].raw();
    sy -= i64{alpha.raw()} * kChainSinQ[k].raw();
    sz += i64{t.sin.raw()} * qd_sq.raw() - i64{t.cos.raw()} * s.qdd_rad_s2[k].raw();
  }
  const std::array<Q14_17, 3> elbows{narrowed<Q14_17, 30>(sx), narrowed<Q14_17, 30>(sy),
                                     narrowed<Q14_17, 30>(sz)};
  // F in N: m_in pdd (Q7.24 x Q10.21 = Q.45) + m_c a S (Q7.24 x Q14.17 = Q.41).
  std::array<Q12_19, 3> force{};
  for (unsigned r = 0; r < 3; ++r) {
    const i64 f = i64{model.parameters.platform_inertial_mass_kg.raw()} * pdd[r].raw() +
                  (i64{model.coupling_moment_kg_m.raw()} * elbows[r].raw() << 4);
    force[r] = narrowed<Q12_19, 26>(f);
  }
  force[2] += model.platform_weight_N;
  Joint3Q12_19 tau{};
  for (unsigned i = 0; i < 3; ++i) {
    const Q12_19 lambda = narrowed<Q12_19, 30>(dot_raw(pose.adjugate_columns[i], force));
    tau[i] = mul<Q12_19>(pose.jacobian_scale_m[i], lambda) +
             mul<Q12_19>(model.coupling_moment_kg_m, along_arm(i, pose.trig[i], pdd));
  }
  return tau;
}

// Joint j's terms in cos q, sin q and the smoothed sign of qd, rounded
// once: -Gc cos q + Gs sin q + (Fc + Fs exp(-(qd / vs)^2)) tanh(qd / w);
// tanh(qd / w) into `sign` (the drive train's load friction takes it too).
Q12_19 gravity_and_coulomb(const ModelQ& model, unsigned j, const SinCos& t, Q10_21 qd,
                           Q1_30& sign) {
  const ModelParametersQ& m = model.parameters;
  sign = tanh(mul<Q10_21>(qd, model.inverse_smoothing_s_per_rad));
  Q12_19 coulomb = m.coulomb_friction_Nm[j];
  if (model.inverse_stribeck_s_per_rad.raw() > 0) {
    const Q10_21 v = mul<Q10_21>(qd, model.inverse_stribeck_s_per_rad);
    coulomb += mul<Q12_19>(m.stribeck_friction_Nm[j], exp_neg(mul<Q10_21>(v, v)));
  }
  // Three products of a 32-bit value and a Q1.30 one of at most 1 in
  // magnitude (2^30), each at most 2^61: their sum fits 64 bits.
  static_assert(std::is_same_v<decltype(SinCos::sin), Q1_30> &&
                    std::is_same_v<std::remove_reference_t<decltype(sign)>, Q1_30>,
                "the sum of three products needs unit factors to stay within 64 bits");
  const i64 sum = i64{m.arm_gravity_sin_Nm[j].raw()} * t.sin.raw() -
                  i64{m.arm_gravity_cos_Nm[j].raw()} * t.cos.raw() +
                  i64{coulomb.raw()} * sign.raw();
  return narrowed<Q12_19, 30>(sum);
}

// The drive's torque for the model's y at joint j: y / (1 - gap - mu
// tanh(qd / w) sign y), as host_id fit's model solves it (shape: tanh(qd /
// w)); y exactly without either term.
Q12_19 drive_torque(const ModelQ& model, unsigned j, Q12_19 y, Q1_30 shape) {
  const ModelParametersQ& m = model.parameters;
  if (m.torque_gain_gap[j].raw() == 0 && m.load_friction[j].raw() == 0) return y;
  i64 gain = (i64{1} << 30) - m.torque_gain_gap[j].raw();
  if (m.load_friction[j].raw() != 0) {
    const i64 loss = shift_round(i64{m.load_friction[j].raw()} * shape.raw(), 30);
    gain -= y.raw() < 0 ? -loss : loss;
  }
  if (gain < kSmallestDriveGain.raw()) gain = kSmallestDriveGain.raw();
  if (gain > Q1_30::max().raw()) gain = Q1_30::max().raw();
  return quotient<Q12_19>(y, Q1_30::from_raw(static_cast<std::int32_t>(gain)));
}

}  // namespace

VelocityKinematicsQ velocity_kinematics(const GeometryQ& g, const JointAnglesQ& q,
                                        const std::array<Q10_21, 3>& qd, const Vec3Q& p) {
  PoseQ pose;
  const Q7_24 inverse_b = quotient<Q7_24>(Q7_24::from_int(1), g.forearm_length_m);
  const KinematicsStatus status = pose_of(g, inverse_b, q, &p, pose);
  if (status != KinematicsStatus::kOk) return VelocityKinematicsQ{status, {}, {}};
  return pose_velocity_kinematics(g, inverse_b, qd, pose);
}

ModelQ prepare_model(const GeometryQ& g, const ModelParametersQ& m) {
  ModelQ model;
  model.geometry = g;
  model.parameters = m;
  model.inverse_forearm_per_m = quotient<Q7_24>(Q7_24::from_int(1), g.forearm_length_m);
  model.inverse_smoothing_s_per_rad =
      quotient<Q10_21>(Q10_21::from_int(1), m.coulomb_smoothing_rad_s);
  if (m.stribeck_velocity_rad_s.raw() > 0) {
    model.inverse_stribeck_s_per_rad =
        quotient<Q10_21>(Q10_21::from_int(1), m.stribeck_velocity_rad_s);
  }
  model.coupling_moment_kg_m = mul<Q7_24>(m.forearm_coupling_kg, g.upper_arm_length_m);
  model.platform_weight_N = mul<Q12_19>(m.platform_weight_mass_kg, m.gravity_m_s2);
  return model;
}

KinematicsStatus model_torque(const ModelQ& model, const JointStateQ& s, Joint3Q12_19& tau_Nm) {
  tau_Nm = {};
  const GeometryQ& g = model.geometry;
  const ModelParametersQ& m = model.parameters;
  PoseQ pose;
  const KinematicsStatus status = pose_of(g, model.inverse_forearm_per_m, s.q_rad,
                                          s.platform_known ? &s.platform_m : nullptr, pose);
  if (status != KinematicsStatus::kOk) return status;
  const Vec3Rate pdd = s.platform_known
                           ? s.platform_acceleration_m_s2
                           : platform_acceleration(g, model.inverse_forearm_per_m, s, pose);
  const Joint3Q12_19 platform = platform_torque(model, s, pose, pdd);
  for (unsigned i = 0; i < 3; ++i) {
    Q1_30 shape{};
    const Q12_19 y = mul<Q12_19>(m.arm_inertia_kg_m2[i], s.qdd_rad_s2[i]) +
                     mul<Q12_19>(m.viscous_friction_Nm_s_per_rad[i], s.qd_rad_s[i]) +
                     gravity_and_coulomb(model, i, pose.trig[i], s.qd_rad_s[i], shape) +
                     platform[i] + m.torque_offset_Nm[i];
    tau_Nm[i] = drive_torque(model, i, y, shape);
  }
  return KinematicsStatus::kOk;
}

}  // namespace delta::fx
