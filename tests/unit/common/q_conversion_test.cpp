// delta/q_conversion.hpp: the one conversion from double to a Q format,
// rounding as q.hpp does (to the nearest, ties upwards).
#include "delta/q_conversion.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace {

using delta::fx::Q1_30;
using delta::fx::Q7_24;

// Exactly k + 1/2 steps of Q7.24.
double half_steps(int k) {
  return std::ldexp(k + 0.5, -24);
}

TEST(QConversionTest, TiesRoundUpwardsAsQ_hppRoundsAtCompileTime) {
  EXPECT_EQ(delta::to_q<Q7_24>(half_steps(0))->raw(), 1);
  EXPECT_EQ(delta::to_q<Q7_24>(half_steps(-1))->raw(), 0);   // -1/2 step goes up
  EXPECT_EQ(delta::to_q<Q7_24>(half_steps(-2))->raw(), -1);  // -3/2 steps: -1
  EXPECT_EQ(delta::to_q<Q7_24>(half_steps(-1))->raw(), Q7_24::from(-0.5 / (1 << 24)).raw());
  EXPECT_EQ(delta::to_q<Q7_24>(half_steps(-2))->raw(), Q7_24::from(-1.5 / (1 << 24)).raw());
  EXPECT_EQ(delta::to_q<Q7_24>(0.2)->raw(), Q7_24::from(0.2).raw());
  EXPECT_EQ(delta::to_q<Q7_24>(-0.46)->raw(), Q7_24::from(-0.46).raw());
}

TEST(QConversionTest, OutOfRangeOrNotFiniteIsNothing) {
  EXPECT_FALSE(delta::to_q<Q1_30>(2.0).has_value());
  EXPECT_TRUE(delta::to_q<Q1_30>(-2.0).has_value());  // the format's least value
  EXPECT_EQ(delta::to_q<Q1_30>(-2.0)->raw(), INT32_MIN);
  EXPECT_EQ(delta::to_q<Q1_30>(std::ldexp(INT32_MAX, -30))->raw(), INT32_MAX);
  EXPECT_FALSE(delta::to_q<Q1_30>(std::ldexp(INT32_MAX + 0.5, -30)).has_value());
  EXPECT_FALSE(delta::to_q<Q7_24>(std::numeric_limits<double>::quiet_NaN()).has_value());
  EXPECT_FALSE(delta::to_q<Q7_24>(std::numeric_limits<double>::infinity()).has_value());
}

TEST(QConversionTest, SaturatedConversionClampsAndRoundTrips) {
  EXPECT_EQ(delta::to_q_saturated<Q1_30>(5.0), Q1_30::max());
  EXPECT_EQ(delta::to_q_saturated<Q1_30>(-5.0), Q1_30::min());
  EXPECT_EQ(delta::to_q_saturated<Q1_30>(std::numeric_limits<double>::quiet_NaN()), Q1_30::zero());
  EXPECT_EQ(delta::to_double(delta::to_q_saturated<Q7_24>(1.25)), 1.25);
  EXPECT_EQ(delta::to_double(Q7_24::from_raw(-3)), -3.0 / (1 << 24));
}

}  // namespace
