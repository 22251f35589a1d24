#include "delta/fixed/math.hpp"

namespace delta::fx {

namespace {

// pi / 2 in Q3.60 (for atan2) and Q3.58 (for the quadrant reduction, whose
// operand angle * 2^30 must leave headroom in 64 bits).
constexpr std::int64_t kHalfPiQ60 = 1811004864519280711LL;
constexpr std::int64_t kHalfPiQ58 = 452751216129820178LL;

// atan(2^-i) in Q3.60, i = 0..39.
constexpr std::int64_t kAtanTableQ60[40] = {905502432259640355LL,
                                            534549298976576474LL,
                                            282441168888798124LL,
                                            143371547418228444LL,
                                            71963988336308046LL,
                                            36017075762092179LL,
                                            18012932708689205LL,
                                            9007016009513623LL,
                                            4503576721087964LL,
                                            2251796950380271LL,
                                            1125899548928887LL,
                                            562949908682076LL,
                                            281474971118251LL,
                                            140737487656277LL,
                                            70368744090283LL,
                                            35184372077909LL,
                                            17592186043051LL,
                                            8796093022037LL,
                                            4398046511083LL,
                                            2199023255549LL,
                                            1099511627776LL,
                                            549755813888LL,
                                            274877906944LL,
                                            137438953472LL,
                                            68719476736LL,
                                            34359738368LL,
                                            17179869184LL,
                                            8589934592LL,
                                            4294967296LL,
                                            2147483648LL,
                                            1073741824LL,
                                            536870912LL,
                                            268435456LL,
                                            134217728LL,
                                            67108864LL,
                                            33554432LL,
                                            16777216LL,
                                            8388608LL,
                                            4194304LL,
                                            2097152LL};

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
  // Scale so that max(|x|, |y|) lies in [2^59, 2^60): CORDIC's gain of 1.65
  // then stays below 2^61.
  std::uint64_t m =
      static_cast<std::uint64_t>(x < 0 ? -x : x) | static_cast<std::uint64_t>(y < 0 ? -y : y);
  int lead = 0;
  while (m >= (std::uint64_t{1} << 60)) {
    m >>= 1;
    --lead;
  }
  while (m < (std::uint64_t{1} << 59)) {
    m <<= 1;
    ++lead;
  }
  std::int64_t xs = lead >= 0 ? x * (std::int64_t{1} << lead) : (x >> -lead);
  std::int64_t ys = lead >= 0 ? y * (std::int64_t{1} << lead) : (y >> -lead);
  // Into the right half plane: rotate by pi.
  std::int64_t z = 0;  // Q3.60
  if (xs < 0) {
    z = ys >= 0 ? 2 * kHalfPiQ60 : -2 * kHalfPiQ60;
    xs = -xs;
    ys = -ys;
  }
  // Vectoring: drive y to zero, accumulating the angle.
  for (int i = 0; i < 40; ++i) {
    const std::int64_t dx = xs >> i;
    const std::int64_t dy = ys >> i;
    if (ys > 0) {
      xs += dy;
      ys -= dx;
      z += kAtanTableQ60[i];
    } else {
      xs -= dy;
      ys += dx;
      z -= kAtanTableQ60[i];
    }
  }
  return Q3_28::from_raw(static_cast<std::int32_t>(detail::shift_round(z, 32)));
}

std::uint64_t isqrt_round(std::uint64_t v) {
  // Bit by bit: the largest r with r^2 <= v.
  std::uint64_t rem = v;
  std::uint64_t root = 0;
  std::uint64_t bit = std::uint64_t{1} << 62;
  while (bit > rem) bit >>= 2;
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
