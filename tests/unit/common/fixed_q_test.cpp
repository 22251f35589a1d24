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
  // 2^-25 is half an LSB of Q7.24: ties round away from zero.
  static_assert(Q7_24::from(1.0 / 33554432.0).raw() == 1);
  static_assert(Q7_24::from(-1.0 / 33554432.0).raw() == -1);
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
  // Rounding of a negative product: -1 LSB * 0.5 = -0.5 LSB -> -1 (away from zero).
  EXPECT_EQ(mul<Q7_24>(Q7_24::from_raw(-1), Q7_24::from(0.5)).raw(), -1);
  EXPECT_EQ(mul<Q7_24>(Q7_24::from_raw(1), Q7_24::from(0.5)).raw(), 1);
  EXPECT_EQ(mul<Q7_24>(Q7_24::from(100.0), Q7_24::from(100.0)).raw(), INT32_MAX);
  EXPECT_EQ(mul<Q7_24>(Q7_24::from(-100.0), Q7_24::from(100.0)).raw(), INT32_MIN);
}

TEST(FixedQTest, DivideRoundsToNearestAndHandlesZero) {
  EXPECT_EQ(div<Q7_24>(Q7_24::from(1.0), Q7_24::from(3.0)).raw(), 5592405);   // 5592405.33
  EXPECT_EQ(div<Q7_24>(Q7_24::from(2.0), Q7_24::from(3.0)).raw(), 11184811);  // 11184810.67
  EXPECT_EQ(div<Q7_24>(Q7_24::from(-2.0), Q7_24::from(3.0)).raw(), -11184811);
  EXPECT_EQ(div<Q7_24>(Q7_24::from(2.0), Q7_24::from(-3.0)).raw(), -11184811);
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
  EXPECT_EQ(convert<Q7_24>(Q1_30::from_raw(-32)).raw(), -1);
}

}  // namespace
}  // namespace delta::fx
