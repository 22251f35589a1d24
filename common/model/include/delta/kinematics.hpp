// Delta kinematics following docs/conventions.md, written once and
// templated on the scalar type T. The math functions (sqrt, sin, cos, atan2,
// abs) are found by argument-dependent lookup, so a scalar type that brings
// its own can reuse this code. No heap, no exceptions.
//
// Chain i: motor axis at M_i = base_radius * u_i, u_i = (cos phi_i, sin phi_i, 0).
// Elbow:   B_i = M_i + a (cos theta_i u_i - sin theta_i z)   (theta > 0: down)
// Platform joint: P_i = p + r u_i.   Constraint: |P_i - B_i| = b.
#pragma once

#include <array>
#include <cmath>
#include <numbers>

#include "delta/geometry.hpp"
#include "delta/kinematics_status.hpp"
#include "delta/vec3.hpp"

namespace delta {

template <class T>
using JointVector = std::array<T, 3>;

template <class T>
struct InverseKinematicsResult {
  KinematicsStatus status{KinematicsStatus::kUnreachable};
  int failed_chain{-1};  // 0-based chain that could not be solved, -1 if none
  JointVector<T> theta_rad{};
};

template <class T>
struct ForwardKinematicsResult {
  KinematicsStatus status{KinematicsStatus::kUnreachable};
  Vec3<T> position_m{};
};

// Velocity kinematics at one pose: pdot = J qdot and pddot = J qddot + Jdot qdot.
template <class T>
struct VelocityKinematics {
  KinematicsStatus status{KinematicsStatus::kSingular};
  Mat3<T> jacobian{};           // m/rad
  Vec3<T> jacobian_dot_qdot{};  // m/s^2
};

namespace detail {

template <class T>
constexpr Vec3<T> unit_radial(int chain) {
  return {T(kChainCos[static_cast<unsigned>(chain)]), T(kChainSin[static_cast<unsigned>(chain)]),
          T(0)};
}

template <class T>
constexpr T pi() {
  return T(std::numbers::pi);
}

}  // namespace detail

// Elbow position of chain i at a joint angle given by its cosine and sine.
template <class T>
Vec3<T> elbow_position(const BasicGeometry<T>& g, int chain, T cos_theta, T sin_theta) {
  const Vec3<T> u = detail::unit_radial<T>(chain);
  const T radial = g.base_radius_m + g.upper_arm_length_m * cos_theta;
  return {radial * u.x, radial * u.y, -g.upper_arm_length_m * sin_theta};
}

// Elbow position of chain i at joint angle theta.
template <class T>
Vec3<T> elbow_position(const BasicGeometry<T>& g, int chain, T theta_rad) {
  using std::cos;
  using std::sin;
  return elbow_position(g, chain, T(cos(theta_rad)), T(sin(theta_rad)));
}

// Joint angle of one chain for platform position p, on the working branch
// (elbow farther from the base's z axis).
template <class T>
KinematicsStatus inverse_kinematics_chain(const BasicGeometry<T>& g, int chain, const Vec3<T>& p,
                                          T& theta_rad) {
  using std::atan2;
  using std::sqrt;
  const T a = g.upper_arm_length_m;
  const T b = g.forearm_length_m;
  const Vec3<T> u = detail::unit_radial<T>(chain);
  // Platform joint relative to the motor axis, in the chain's frame:
  // radial X, tangential Y, vertical Z.
  const T X = p.x * u.x + p.y * u.y + g.platform_radius_m - g.base_radius_m;
  const T Y = -p.x * u.y + p.y * u.x;
  const T Z = p.z;
  // |P - B|^2 = b^2  <=>  E cos(theta) + F sin(theta) + G = 0.
  const T E = T(-2) * a * X;
  const T F = T(2) * a * Z;
  const T G = X * X + Y * Y + Z * Z + a * a - b * b;
  const T rho_sq = E * E + F * F;
  if (!(rho_sq > G * G)) return KinematicsStatus::kUnreachable;  // also catches NaN
  const T rho = sqrt(rho_sq);
  const T c = -G / rho;  // cos(theta - alpha), in (-1, 1)
  const T alpha = atan2(F, E);
  const T delta = atan2(sqrt(T(1) - c * c), c);  // acos(c), in [0, pi]
  // Of alpha +/- delta, the larger cos(theta) puts the elbow farther out:
  // cos(alpha + delta) - cos(alpha - delta) = -2 sin(alpha) sin(delta).
  T theta = (F > T(0)) ? alpha - delta : alpha + delta;
  if (theta > detail::pi<T>()) theta = theta - T(2) * detail::pi<T>();
  if (theta <= -detail::pi<T>()) theta = theta + T(2) * detail::pi<T>();
  theta_rad = theta;
  return KinematicsStatus::kOk;
}

template <class T>
InverseKinematicsResult<T> inverse_kinematics(const BasicGeometry<T>& g, const Vec3<T>& p) {
  InverseKinematicsResult<T> r;
  for (int i = 0; i < 3; ++i) {
    if (inverse_kinematics_chain(g, i, p, r.theta_rad[static_cast<unsigned>(i)]) !=
        KinematicsStatus::kOk) {
      r.status = KinematicsStatus::kUnreachable;
      r.failed_chain = i;
      r.theta_rad = {};
      return r;
    }
  }
  r.status = KinematicsStatus::kOk;
  return r;
}

// Platform position for joint angles q: the intersection of three spheres of
// radius b centred at C_i = B_i - r u_i, taking the solution below (lower z).
// The same from the joint angles' cosines and sines (a caller that has
// them already need not compute them again).
template <class T>
ForwardKinematicsResult<T> forward_kinematics(const BasicGeometry<T>& g,
                                              const JointVector<T>& cos_q,
                                              const JointVector<T>& sin_q) {
  using std::sqrt;
  ForwardKinematicsResult<T> r;
  std::array<Vec3<T>, 3> c{};
  for (int i = 0; i < 3; ++i) {
    const auto k = static_cast<unsigned>(i);
    c[k] =
        elbow_position(g, i, cos_q[k], sin_q[k]) - detail::unit_radial<T>(i) * g.platform_radius_m;
  }
  const Vec3<T> d21 = c[1] - c[0];
  const Vec3<T> d31 = c[2] - c[0];
  const T d = sqrt(d21.squared_norm());
  if (!(d > T(0))) {
    r.status = KinematicsStatus::kSingular;
    return r;
  }
  const Vec3<T> ex = d21 * (T(1) / d);
  const T i = ex.dot(d31);
  const Vec3<T> ey_raw = d31 - ex * i;
  const T j = sqrt(ey_raw.squared_norm());
  if (!(j > T(1e-12) * (d + T(1)))) {
    r.status = KinematicsStatus::kSingular;
    return r;
  }
  const Vec3<T> ey = ey_raw * (T(1) / j);
  Vec3<T> ez = ex.cross(ey);
  // Equal radii: x = d/2, y = (i^2 + j^2 - 2 i x) / (2 j).
  const T x = d / T(2);
  const T y = (i * i + j * j - T(2) * i * x) / (T(2) * j);
  const T b = g.forearm_length_m;
  const T z_sq = b * b - x * x - y * y;
  if (!(z_sq >= T(0))) {
    r.status = KinematicsStatus::kUnreachable;
    return r;
  }
  if (ez.z > T(0)) ez = -ez;  // the solution below
  r.position_m = c[0] + ex * x + ey * y + ez * sqrt(z_sq);
  r.status = KinematicsStatus::kOk;
  return r;
}

template <class T>
ForwardKinematicsResult<T> forward_kinematics(const BasicGeometry<T>& g, const JointVector<T>& q) {
  using std::cos;
  using std::sin;
  return forward_kinematics(g, JointVector<T>{T(cos(q[0])), T(cos(q[1])), T(cos(q[2]))},
                            JointVector<T>{T(sin(q[0])), T(sin(q[1])), T(sin(q[2]))});
}

// Jacobian and Jdot*qdot at (q, p), where p = FK(q).
//   Forearm d_i = P_i - B_i, arm tangent e_i = dB_i/dtheta_i.
//   Rigid forearm: d_i . pdot = (d_i . e_i) qdot_i  =>  J = A^-1 diag(d_i . e_i),
//   with A the matrix of rows d_i^T. Differentiating once more:
//   d_i . pddot = (d_i . e_i) qddot_i + (d_i . h_i) qdot_i^2 - |ddot_i|^2,
//   h_i = de_i/dtheta_i, ddot_i = pdot - e_i qdot_i.
// cos_q, sin_q: the joint angles' cosines and sines.
template <class T>
VelocityKinematics<T> velocity_kinematics(const BasicGeometry<T>& g, const JointVector<T>& cos_q,
                                          const JointVector<T>& sin_q, const JointVector<T>& qdot,
                                          const Vec3<T>& p) {
  using std::abs;
  VelocityKinematics<T> r;
  Mat3<T> A{};
  std::array<Vec3<T>, 3> e{};
  std::array<Vec3<T>, 3> h{};
  std::array<T, 3> de{};
  const T a = g.upper_arm_length_m;
  for (int i = 0; i < 3; ++i) {
    const auto k = static_cast<unsigned>(i);
    const Vec3<T> u = detail::unit_radial<T>(i);
    const T s = sin_q[k];
    const T co = cos_q[k];
    const Vec3<T> elbow = elbow_position(g, i, co, s);
    A.row[k] = p + u * g.platform_radius_m - elbow;
    e[k] = Vec3<T>{-a * s * u.x, -a * s * u.y, -a * co};
    h[k] = Vec3<T>{-a * co * u.x, -a * co * u.y, a * s};
    de[k] = A.row[k].dot(e[k]);
  }
  const T det = A.determinant();
  const T b = g.forearm_length_m;
  if (!(abs(det) > T(1e-9) * b * b * b)) return r;  // parallel singularity
  const Mat3<T> adj = A.adjugate();
  const T inv_det = T(1) / det;
  for (unsigned rr = 0; rr < 3; ++rr) {
    r.jacobian.row[rr] = Vec3<T>{adj(rr, 0) * de[0] * inv_det, adj(rr, 1) * de[1] * inv_det,
                                 adj(rr, 2) * de[2] * inv_det};
  }
  const Vec3<T> pdot = r.jacobian * Vec3<T>{qdot[0], qdot[1], qdot[2]};
  Vec3<T> rhs{};
  std::array<T, 3> rhs_arr{};
  for (unsigned k = 0; k < 3; ++k) {
    const Vec3<T> ddot = pdot - e[k] * qdot[k];
    rhs_arr[k] = A.row[k].dot(h[k]) * qdot[k] * qdot[k] - ddot.squared_norm();
  }
  rhs = Vec3<T>{rhs_arr[0], rhs_arr[1], rhs_arr[2]};
  r.jacobian_dot_qdot = (adj * rhs) * inv_det;
  r.status = KinematicsStatus::kOk;
  return r;
}

template <class T>
VelocityKinematics<T> velocity_kinematics(const BasicGeometry<T>& g, const JointVector<T>& q,
                                          const JointVector<T>& qdot, const Vec3<T>& p) {
  using std::cos;
  using std::sin;
  return velocity_kinematics(g, JointVector<T>{T(cos(q[0])), T(cos(q[1])), T(cos(q[2]))},
                             JointVector<T>{T(sin(q[0])), T(sin(q[1])), T(sin(q[2]))}, qdot, p);
}

// Where a target lies with respect to the usable workspace.
enum class WorkspaceStatus : int {
  kInside = 0,
  kUnreachable = 1,   // inverse kinematics has no solution
  kJointLimit = 2,    // a joint angle lies outside [min, max]
  kNearSingular = 3,  // too close to a serial or parallel singularity
};

template <class T>
struct WorkspaceLimits {
  T joint_min_rad{T(-1.2)};  // about -69 degrees
  T joint_max_rad{T(1.4)};   // about  80 degrees
  // Smallest |cos| of the angle between the forearm and the elbow's direction
  // of motion (serial singularity: forearm in line with the arm), and
  // smallest |det A| / b^3 (parallel singularity).
  T min_transmission{T(0.05)};
};

template <class T>
struct WorkspaceCheck {
  WorkspaceStatus status{WorkspaceStatus::kUnreachable};
  int chain{-1};  // the offending chain, -1 if none or not chain-specific
  JointVector<T> theta_rad{};
};

template <class T>
WorkspaceCheck<T> check_workspace(const BasicGeometry<T>& g, const Vec3<T>& p,
                                  const WorkspaceLimits<T>& limits) {
  using std::abs;
  using std::sqrt;
  WorkspaceCheck<T> w;
  const auto ik = inverse_kinematics(g, p);
  if (ik.status != KinematicsStatus::kOk) {
    w.chain = ik.failed_chain;
    return w;
  }
  w.theta_rad = ik.theta_rad;
  for (unsigned k = 0; k < 3; ++k) {
    if (ik.theta_rad[k] < limits.joint_min_rad || ik.theta_rad[k] > limits.joint_max_rad) {
      w.status = WorkspaceStatus::kJointLimit;
      w.chain = static_cast<int>(k);
      return w;
    }
  }
  const T a = g.upper_arm_length_m;
  const T b = g.forearm_length_m;
  Mat3<T> A{};
  for (int i = 0; i < 3; ++i) {
    const auto k = static_cast<unsigned>(i);
    const Vec3<T> u = detail::unit_radial<T>(i);
    A.row[k] = p + u * g.platform_radius_m - elbow_position(g, i, ik.theta_rad[k]);
    using std::cos;
    using std::sin;
    const Vec3<T> e{-a * sin(ik.theta_rad[k]) * u.x, -a * sin(ik.theta_rad[k]) * u.y,
                    -a * cos(ik.theta_rad[k])};
    // |d . e| / (|d| |e|) = |cos| of the angle between forearm and arm tangent.
    if (abs(A.row[k].dot(e)) < limits.min_transmission * a * b) {
      w.status = WorkspaceStatus::kNearSingular;
      w.chain = i;
      return w;
    }
  }
  if (abs(A.determinant()) < limits.min_transmission * b * b * b) {
    w.status = WorkspaceStatus::kNearSingular;
    return w;
  }
  w.status = WorkspaceStatus::kInside;
  return w;
}

}  // namespace delta
