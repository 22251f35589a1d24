#include "delta/fixed/math.hpp"

#include <array>
#include <cstddef>

namespace delta::fx {

namespace {

// pi / 2 in Q3.58, for the quadrant reduction (its operand angle * 2^30
// must leave headroom in 64 bits).
constexpr std::int64_t kHalfPiQ58 = 452751216129820178LL;
// 2 / pi in Q0.32.
constexpr std::int64_t kTwoOverPiQ32 = 2734261102LL;

// atan(t) / t as a polynomial in u = t^2 on [0, tan^2(pi/8)], highest power
// first, Q1.30 (mpmath chebyfit, degree 5: 6.2e-10; t P(u) is within
// 5.5e-10 rad of atan t with the Q1.30 coefficients and the Horner steps
// below); pi, pi/2 and pi/4 in Q2.29.
constexpr std::int32_t kAtanPolyQ30[6] = {-64706960, 113492673,  -152895818,
                                          214728855, -357913657, 1073741823};
// tan(pi/8) in Q0.32.
constexpr std::uint64_t kTanPiOver8Q32 = 1779033704u;
// 1 / D for D in the middle of [(128 + i) / 256, (129 + i) / 256), Q1.15:
// 2^24 / (257 + 2 i), rounded.
constexpr auto kReciprocalSeedQ15 = [] {
  std::array<std::uint16_t, 128> t{};
  for (std::uint32_t i = 0; i < 128; ++i) {
    const std::uint32_t d = 257 + 2 * i;
    t[i] = static_cast<std::uint16_t>(((1u << 24) + d / 2) / d);
  }
  return t;
}();
constexpr std::int32_t kPiQ29 = 1686629713;
constexpr std::int32_t kHalfPiQ29 = 843314857;
constexpr std::int32_t kQuarterPiQ29 = 421657428;

// cos r and sin(r) / r as polynomials in v = r^2 / 2 on [0, (pi/4)^2 / 2],
// highest power first, Q1.30 (mpmath chebyfit, degree 4: 4.8e-11 and
// 3.4e-12; the Taylor series would need two more terms for cos and one for
// sin). With the Q1.30 coefficients and rounded Horner steps the error is
// 0.81 LSB for cos and 1.04 LSB for sin at exact r.
constexpr std::int32_t kCosPolyQ30[5] = {418842, -11928514, 178956756, -1073741816, 1073741824};
constexpr std::int32_t kSinPolyQ30[5] = {46684, -1704174, 35791375, -357913941, 1073741824};

constexpr std::int64_t kOneQ30 = std::int64_t{1} << 30;

// (a * b) / 2^30 rounded half up, for Q1.30 operands of at most 31 bits
// whose product fits Q1.30 again (one 32 x 32 -> 64 multiply, no branch,
// and 32-bit arithmetic around it).
constexpr std::int32_t mul30(std::int32_t a, std::int32_t b) {
  return static_cast<std::int32_t>((std::int64_t{a} * b + (std::int64_t{1} << 29)) >> 30);
}

// c[0] v^(n-1) + ... + c[n-1] for a fraction v in Q0.32 (0 <= v < 1/2):
// Horner's rule, each step c + p v rounded half up (one SMMLAR on
// Cortex-M4).
template <std::size_t N>
constexpr std::int32_t horner(const std::int32_t (&c)[N], std::int32_t v_q32) {
  std::int32_t p = c[0];
  for (std::size_t k = 1; k < N; ++k) p = add_high_product(c[k], p, v_q32);
  return p;
}

}  // namespace

namespace {

// The reduction angle = n pi/2 + r, |r| <= pi/4 (+ a rounding hair): n by
// a multiply with 2/pi (no division), r in Q1.30.
struct Reduced {
  int quadrant;    // n mod 4
  std::int32_t r;  // Q1.30
};

Reduced reduce(Q3_28 angle_rad) {
  const std::int64_t scaled = std::int64_t{angle_rad.raw()} * kTwoOverPiQ32;  // Q3.60
  const std::int64_t n = (scaled + (std::int64_t{1} << 59)) >> 60;
  const std::int64_t a58 = std::int64_t{angle_rad.raw()} * (std::int64_t{1} << 30);
  const std::int64_t r58 = a58 - n * kHalfPiQ58;
  return {static_cast<int>(n & 3), static_cast<std::int32_t>(shift_round(r58, 28))};
}

// v = r^2 / 2 in Q0.32 from r in Q1.30: below 0.31 for |r| <= pi/4 (+ a
// hair), so it fits and horner() applies.
std::int32_t half_square_q32(std::int32_t r) {
  return static_cast<std::int32_t>((std::int64_t{r} * r + (std::int64_t{1} << 28)) >> 29);
}

// sin r = r S(v); every partial sum stays within Q1.30.
std::int32_t sin_poly(std::int32_t r, std::int32_t v) {
  return mul30(r, horner(kSinPolyQ30, v));
}

// cos r = C(v).
std::int32_t cos_poly(std::int32_t v) {
  return horner(kCosPolyQ30, v);
}

Q1_30 clamp_unit(std::int64_t v) {
  return Q1_30::from_raw(
      static_cast<std::int32_t>(v > kOneQ30 ? kOneQ30 : (v < -kOneQ30 ? -kOneQ30 : v)));
}

}  // namespace

std::uint32_t reciprocal_q30(std::uint32_t den) {
  using u32 = std::uint32_t;
  using u64 = std::uint64_t;
  u32 r = u32{kReciprocalSeedQ15[(den >> 24) - 128]} << 15;
  for (int i = 0; i < 2; ++i) {
    const u32 e = (u32{2} << 30) - static_cast<u32>((u64{den} * r) >> 32);
    r = static_cast<u32>((u64{r} * e) >> 30);
  }
  return r;
}

SinCos sincos(Q3_28 angle_rad) {
  const Reduced red = reduce(angle_rad);
  const std::int32_t v = half_square_q32(red.r);
  const std::int64_t s = sin_poly(red.r, v);
  const std::int64_t c = cos_poly(v);
  switch (red.quadrant) {
    case 0:
      return {clamp_unit(s), clamp_unit(c)};
    case 1:
      return {clamp_unit(c), clamp_unit(-s)};
    case 2:
      return {clamp_unit(-s), clamp_unit(-c)};
    default:
      return {clamp_unit(-c), clamp_unit(s)};
  }
}

Q1_30 cos(Q3_28 angle_rad) {
  const Reduced red = reduce(angle_rad);
  const std::int32_t v = half_square_q32(red.r);
  switch (red.quadrant) {
    case 0:
      return clamp_unit(cos_poly(v));
    case 1:
      return clamp_unit(-std::int64_t{sin_poly(red.r, v)});
    case 2:
      return clamp_unit(-std::int64_t{cos_poly(v)});
    default:
      return clamp_unit(sin_poly(red.r, v));
  }
}

Q3_28 atan2_raw(std::int64_t y, std::int64_t x) {
  if (x == 0 && y == 0) return Q3_28::zero();
  // |x|, |y| scaled together so that the larger lies in [2^30, 2^31).
  const auto ux = static_cast<std::uint64_t>(x < 0 ? -x : x);
  const auto uy = static_cast<std::uint64_t>(y < 0 ? -y : y);
  const int lead = __builtin_clzll(ux | uy) - 33;  // bit 30 becomes the top bit
  auto big = static_cast<std::uint32_t>(lead >= 0 ? (ux > uy ? ux : uy) << lead
                                                  : (ux > uy ? ux : uy) >> -lead);
  auto small = static_cast<std::uint32_t>(lead >= 0 ? (ux > uy ? uy : ux) << lead
                                                    : (ux > uy ? uy : ux) >> -lead);
  // atan(small / big) in [0, pi/4]; above pi/8 as pi/4 - atan(t) with
  // t = (big - small) / (big + small), so that t lies in [0, tan(pi/8)]
  // either way and a short polynomial serves.
  using u32 = std::uint32_t;
  using u64 = std::uint64_t;
  const bool upper = (u64{small} << 32) > u64{big} * kTanPiOver8Q32;
  u32 num = upper ? big - small : small;
  u32 den = upper ? big + small : big;  // < 2^32
  // t = num / den through the reciprocal of d = den * 2^k in [2^31, 2^32):
  // a seed within 0.4 % from the table, then two Newton steps
  // r <- r (2 - D r), D = d / 2^32 (errors 3.9e-3, 1.5e-5, 2.3e-10).
  const int k = __builtin_clz(den);  // 0 or 1
  den <<= k;
  num <<= k;
  const u32 r = reciprocal_q30(den);
  const auto t = static_cast<std::int32_t>((u64{num} * r + (u64{1} << 31)) >> 32);  // Q1.30
  // atan(t) = t P(u), u = t^2 in Q0.32 (below 0.172). Every partial sum
  // of P fits 32 bits in Q1.30, so 32-bit arithmetic around each product.
  const auto u = static_cast<std::int32_t>((std::int64_t{t} * t + (std::int64_t{1} << 27)) >> 28);
  const std::int32_t p = horner(kAtanPolyQ30, u);
  // Q2.29 from here on, 32 bits.
  auto angle = static_cast<std::int32_t>((std::int64_t{t} * p + (std::int64_t{1} << 30)) >> 31);
  if (upper) angle = kQuarterPiQ29 - angle;
  // Back to the octant, the half plane and the sign of y.
  if (uy > ux) angle = kHalfPiQ29 - angle;
  if (x < 0) angle = kPiQ29 - angle;
  if (y < 0) angle = -angle;
  return Q3_28::from_raw(shift_round32(angle, 1));
}

namespace {

// floor(sqrt(x)) by bisection, for the table below (compile time only).
constexpr std::uint32_t isqrt_slow(std::uint64_t x) {
  std::uint64_t lo = 0, hi = 1ull << 32;
  while (hi - lo > 1) {
    const std::uint64_t mid = (lo + hi) / 2;
    (mid * mid <= x ? lo : hi) = mid;
  }
  return static_cast<std::uint32_t>(lo);
}

// sqrt of the middle of each interval [i 2^24, (i + 1) 2^24), i = 64..255:
// a seed within 0.4 % of sqrt(hi) for any hi in [2^30, 2^32).
constexpr auto kSqrtSeed = [] {
  std::array<std::uint16_t, 192> t{};
  for (std::uint32_t i = 0; i < 192; ++i) {
    t[i] = static_cast<std::uint16_t>(isqrt_slow((std::uint64_t{i + 64} << 24) + (1u << 23)));
  }
  return t;
}();

}  // namespace

std::uint64_t isqrt_round(std::uint64_t v) {
  if (v == 0) return 0;
  // Normalise by an even shift so that n = v * 4^k lies in [2^62, 2^64).
  const int shift = __builtin_clzll(v) & ~1;
  const std::uint64_t n = v << shift;
  // floor(sqrt(n >> 32)): a seed from the table, one Newton step (a
  // hardware divide on Cortex-M4), which lands on the floor or one above
  // it (the seed is within 0.4 %), and a check.
  const auto hi = static_cast<std::uint32_t>(n >> 32);  // [2^30, 2^32)
  const std::uint32_t seed = kSqrtSeed[(hi >> 24) - 64];
  std::uint32_t x = (seed + hi / seed) >> 1;
  if (x * x > hi || x > 0xFFFFu) --x;
  // Then one correction step to about 2^-15 and an exact fix-up, in 32-bit
  // values (floor(sqrt(n)) < 2^32) with 64-bit squares.
  using u64 = std::uint64_t;
  const std::uint32_t y0 = x << 16;  // <= sqrt(n)
  const u64 e = n - u64{y0} * y0;    // < 2^50
  const u64 y1 = u64{y0} + static_cast<std::uint32_t>(e >> 17) / x;
  std::uint32_t y = y1 > 0xFFFFFFFFu ? 0xFFFFFFFFu : static_cast<std::uint32_t>(y1);
  while (u64{y} * y > n) --y;
  while (y < 0xFFFFFFFFu && u64{y + 1} * (y + 1) <= n) ++y;
  // floor(sqrt(v)) = floor(floor(sqrt(n)) / 2^k); then round to nearest:
  // (r + 1/2)^2 = r^2 + r + 1/4 <= v  <=>  v - r^2 > r.
  std::uint64_t r = y >> (shift / 2);
  if (v - r * r > r) ++r;
  return r;
}

namespace {

// log2(e) in Q1.30.
constexpr std::int64_t kLog2eQ30 = 1549082005;  // 1.4426950408889634 * 2^30
// 2^-f = 2^-(2 v) as a polynomial in v = f / 2 on [0, 1/2], highest power
// first, Q1.30 (mpmath chebyfit, degree 7: 3.0e-11; with the Q1.30
// coefficients and rounded Horner steps within 1.07 LSB).
constexpr std::int32_t kExp2PolyQ30[8] = {-1487275,   10119783,   -45622651,   165194165,
                                          -476771116, 1031764646, -1488522228, 1073741824};

}  // namespace

Q1_30 exp_neg(Q10_21 x) {
  if (x.raw() <= 0) return Q1_30::from_raw(1 << 30);
  // y = x log2(e) in Q.51: k its whole part, the fraction f; e^-x =
  // 2^-k 2^-f.
  const std::int64_t y = std::int64_t{x.raw()} * kLog2eQ30;
  const std::int64_t k = y >> 51;
  if (k >= 31) return Q1_30::zero();
  // v = f / 2 in Q0.32, below 1/2 (truncated: within 2^-32).
  const auto v = static_cast<std::int32_t>((y & ((std::int64_t{1} << 51) - 1)) >> 20);
  const std::int32_t p = horner(kExp2PolyQ30, v);  // every partial sum within Q1.30
  if (k == 0) return Q1_30::from_raw(p);
  return Q1_30::from_raw(shift_round32(p, static_cast<int>(k)));
}

Q1_30 tanh(Q10_21 x) {
  const bool negative = x.raw() < 0;
  const Q10_21 magnitude = negative ? -x : x;
  // (1 - t) / (1 + t) with 1 + t = 2 D, D = (1 + t) / 2 in [1/2, 1].
  const std::int64_t t = exp_neg(magnitude.scaled_by(2)).raw();
  if (t == 0) return Q1_30::from_raw(negative ? -(1 << 30) : 1 << 30);  // |x| > 10.7
  const auto den = static_cast<std::uint32_t>((kOneQ30 + t) << 1);      // D in Q0.32
  if (den == 0) return Q1_30::zero();  // t = 1 (x = 0): D = 1 wraps
  const std::int64_t q = ((kOneQ30 - t) * reciprocal_q30(den) + (std::int64_t{1} << 30)) >> 31;
  const auto r = static_cast<std::int32_t>(q > kOneQ30 ? kOneQ30 : q);
  return Q1_30::from_raw(negative ? -r : r);
}

}  // namespace delta::fx
