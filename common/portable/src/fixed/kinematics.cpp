#include "delta/fixed/kinematics.hpp"

#include "delta/fixed/math.hpp"

namespace delta::fx {

namespace {

constexpr const Q1_30 (&kCos)[3] = kChainCosQ;
constexpr const Q1_30 (&kSin)[3] = kChainSinQ;

using i64 = std::int64_t;

// Products of two Q7.24 lengths, exact in Q.48.
constexpr i64 prod48(Q7_24 a, Q7_24 b) {
  return i64{a.raw()} * b.raw();
}

// Shifts a, b, c right together until all magnitudes are below 2^30, so
// that squares and their sums fit in 64 bits. Ratios are unchanged to
// within a unit in 2^29 (the shifts round down: the discarded bits are
// below the precision that is kept).
void normalise(i64& a, i64& b, i64& c) {
  const auto mag = [](i64 v) { return static_cast<std::uint64_t>(v < 0 ? -v : v); };
  const std::uint64_t m = mag(a) | mag(b) | mag(c);
  // The shift that brings the top set bit below bit 30 (one clz, no loop).
  const int shift = m == 0 ? 0 : 34 - __builtin_clzll(m);
  if (shift > 0) {
    a >>= shift;
    b >>= shift;
    c >>= shift;
  }
}

Q7_24 length(i64 squared_q48) {
  return Q7_24::from_raw(
      static_cast<std::int32_t>(isqrt_round(static_cast<std::uint64_t>(squared_q48))));
}

}  // namespace

Vec3Q elbow_position(const GeometryQ& g, int chain, Q3_28 theta_rad) {
  return elbow_position(g, chain, sincos(theta_rad));
}

Vec3Q elbow_position(const GeometryQ& g, int chain, const SinCos& sc) {
  const auto k = static_cast<unsigned>(chain);
  const Q7_24 radial = g.base_radius_m + mul<Q7_24>(g.upper_arm_length_m, sc.cos);
  return {mul<Q7_24>(radial, kCos[k]), mul<Q7_24>(radial, kSin[k]),
          -mul<Q7_24>(g.upper_arm_length_m, sc.sin)};
}

InverseKinematicsQ inverse_kinematics(const GeometryQ& g, const Vec3Q& p) {
  InverseKinematicsQ r;
  const Q7_24 a = g.upper_arm_length_m;
  const Q7_24 b = g.forearm_length_m;
  // The platform joint in each chain's frame: radial X, tangential Y, Z.
  // X_k = x cos_k + y sin_k + r_p - r_b and Y_k = y cos_k - x sin_k, with
  // cos 1, -1/2, -1/2 and sin 0, s, -s: four products serve all three
  // chains. They are the same values as the twelve products written out: a
  // product with 1 is exact, and -(y s) rounds like y (-s) unless y s is a
  // tie, which needs |y| >= 2^29 LSB = 32 m since s's raw value is odd.
  const Q1_30 half_neg = kCos[1], s = kSin[1];
  const Q7_24 hx = mul<Q7_24>(p.x_m, half_neg), hy = mul<Q7_24>(p.y_m, half_neg);
  const Q7_24 sx = mul<Q7_24>(p.x_m, s), sy = mul<Q7_24>(p.y_m, s);
  const Q7_24 offset_r = g.platform_radius_m;
  const Q7_24 Xs[3] = {p.x_m + Q7_24::zero() + offset_r - g.base_radius_m,
                       hx + sy + offset_r - g.base_radius_m,
                       hx + (-sy) + offset_r - g.base_radius_m};
  const Q7_24 Ys[3] = {p.y_m - Q7_24::zero(), hy - sx, hy - (-sx)};
  for (unsigned k = 0; k < 3; ++k) {
    const Q7_24 X = Xs[k];
    const Q7_24 Y = Ys[k];
    const Q7_24 Z = p.z_m;
    // E cos(theta) + F sin(theta) + G = 0, all exact in Q.48.
    i64 E = -2 * prod48(a, X);
    i64 F = 2 * prod48(a, Z);
    i64 G = prod48(X, X) + prod48(Y, Y) + prod48(Z, Z) + prod48(a, a) - prod48(b, b);
    normalise(E, F, G);
    // Below 2^30 now: 32 x 32 -> 64 products.
    const auto e = static_cast<std::int32_t>(E), f = static_cast<std::int32_t>(F),
               gg = static_cast<std::int32_t>(G);
    const i64 disc = i64{e} * e + i64{f} * f - i64{gg} * gg;  // rho^2 - G^2
    if (disc <= 0) {
      r.status = KinematicsStatus::kUnreachable;
      r.failed_chain = static_cast<int>(k);
      r.theta_rad = {};
      return r;
    }
    const auto root = static_cast<std::int32_t>(isqrt_round(static_cast<std::uint64_t>(disc)));
    // theta = alpha +/- delta with cos(alpha) = E/rho, sin(alpha) = F/rho,
    // cos(delta) = -G/rho, sin(delta) = root/rho: one atan2 of the angle-sum
    // products (the common factor rho^2 cancels). Of the two, the larger
    // cos(theta) puts the elbow farther out: alpha - delta when F > 0.
    const std::int32_t signed_root = F > 0 ? -root : root;
    const i64 sin_theta = -(i64{f} * gg) + i64{e} * signed_root;
    const i64 cos_theta = -(i64{e} * gg) - i64{f} * signed_root;
    const Q3_28 theta = atan2_raw(sin_theta, cos_theta);
    r.theta_rad[k] = theta;
  }
  r.status = KinematicsStatus::kOk;
  return r;
}

ForwardKinematicsQ forward_kinematics(const GeometryQ& g, const JointAnglesQ& q) {
  return forward_kinematics(g, std::array<SinCos, 3>{sincos(q[0]), sincos(q[1]), sincos(q[2])});
}

ForwardKinematicsQ forward_kinematics(const GeometryQ& g, const std::array<SinCos, 3>& trig) {
  ForwardKinematicsQ r;
  // Sphere centres C_i = B_i - r u_i, radius b.
  Vec3Q c[3];
  for (unsigned k = 0; k < 3; ++k) {
    const Vec3Q e = elbow_position(g, static_cast<int>(k), trig[k]);
    c[k] = {e.x_m - mul<Q7_24>(g.platform_radius_m, kCos[k]),
            e.y_m - mul<Q7_24>(g.platform_radius_m, kSin[k]), e.z_m};
  }
  const Vec3Q d21{c[1].x_m - c[0].x_m, c[1].y_m - c[0].y_m, c[1].z_m - c[0].z_m};
  const Vec3Q d31{c[2].x_m - c[0].x_m, c[2].y_m - c[0].y_m, c[2].z_m - c[0].z_m};
  const Q7_24 d =
      length(prod48(d21.x_m, d21.x_m) + prod48(d21.y_m, d21.y_m) + prod48(d21.z_m, d21.z_m));
  if (d.raw() == 0) {
    r.status = KinematicsStatus::kSingular;
    return r;
  }
  // Unit vectors in Q1.30.
  // Quotients through one reciprocal each of d and j (a 64-bit division is
  // a library call on Cortex-M4).
  const Divisor by_d(d);
  const Q1_30 ex[3] = {by_d.divide<Q1_30>(d21.x_m), by_d.divide<Q1_30>(d21.y_m),
                       by_d.divide<Q1_30>(d21.z_m)};
  const Q7_24 i =
      mul<Q7_24>(ex[0], d31.x_m) + mul<Q7_24>(ex[1], d31.y_m) + mul<Q7_24>(ex[2], d31.z_m);
  const Vec3Q ey_raw{d31.x_m - mul<Q7_24>(ex[0], i), d31.y_m - mul<Q7_24>(ex[1], i),
                     d31.z_m - mul<Q7_24>(ex[2], i)};
  const Q7_24 j = length(prod48(ey_raw.x_m, ey_raw.x_m) + prod48(ey_raw.y_m, ey_raw.y_m) +
                         prod48(ey_raw.z_m, ey_raw.z_m));
  if (j.raw() < 64) {  // collinear centres (j < 4 um)
    r.status = KinematicsStatus::kSingular;
    return r;
  }
  const Divisor by_j(j);
  const Q1_30 ey[3] = {by_j.divide<Q1_30>(ey_raw.x_m), by_j.divide<Q1_30>(ey_raw.y_m),
                       by_j.divide<Q1_30>(ey_raw.z_m)};
  Q1_30 ez[3] = {mul<Q1_30>(ex[1], ey[2]) - mul<Q1_30>(ex[2], ey[1]),
                 mul<Q1_30>(ex[2], ey[0]) - mul<Q1_30>(ex[0], ey[2]),
                 mul<Q1_30>(ex[0], ey[1]) - mul<Q1_30>(ex[1], ey[0])};
  if (ez[2] > Q1_30::zero()) {  // the solution below
    for (Q1_30& v : ez) v = -v;
  }
  // Equal radii: x = d / 2, y = (i^2 + j^2 - 2 i x) / (2 j), z = sqrt(b^2 - x^2 - y^2).
  const Q7_24 x = d.halved(1);
  const i64 num48 = prod48(i, i) + prod48(j, j) - 2 * prod48(i, x);
  const Q7_24 y = quotient<Q7_24>(Q7_24::from_raw(narrow<24>(num48)), j.scaled_by(2));
  const i64 z_sq48 = prod48(g.forearm_length_m, g.forearm_length_m) - prod48(x, x) - prod48(y, y);
  if (z_sq48 < 0) {
    r.status = KinematicsStatus::kUnreachable;
    return r;
  }
  const Q7_24 z = length(z_sq48);
  r.position = {c[0].x_m + mul<Q7_24>(ex[0], x) + mul<Q7_24>(ey[0], y) + mul<Q7_24>(ez[0], z),
                c[0].y_m + mul<Q7_24>(ex[1], x) + mul<Q7_24>(ey[1], y) + mul<Q7_24>(ez[1], z),
                c[0].z_m + mul<Q7_24>(ex[2], x) + mul<Q7_24>(ey[2], y) + mul<Q7_24>(ez[2], z)};
  r.status = KinematicsStatus::kOk;
  return r;
}

}  // namespace delta::fx
