// Worst-case errors of the fixed-point math against double, over the whole
// input domain. The bounds asserted here are the ones documented in
// common/portable/include/delta/fixed/math.hpp and docs/design/fixed-point-core.md.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "delta/fixed/math.hpp"

namespace delta::fx {
namespace {

constexpr double kQ30 = 1073741824.0;  // 2^30
constexpr double kQ28 = 268435456.0;   // 2^28

TEST(FixedMathTest, SinCosWorstErrorOverTheWholeQ3_28Range) {
  // Every 997th raw angle from -2^31 to 2^31 (about 4.3 million angles),
  // plus the quadrant boundaries.
  double worst = 0.0;
  std::int64_t worst_raw = 0;
  const auto check = [&](std::int32_t raw) {
    const SinCos sc = sincos(Q3_28::from_raw(raw));
    const double a = raw / kQ28;
    const double es = std::abs(sc.sin.raw() / kQ30 - std::sin(a));
    const double ec = std::abs(sc.cos.raw() / kQ30 - std::cos(a));
    if (std::max(es, ec) > worst) {
      worst = std::max(es, ec);
      worst_raw = raw;
    }
  };
  for (std::int64_t raw = INT32_MIN; raw <= INT32_MAX; raw += 997)
    check(static_cast<std::int32_t>(raw));
  for (int k = -5; k <= 5; ++k) {
    for (int d = -2; d <= 2; ++d) {
      const std::int64_t r = k * static_cast<std::int64_t>(kHalfPi.raw()) + d;
      if (r >= INT32_MIN && r <= INT32_MAX) check(static_cast<std::int32_t>(r));
    }
  }
  std::printf("sincos: worst error %.3g (%.2f LSB of Q1.30) at raw %lld\n", worst, worst * kQ30,
              static_cast<long long>(worst_raw));
  EXPECT_LE(worst, 2.0 / kQ30);
}

TEST(FixedMathTest, CosAloneEqualsSinCosBitForBit) {
  for (std::int64_t raw = INT32_MIN; raw <= INT32_MAX; raw += 9973) {
    const Q3_28 a = Q3_28::from_raw(static_cast<std::int32_t>(raw));
    ASSERT_EQ(cos(a).raw(), sincos(a).cos.raw()) << raw;
  }
}

TEST(FixedMathTest, SinCosOfExactAngles) {
  EXPECT_EQ(sincos(Q3_28::zero()).sin.raw(), 0);
  EXPECT_EQ(sincos(Q3_28::zero()).cos.raw(), 1 << 30);
  EXPECT_NEAR(sincos(kHalfPi).sin.raw(), 1 << 30, 1);
  EXPECT_NEAR(sincos(kPi).cos.raw(), -(1 << 30), 1);
  EXPECT_NEAR(sincos(Q3_28::from(0.5235987755982988)).sin.raw(), 1 << 29, 2);  // sin 30 deg
}

TEST(FixedMathTest, Atan2WorstErrorOverAllDirectionsAndMagnitudes) {
  double worst = 0.0;
  int cases = 0;
  for (int k = 0; k < 200000; ++k) {
    const double angle = -std::numbers::pi + 2.0 * std::numbers::pi * (k + 0.37) / 200000.0;
    for (const double radius : {3.0, 1e4, 2.1e9}) {  // small to near-int32 magnitudes
      const auto x = static_cast<std::int64_t>(std::llround(radius * std::cos(angle)));
      const auto y = static_cast<std::int64_t>(std::llround(radius * std::sin(angle)));
      if (x == 0 && y == 0) continue;
      const double got = atan2_raw(y, x).raw() / kQ28;
      double err = std::abs(got - std::atan2(static_cast<double>(y), static_cast<double>(x)));
      err = std::min(err, std::abs(err - 2.0 * std::numbers::pi));  // +pi vs -pi
      worst = std::max(worst, err);
      ++cases;
    }
  }
  std::printf("atan2: worst error %.3g rad (%.2f LSB of Q3.28) over %d cases\n", worst,
              worst * kQ28, cases);
  EXPECT_LE(worst, 2.0 / kQ28);
  // Axes and the (0, 0) convention.
  EXPECT_EQ(atan2_raw(0, 0).raw(), 0);
  EXPECT_EQ(atan2_raw(0, 5).raw(), 0);
  EXPECT_NEAR(atan2_raw(5, 0).raw(), kHalfPi.raw(), 1);
  EXPECT_NEAR(atan2_raw(0, -5).raw(), kPi.raw(), 1);
  EXPECT_NEAR(atan2_raw(-5, 0).raw(), -kHalfPi.raw(), 1);
}

// The plain bit-by-bit square root, as the oracle for the fast one.
std::uint64_t reference_isqrt_round(std::uint64_t v) {
  std::uint64_t rem = v, root = 0, bit = std::uint64_t{1} << 62;
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
  return rem > root ? root + 1 : root;
}

TEST(FixedMathTest, FastSqrtEqualsBitByBitEverywhereTried) {
  // Every small value, squares and their neighbours at every size, and a
  // spread of 2 million values over the whole 64-bit range.
  for (std::uint64_t v = 0; v < 100000; ++v)
    ASSERT_EQ(isqrt_round(v), reference_isqrt_round(v)) << v;
  for (std::uint64_t r = 1; r < (std::uint64_t{1} << 32); r = r * 3 + 1) {
    for (const std::uint64_t v : {r * r - 1, r * r, r * r + 1, r * r + r, r * r + r + 1}) {
      ASSERT_EQ(isqrt_round(v), reference_isqrt_round(v)) << v;
    }
  }
  std::uint64_t x = 88172645463325252ull;
  for (int i = 0; i < 2000000; ++i) {
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    const std::uint64_t v = x >> (i % 64);
    ASSERT_EQ(isqrt_round(v), reference_isqrt_round(v)) << v;
  }
  EXPECT_EQ(isqrt_round(UINT64_MAX), std::uint64_t{1} << 32);
}

TEST(FixedMathTest, SqrtIsExactToTheNearestLsb) {
  for (std::uint64_t v : {0ull, 1ull, 2ull, 3ull, 4ull, 15ull, 16ull, 17ull, 1ull << 40,
                          (1ull << 62) - 1, 18446744073709551615ull}) {
    const long double exact = std::sqrt(static_cast<long double>(v));
    EXPECT_LE(std::abs(static_cast<long double>(isqrt_round(v)) - exact), 0.5L + 1e-9L) << v;
  }
  // Over Q7.24: every 9973rd positive raw value.
  double worst_lsb = 0.0;
  for (std::int64_t raw = 1; raw <= INT32_MAX; raw += 9973) {
    const Q7_24 r = sqrt<Q7_24>(Q7_24::from_raw(static_cast<std::int32_t>(raw)));
    const double exact = std::sqrt(static_cast<double>(raw) / 16777216.0) * 16777216.0;
    worst_lsb = std::max(worst_lsb, std::abs(r.raw() - exact));
  }
  EXPECT_LE(worst_lsb, 0.5 + 1e-6);
  EXPECT_EQ(sqrt<Q7_24>(Q7_24::from(-1.0)).raw(), 0);
  EXPECT_EQ(sqrt<Q7_24>(Q7_24::from(0.25)).raw(), Q7_24::from(0.5).raw());
}

TEST(FixedMathTest, ExpNegWorstErrorOverItsRange) {
  // Every 101st raw value of Q10.21 from 0 to 32 (beyond, e^-x is below one
  // LSB of Q1.30 and the result 0), and the whole positive range coarsely.
  double worst = 0.0;
  for (std::int64_t raw = 0; raw <= (std::int64_t{32} << 21); raw += 101) {
    const Q10_21 x = Q10_21::from_raw(static_cast<std::int32_t>(raw));
    const double exact = std::exp(-static_cast<double>(raw) / 2097152.0);
    worst = std::max(worst, std::abs(exp_neg(x).raw() / kQ30 - exact));
  }
  for (std::int64_t raw = std::int64_t{32} << 21; raw <= INT32_MAX; raw += 1000003) {
    EXPECT_LE(exp_neg(Q10_21::from_raw(static_cast<std::int32_t>(raw))).raw(), 1);
  }
  std::printf("exp_neg worst error %.3g (%.2f LSB of Q1.30)\n", worst, worst * kQ30);
  EXPECT_LE(worst * kQ30, 2.0);
  EXPECT_EQ(exp_neg(Q10_21::zero()).raw(), 1 << 30);
  EXPECT_EQ(exp_neg(Q10_21::from(-3.0)).raw(), 1 << 30);  // x <= 0 gives 1
}

TEST(FixedMathTest, TanhWorstErrorAndOddness) {
  double worst = 0.0;
  for (std::int64_t raw = -(std::int64_t{24} << 21); raw <= (std::int64_t{24} << 21); raw += 37) {
    const Q10_21 x = Q10_21::from_raw(static_cast<std::int32_t>(raw));
    const double exact = std::tanh(static_cast<double>(raw) / 2097152.0);
    worst = std::max(worst, std::abs(tanh(x).raw() / kQ30 - exact));
    ASSERT_EQ(tanh(-x).raw(), -tanh(x).raw()) << raw;
  }
  std::printf("tanh worst error %.3g (%.2f LSB of Q1.30)\n", worst, worst * kQ30);
  EXPECT_LE(worst * kQ30, 3.0);
  EXPECT_EQ(tanh(Q10_21::max()).raw(), 1 << 30);
  EXPECT_EQ(tanh(Q10_21::min()).raw(), -(1 << 30));
}

TEST(FixedMathTest, QuotientThroughTheReciprocalIsWithinTwoLsbOfDiv) {
  // Against the correctly rounded div<>, over operands of every magnitude
  // and sign, and formats that shift either way.
  std::uint64_t x = 88172645463325252ull;
  int worst = 0;
  for (int i = 0; i < 500000; ++i) {
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    const auto a = Q7_24::from_raw(static_cast<std::int32_t>(x) >> (i % 24));
    const auto b = Q7_24::from_raw(static_cast<std::int32_t>(x >> 32) >> (i % 29));
    if (b.raw() == 0) continue;
    const int d1 = std::abs(quotient<Q1_30>(a, b).raw() - div<Q1_30>(a, b).raw());
    const int d2 = std::abs(quotient<Q10_21>(a, b).raw() - div<Q10_21>(a, b).raw());
    worst = std::max({worst, d1, d2});
  }
  std::printf("quotient: worst %d LSB from div\n", worst);
  EXPECT_LE(worst, 2);
  EXPECT_EQ(quotient<Q7_24>(Q7_24::from(1.0), Q7_24::zero()).raw(), INT32_MAX);
  EXPECT_EQ(quotient<Q7_24>(Q7_24::from(-1.0), Q7_24::zero()).raw(), INT32_MIN);
  EXPECT_EQ(quotient<Q7_24>(Q7_24::from(3.0), Q7_24::from(-1.5)).raw(), Q7_24::from(-2.0).raw());
}

}  // namespace
}  // namespace delta::fx
