#include <gtest/gtest.h>

#include "delta/fixed/q.hpp"

namespace delta::fx {
namespace {

double value(Q7_24 q) {
  return q.raw() / 16777216.0;
}

TEST(FixedQTest, CompileTimeConstantsRoundToNearest) {
  static_assert(Q7_24::from(1.0).raw() == 1 << 24);
  static_assert(Q7_24::from(-0.5).raw() == -(1 << 23));
  static_assert(Q1_30::from(0.25).raw() == 1 << 28);
  // 2^-25 is half an LSB of Q7.24: ties round upwards.
  static_assert(Q7_24::from(1.0 / 33554432.0).raw() == 1);
  static_assert(Q7_24::from(-1.0 / 33554432.0).raw() == 0);
  static_assert(Q7_24::from(-3.0 / 33554432.0).raw() == -1);
  static_assert(Q7_24::from(-1.1 / 33554432.0).raw() == -1);
  static_assert(Q7_24::from(-128.0).raw() == INT32_MIN);
  EXPECT_EQ(Q7_24::from(0.2).raw(), 3355443);  // 0.2 * 2^24 = 3355443.2
}

TEST(FixedQTest, AddAndSubtractSaturate) {
  const Q7_24 big = Q7_24::from(127.5);
  EXPECT_EQ((big + big).raw(), INT32_MAX);
  EXPECT_EQ((-big - big).raw(), INT32_MIN);
  EXPECT_EQ((-Q7_24::min()).raw(), INT32_MAX);
  EXPECT_DOUBLE_EQ(value(Q7_24::from(1.25) - Q7_24::from(3.5)), -2.25);
}

TEST(FixedQTest, MultiplyRoundsToNearestAndSaturates) {
  // 0.1 * 0.1 in Q7.24: exact 0.01 * 2^24 = 167772.16, from rounded operands.
  const Q7_24 a = Q7_24::from(0.1);
  const Q7_24 p = mul<Q7_24>(a, a);
  EXPECT_EQ(p.raw(), 167772);
  // Mixed formats: Q1.30 * Q7.24 -> Q7.24.
  EXPECT_EQ(mul<Q7_24>(Q1_30::from(0.5), Q7_24::from(3.0)).raw(), Q7_24::from(1.5).raw());
  // Ties round upwards: -1 LSB * 0.5 = -0.5 LSB -> 0, +0.5 LSB -> 1,
  // -3 LSB * 0.5 = -1.5 LSB -> -1; off a tie to the nearest.
  EXPECT_EQ(mul<Q7_24>(Q7_24::from_raw(-1), Q7_24::from(0.5)).raw(), 0);
  EXPECT_EQ(mul<Q7_24>(Q7_24::from_raw(1), Q7_24::from(0.5)).raw(), 1);
  EXPECT_EQ(mul<Q7_24>(Q7_24::from_raw(-3), Q7_24::from(0.5)).raw(), -1);
  EXPECT_EQ(mul<Q7_24>(Q7_24::from_raw(-3), Q7_24::from(0.75)).raw(), -2);   // -2.25 -> -2
  EXPECT_EQ(mul<Q7_24>(Q7_24::from_raw(-3), Q7_24::from(0.875)).raw(), -3);  // -2.625 -> -3
  EXPECT_EQ(mul<Q7_24>(Q7_24::from(100.0), Q7_24::from(100.0)).raw(), INT32_MAX);
  EXPECT_EQ(mul<Q7_24>(Q7_24::from(-100.0), Q7_24::from(100.0)).raw(), INT32_MIN);
}

// mul() equals the plain rule (the exact product rounded to the nearest,
// ties upwards, then saturated) for every operand tried: random raws of all
// magnitudes and signs, ties, zeros and extremes. A faster rounding must
// keep passing it.
template <class R, class A, class B>
void expect_mul_matches_the_rule(std::uint64_t seed) {
  constexpr int shift = A::kFracBits + B::kFracBits - R::kFracBits;
  const auto rule = [](std::int32_t a, std::int32_t b) {
    const std::int64_t p = std::int64_t{a} * b;
    const std::int64_t h = std::int64_t{1} << (shift - 1);
    // floor(p / 2^shift + 1/2), with / rounding towards zero in C++.
    const std::int64_t num = p + h;
    const std::int64_t den = std::int64_t{1} << shift;
    const std::int64_t q = num / den - (num % den < 0 ? 1 : 0);
    return static_cast<std::int32_t>(q > INT32_MAX ? INT32_MAX : (q < INT32_MIN ? INT32_MIN : q));
  };
  std::uint64_t x = seed;
  const auto next = [&x] {
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    return x;
  };
  constexpr std::int64_t half = std::int64_t{1} << (shift - 1);
  constexpr auto half32 = static_cast<std::int32_t>(half > INT32_MAX ? INT32_MAX : half);
  const std::int32_t edges[] = {
      0, 1, -1, 2, -2, 3, -3, INT32_MAX, INT32_MIN, INT32_MIN + 1, half32, -half32};
  for (const std::int32_t a : edges) {
    for (const std::int32_t b : edges) {
      ASSERT_EQ(mul<R>(A::from_raw(a), B::from_raw(b)).raw(), rule(a, b)) << a << " * " << b;
    }
  }
  for (int i = 0; i < 200000; ++i) {
    const auto a = static_cast<std::int32_t>(static_cast<std::uint32_t>(next()) >> (next() % 32));
    const auto b = static_cast<std::int32_t>(static_cast<std::uint32_t>(next()) >> (next() % 32));
    const std::int32_t sa = (next() & 1) ? -a : a;  // a is never INT32_MIN here
    ASSERT_EQ(mul<R>(A::from_raw(sa), B::from_raw(b)).raw(), rule(sa, b)) << sa << " * " << b;
    // A tie: -1 times an odd multiple of 2^(shift-1), where it fits.
    const std::int64_t tie = static_cast<std::int64_t>(next() % 1024 * 2 + 1) * half;
    if (tie <= INT32_MAX) {
      const auto t = static_cast<std::int32_t>(tie);
      ASSERT_EQ(mul<R>(A::from_raw(-1), B::from_raw(t)).raw(), rule(-1, t)) << t;
      ASSERT_EQ(mul<R>(A::from_raw(t), B::from_raw(1)).raw(), rule(t, 1)) << t;
    }
  }
}

TEST(FixedQTest, MultiplyEqualsTheRoundingRuleForEveryOperand) {
  expect_mul_matches_the_rule<Q7_24, Q7_24, Q7_24>(1);    // shift 24
  expect_mul_matches_the_rule<Q7_24, Q1_30, Q7_24>(2);    // shift 30
  expect_mul_matches_the_rule<Q12_19, Q12_19, Q3_28>(3);  // shift 28
  expect_mul_matches_the_rule<Q1_30, Q1_30, Q1_30>(4);    // shift 30
  expect_mul_matches_the_rule<Q3_28, Q1_30, Q1_30>(5);    // shift 32: the generic path
  expect_mul_matches_the_rule<Q10_21, Q1_30, Q10_21>(6);  // shift 30
}

TEST(FixedQTest, DivideRoundsToNearestAndHandlesZero) {
  EXPECT_EQ(div<Q7_24>(Q7_24::from(1.0), Q7_24::from(3.0)).raw(), 5592405);   // 5592405.33
  EXPECT_EQ(div<Q7_24>(Q7_24::from(2.0), Q7_24::from(3.0)).raw(), 11184811);  // 11184810.67
  EXPECT_EQ(div<Q7_24>(Q7_24::from(-2.0), Q7_24::from(3.0)).raw(), -11184811);
  EXPECT_EQ(div<Q7_24>(Q7_24::from(2.0), Q7_24::from(-3.0)).raw(), -11184811);
  EXPECT_EQ(div<Q7_24>(Q7_24::from(-1.0), Q7_24::from(3.0)).raw(), -5592405);  // -5592405.33
  // Ties round upwards: 1.5 and -1.5 LSB, 2.5 and -2.5 LSB.
  EXPECT_EQ(div<Q7_24>(Q7_24::from_raw(3), Q7_24::from(2.0)).raw(), 2);
  EXPECT_EQ(div<Q7_24>(Q7_24::from_raw(-3), Q7_24::from(2.0)).raw(), -1);
  EXPECT_EQ(div<Q7_24>(Q7_24::from_raw(5), Q7_24::from(-2.0)).raw(), -2);
  EXPECT_EQ(div<Q7_24>(Q7_24::from_raw(-5), Q7_24::from(-2.0)).raw(), 3);
  EXPECT_EQ(div<Q1_30>(Q7_24::from(0.25), Q7_24::from(0.5)).raw(), 1 << 29);
  EXPECT_EQ(div<Q7_24>(Q7_24::from(1.0), Q7_24::zero()).raw(), INT32_MAX);
  EXPECT_EQ(div<Q7_24>(Q7_24::from(-1.0), Q7_24::zero()).raw(), INT32_MIN);
  EXPECT_EQ(div<Q7_24>(Q7_24::from(100.0), Q7_24::from(0.01)).raw(), INT32_MAX);
}

TEST(FixedQTest, ConvertRoundsAndSaturates) {
  EXPECT_EQ(convert<Q1_30>(Q7_24::from(0.75)).raw(), Q1_30::from(0.75).raw());
  EXPECT_EQ(convert<Q1_30>(Q7_24::from(3.0)).raw(), INT32_MAX);
  // Q1.30 -> Q7.24 drops 6 bits: 33 / 64 = 0.516 rounds to 1.
  EXPECT_EQ(convert<Q7_24>(Q1_30::from_raw(33)).raw(), 1);
  EXPECT_EQ(convert<Q7_24>(Q1_30::from_raw(31)).raw(), 0);
  // -32 / 64 = -0.5 is a tie (upwards: 0); -33 / 64 rounds to -1.
  EXPECT_EQ(convert<Q7_24>(Q1_30::from_raw(-32)).raw(), 0);
  EXPECT_EQ(convert<Q7_24>(Q1_30::from_raw(-33)).raw(), -1);
  EXPECT_EQ(convert<Q7_24>(Q1_30::from_raw(-96)).raw(), -1);
}

}  // namespace
}  // namespace delta::fx
