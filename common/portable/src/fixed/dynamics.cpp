#include "delta/fixed/dynamics.hpp"

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
template <class R>
R narrowed(i64 v, int shift) {
  return R::from_raw(detail::saturate32(detail::shift_round(v, shift)));
}

Vec3Unit cross(const Vec3Unit& a, const Vec3Unit& b) {
  const auto c = [](Q1_30 p, Q1_30 q, Q1_30 r, Q1_30 s) {
    return narrowed<Q1_30>(i64{p.raw()} * q.raw() - i64{r.raw()} * s.raw(), 30);
  };
  return {c(a[1], b[2], a[2], b[1]), c(a[2], b[0], a[0], b[2]), c(a[0], b[1], a[1], b[0])};
}

// What one pose's kinematics give the dynamics terms: per chain the
// forearm's direction n_k = d_k / b, the elbow's direction of motion
// e_k / a = (-sin q u_k, -cos q z) and its derivative h_k / a =
// (-cos q u_k, sin q z), and the velocity kinematics.
struct PoseQ {
  std::array<Vec3Unit, 3> arm_tangent{};      // e_k / a
  std::array<Vec3Unit, 3> arm_curvature{};    // h_k / a
  std::array<Vec3Unit, 3> forearm{};          // n_k
  std::array<Vec3Unit, 3> inverse_columns{};  // adj(N): column k is n_k+1 x n_k+2
  Q7_24 inverse_determinant{};                // 1 / det N, |.| <= 64
  Q7_24 inverse_forearm_per_m{};              // 1 / b
  VelocityKinematicsQ vk{};
};

void chain_directions(const GeometryQ& g, Q7_24 inverse_b, const std::array<SinCos, 3>& trig,
                      const Vec3Q& p, PoseQ& out) {
  out.inverse_forearm_per_m = inverse_b;
  for (unsigned k = 0; k < 3; ++k) {
    const Q1_30 c = trig[k].cos, s = trig[k].sin;
    const Q1_30 ux = kChainCosQ[k], uy = kChainSinQ[k];
    const Vec3Q elbow = elbow_position(g, static_cast<int>(k), trig[k]);
    const Vec3Q d{p.x_m + mul<Q7_24>(g.platform_radius_m, ux) - elbow.x_m,
                  p.y_m + mul<Q7_24>(g.platform_radius_m, uy) - elbow.y_m, p.z_m - elbow.z_m};
    out.forearm[k] = {mul<Q1_30>(d.x_m, inverse_b), mul<Q1_30>(d.y_m, inverse_b),
                      mul<Q1_30>(d.z_m, inverse_b)};
    out.arm_tangent[k] = {-mul<Q1_30>(s, ux), -mul<Q1_30>(s, uy), -c};
    out.arm_curvature[k] = {-mul<Q1_30>(c, ux), -mul<Q1_30>(c, uy), s};
  }
}

// J = A^-1 diag(d_k . e_k) with A = b N: J_rk = a adj(N)_rk (n_k . e_k / a) / det N.
// J'q' = A^-1 rhs, rhs_k = (d_k . h_k) qd_k^2 - |pd - e_k qd_k|^2.
KinematicsStatus pose_velocity_kinematics(const GeometryQ& g, const std::array<Q10_21, 3>& qd,
                                          PoseQ& pose) {
  const auto& n = pose.forearm;
  for (unsigned k = 0; k < 3; ++k) pose.inverse_columns[k] = cross(n[(k + 1) % 3], n[(k + 2) % 3]);
  const Q1_30 det = narrowed<Q1_30>(dot_raw(n[0], pose.inverse_columns[0]), 30);
  if (abs(det) < kMinForearmDeterminant) return KinematicsStatus::kSingular;
  pose.inverse_determinant = quotient<Q7_24>(Q1_30::from_raw(1 << 30), det);
  const Q7_24 scale_m = mul<Q7_24>(g.upper_arm_length_m, pose.inverse_determinant);
  auto& J = pose.vk.jacobian_m_per_rad;
  for (unsigned k = 0; k < 3; ++k) {
    const Q1_30 transmission = narrowed<Q1_30>(dot_raw(n[k], pose.arm_tangent[k]), 30);
    for (unsigned r = 0; r < 3; ++r) {
      J[r][k] = mul<Q7_24>(mul<Q1_30>(pose.inverse_columns[k][r], transmission), scale_m);
    }
  }
  Vec3Rate pd{};
  for (unsigned r = 0; r < 3; ++r) pd[r] = narrowed<Q10_21>(dot_raw(J[r], qd), 24);
  const Q7_24 ab = mul<Q7_24>(g.upper_arm_length_m, g.forearm_length_m);
  Vec3Rate rhs{};
  for (unsigned k = 0; k < 3; ++k) {
    const Q14_17 qd_sq = mul<Q14_17>(qd[k], qd[k]);
    const Q7_24 d_dot_h = mul<Q7_24>(ab, narrowed<Q1_30>(dot_raw(n[k], pose.arm_curvature[k]), 30));
    Vec3Rate d_rate{};
    for (unsigned r = 0; r < 3; ++r) {
      const Q7_24 e = mul<Q7_24>(g.upper_arm_length_m, pose.arm_tangent[k][r]);
      d_rate[r] = pd[r] - mul<Q10_21>(e, qd[k]);
    }
    rhs[k] = mul<Q10_21>(d_dot_h, qd_sq) - narrowed<Q10_21>(dot_raw(d_rate, d_rate), 21);
  }
  // A^-1 rhs = adj(N) rhs / (b det N).
  const Q7_24 inverse_b = pose.inverse_forearm_per_m;
  for (unsigned r = 0; r < 3; ++r) {
    const std::array<Q1_30, 3> row{pose.inverse_columns[0][r], pose.inverse_columns[1][r],
                                   pose.inverse_columns[2][r]};
    const Q10_21 w = narrowed<Q10_21>(dot_raw(row, rhs), 30);
    pose.vk.jacobian_dot_qdot_m_s2[r] =
        mul<Q10_21>(mul<Q10_21>(w, pose.inverse_determinant), inverse_b);
  }
  pose.vk.status = KinematicsStatus::kOk;
  return KinematicsStatus::kOk;
}

KinematicsStatus pose_of(const GeometryQ& g, Q7_24 inverse_b, const JointAnglesQ& q,
                         const std::array<Q10_21, 3>& qd, const Vec3Q* position,
                         std::array<SinCos, 3>& trig, PoseQ& pose) {
  for (unsigned k = 0; k < 3; ++k) trig[k] = sincos(q[k]);
  Vec3Q p{};
  if (position != nullptr) {
    p = *position;
  } else {
    const ForwardKinematicsQ fk = forward_kinematics(g, trig);
    if (fk.status != KinematicsStatus::kOk) return fk.status;
    p = fk.position;
  }
  chain_directions(g, inverse_b, trig, p, pose);
  return pose_velocity_kinematics(g, qd, pose);
}

// The terms the platform's masses and the rods' coupling multiply, per
// joint, in m^2/s^2/rad: [J^T pdd]_i, [J^T (0, 0, g)]_i and psi_i =
// J_i . sum_k Bdd_k + e_i . pdd with Bdd_k = e_k qdd_k + h_k qd_k^2.
struct PlatformTerms {
  Vec3Rate inertial{}, weight{}, coupling{};
};

PlatformTerms platform_terms(const GeometryQ& g, const ModelParametersQ& m, const JointStateQ& s,
                             const PoseQ& pose) {
  const auto& J = pose.vk.jacobian_m_per_rad;
  Vec3Rate pdd{};
  for (unsigned r = 0; r < 3; ++r) {
    const i64 jqdd = dot_raw(J[r], s.qdd_rad_s2);  // Q.41
    pdd[r] = narrowed<Q10_21>(jqdd + (i64{pose.vk.jacobian_dot_qdot_m_s2[r].raw()} << 20), 20);
  }
  // sum_k Bdd_k / a, in rad/s^2.
  std::array<Q14_17, 3> elbow_sum{};
  for (unsigned r = 0; r < 3; ++r) {
    i64 acc = 0;  // Q.47
    for (unsigned k = 0; k < 3; ++k) {
      acc += i64{pose.arm_tangent[k][r].raw()} * s.qdd_rad_s2[k].raw() +
             i64{pose.arm_curvature[k][r].raw()} * mul<Q14_17>(s.qd_rad_s[k], s.qd_rad_s[k]).raw();
    }
    elbow_sum[r] = narrowed<Q14_17>(acc, 30);
  }
  Vec3Rate elbow_acceleration{};
  for (unsigned r = 0; r < 3; ++r) {
    elbow_acceleration[r] = mul<Q10_21>(elbow_sum[r], g.upper_arm_length_m);
  }
  PlatformTerms t;
  for (unsigned i = 0; i < 3; ++i) {
    const std::array<Q7_24, 3> column{J[0][i], J[1][i], J[2][i]};
    t.inertial[i] = narrowed<Q10_21>(dot_raw(column, pdd), 24);
    t.weight[i] = mul<Q10_21>(m.gravity_m_s2, J[2][i]);
    const std::array<Q7_24, 3> tangent{mul<Q7_24>(g.upper_arm_length_m, pose.arm_tangent[i][0]),
                                       mul<Q7_24>(g.upper_arm_length_m, pose.arm_tangent[i][1]),
                                       mul<Q7_24>(g.upper_arm_length_m, pose.arm_tangent[i][2])};
    t.coupling[i] =
        narrowed<Q10_21>(dot_raw(column, elbow_acceleration) + dot_raw(tangent, pdd), 24);
  }
  return t;
}

// Fv qd + Fc tanh(qd / w) + Fs exp(-(qd / vs)^2) tanh(qd / w).
Q12_19 friction(const ModelQ& model, unsigned j, Q10_21 qd) {
  const ModelParametersQ& m = model.parameters;
  const Q1_30 sign = tanh(mul<Q10_21>(qd, model.inverse_smoothing_s_per_rad));
  Q12_19 f = mul<Q12_19>(m.viscous_friction_Nm_s_per_rad[j], qd) +
             mul<Q12_19>(m.coulomb_friction_Nm[j], sign);
  if (model.inverse_stribeck_s_per_rad.raw() > 0) {
    const Q10_21 v = mul<Q10_21>(qd, model.inverse_stribeck_s_per_rad);
    const Q1_30 decay = exp_neg(mul<Q10_21>(v, v));
    f += mul<Q12_19>(m.stribeck_friction_Nm[j], mul<Q1_30>(decay, sign));
  }
  return f;
}

}  // namespace

VelocityKinematicsQ velocity_kinematics(const GeometryQ& g, const JointAnglesQ& q,
                                        const std::array<Q10_21, 3>& qd, const Vec3Q& p) {
  std::array<SinCos, 3> trig{};
  PoseQ pose;
  const Q7_24 inverse_b = quotient<Q7_24>(Q7_24::from_int(1), g.forearm_length_m);
  const KinematicsStatus status = pose_of(g, inverse_b, q, qd, &p, trig, pose);
  if (status != KinematicsStatus::kOk) return VelocityKinematicsQ{status, {}, {}};
  return pose.vk;
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
  return model;
}

KinematicsStatus model_torque(const ModelQ& model, const JointStateQ& s, Joint3Q12_19& tau_Nm) {
  tau_Nm = {};
  const GeometryQ& g = model.geometry;
  const ModelParametersQ& m = model.parameters;
  std::array<SinCos, 3> trig{};
  PoseQ pose;
  const KinematicsStatus status = pose_of(g, model.inverse_forearm_per_m, s.q_rad, s.qd_rad_s,
                                          s.platform_known ? &s.platform_m : nullptr, trig, pose);
  if (status != KinematicsStatus::kOk) return status;
  const PlatformTerms platform = platform_terms(g, m, s, pose);
  for (unsigned i = 0; i < 3; ++i) {
    tau_Nm[i] = mul<Q12_19>(m.arm_inertia_kg_m2[i], s.qdd_rad_s2[i]) -
                mul<Q12_19>(m.arm_gravity_cos_Nm[i], trig[i].cos) +
                mul<Q12_19>(m.arm_gravity_sin_Nm[i], trig[i].sin) +
                mul<Q12_19>(m.platform_inertial_mass_kg, platform.inertial[i]) +
                mul<Q12_19>(m.platform_weight_mass_kg, platform.weight[i]) +
                mul<Q12_19>(m.forearm_coupling_kg, platform.coupling[i]) +
                friction(model, i, s.qd_rad_s[i]) + m.torque_offset_Nm[i];
  }
  return KinematicsStatus::kOk;
}

}  // namespace delta::fx
