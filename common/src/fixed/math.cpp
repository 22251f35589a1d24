#include "delta/fixed/math.hpp"

namespace delta::fx {

namespace {

// pi / 2 in Q3.58, for the quadrant reduction (its operand angle * 2^30
// must leave headroom in 64 bits).
constexpr std::int64_t kHalfPiQ58 = 452751216129820178LL;

// atan(2^-i) in Q2.29, i = 0..29, and pi, for the 32-bit CORDIC.
constexpr std::int32_t kAtanTableQ29[30] = {
    421657428, 248918915, 131521918, 66762579, 33510843, 16771758, 8387925, 4194219,
    2097141,   1048575,   524288,    262144,   131072,   65536,    32768,   16384,
    8192,      4096,      2048,      1024,     512,      256,      128,     64,
    32,        16,        8,         4,        2,        1};
constexpr std::int32_t kPiQ29 = 1686629713;

// Taylor coefficients 1/k! in Q1.30.
constexpr std::int64_t kInvFact[14] = {1073741824, 1073741824, 536870912, 178956971, 44739243,
                                       8947849,    1491308,    213044,    26631,     2959,
                                       296,        27,         2,         0};

constexpr std::int64_t kOneQ30 = std::int64_t{1} << 30;

// (a * b) / 2^30 rounded, for Q1.30 operands.
constexpr std::int64_t mul30(std::int64_t a, std::int64_t b) {
  return detail::shift_round(a * b, 30);
}

}  // namespace

SinCos sincos(Q3_28 angle_rad) {
  // n = round(angle / (pi/2)); r = angle - n pi/2 in Q3.58, |r| <= pi/4.
  const std::int64_t a58 = std::int64_t{angle_rad.raw()} * (std::int64_t{1} << 30);
  const std::int64_t n = (a58 >= 0 ? a58 + kHalfPiQ58 / 2 : a58 - kHalfPiQ58 / 2) / kHalfPiQ58;
  const std::int64_t r58 = a58 - n * kHalfPiQ58;
  const std::int64_t x = detail::shift_round(r58, 28);  // Q1.30
  const std::int64_t x2 = mul30(x, x);
  // sin x = x (1 - x^2/3! + x^4/5! - ... - x^10/11!)
  std::int64_t s = kInvFact[11];
  for (int k = 9; k >= 1; k -= 2) s = kInvFact[k] - mul30(x2, s);
  s = mul30(x, s);
  // cos x = 1 - x^2/2! + x^4/4! - ... + x^12/12!
  std::int64_t c = kInvFact[12];
  for (int k = 10; k >= 0; k -= 2) c = kInvFact[k] - mul30(x2, c);
  const auto q = static_cast<int>(((n % 4) + 4) % 4);
  std::int64_t sin_v = 0, cos_v = 0;
  switch (q) {
    case 0:
      sin_v = s;
      cos_v = c;
      break;
    case 1:
      sin_v = c;
      cos_v = -s;
      break;
    case 2:
      sin_v = -s;
      cos_v = -c;
      break;
    default:
      sin_v = -c;
      cos_v = s;
      break;
  }
  const auto clamp = [](std::int64_t v) {
    return Q1_30::from_raw(
        static_cast<std::int32_t>(v > kOneQ30 ? kOneQ30 : (v < -kOneQ30 ? -kOneQ30 : v)));
  };
  return {clamp(sin_v), clamp(cos_v)};
}

Q3_28 atan2_raw(std::int64_t y, std::int64_t x) {
  if (x == 0 && y == 0) return Q3_28::zero();
  // Scale so that max(|x|, |y|) lies in [2^28, 2^29): 32-bit CORDIC, whose
  // gain of 1.65 then stays below 2^30. One count-leading-zeros, no loop.
  const std::uint64_t m =
      static_cast<std::uint64_t>(x < 0 ? -x : x) | static_cast<std::uint64_t>(y < 0 ? -y : y);
  const int lead = __builtin_clzll(m) - 35;  // bit 28 becomes the top bit
  auto xs = static_cast<std::int32_t>(lead >= 0 ? x * (std::int64_t{1} << lead) : (x >> -lead));
  auto ys = static_cast<std::int32_t>(lead >= 0 ? y * (std::int64_t{1} << lead) : (y >> -lead));
  // Into the right half plane: rotate by pi. The angle accumulates in Q2.29.
  std::int32_t z = 0;
  if (xs < 0) {
    z = ys >= 0 ? kPiQ29 : -kPiQ29;
    xs = -xs;
    ys = -ys;
  }
  // Vectoring: drive y to zero, accumulating the angle.
  for (int i = 0; i < 30; ++i) {
    const std::int32_t dx = xs >> i;
    const std::int32_t dy = ys >> i;
    if (ys > 0) {
      xs += dy;
      ys -= dx;
      z += kAtanTableQ29[i];
    } else {
      xs -= dy;
      ys += dx;
      z -= kAtanTableQ29[i];
    }
  }
  return Q3_28::from_raw(static_cast<std::int32_t>(detail::shift_round(z, 1)));
}

std::uint64_t isqrt_round(std::uint64_t v) {
  // Bit by bit: the largest r with r^2 <= v.
  if (v == 0) return 0;
  std::uint64_t rem = v;
  std::uint64_t root = 0;
  // The highest power of four <= v, from one count-leading-zeros.
  std::uint64_t bit = std::uint64_t{1} << ((63 - __builtin_clzll(v)) & ~1);
  while (bit != 0) {
    if (rem >= root + bit) {
      rem -= root + bit;
      root = (root >> 1) + bit;
    } else {
      root >>= 1;
    }
    bit >>= 2;
  }
  // Round to nearest: (root + 1/2)^2 = root^2 + root + 1/4 <= v  <=>  rem > root.
  if (rem > root) ++root;
  return root;
}

}  // namespace delta::fx
