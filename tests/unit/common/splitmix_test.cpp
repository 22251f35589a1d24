#include "delta/splitmix.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace delta {
namespace {

// The published first outputs of SplitMix64 from state 0 (the reference
// implementation of Steele, Lea and Flood, as in Vigna's splitmix64.c).
TEST(SplitMix64Test, GivesThePublishedSequence) {
  SplitMix64 rng(0);
  EXPECT_EQ(rng.next(), 0xE220A8397B1DCDAFull);
  EXPECT_EQ(rng.next(), 0x6E789E6AA1B965F4ull);
  EXPECT_EQ(rng.next(), 0x06C45D188009454Full);
}

// A uniform is the output's top 53 bits over 2^53; a pair is one output's
// top and bottom 32 bits, each over 2^32, so count pairs use count outputs.
TEST(SplitMix64Test, UniformsAreTheTopBitsAndPairsSplitOneOutput) {
  SplitMix64 u(0);
  EXPECT_EQ(u.uniform(), static_cast<double>(0xE220A8397B1DCDAFull >> 11) * 0x1.0p-53);
  SplitMix64 pairs(0);
  double first[2], second[2];
  pairs.fill_pairs(first, second, 2);
  EXPECT_EQ(first[0], static_cast<double>(0xE220A839ull) * 0x1.0p-32);
  EXPECT_EQ(second[0], static_cast<double>(0x7B1DCDAFull) * 0x1.0p-32);
  EXPECT_EQ(first[1], static_cast<double>(0x6E789E6Aull) * 0x1.0p-32);
  EXPECT_EQ(second[1], static_cast<double>(0xA1B965F4ull) * 0x1.0p-32);
  SplitMix64 single(0);
  single.next();
  single.next();
  EXPECT_EQ(pairs.next(), single.next());
  // Both halves stay below 1.
  SplitMix64 many(42);
  double a[4096], b[4096];
  many.fill_pairs(a, b, 4096);
  for (int k = 0; k < 4096; ++k) {
    ASSERT_GE(a[k], 0.0);
    ASSERT_LT(a[k], 1.0);
    ASSERT_GE(b[k], 0.0);
    ASSERT_LT(b[k], 1.0);
  }
}

// normal() is Box-Muller on the next two uniforms, the first moved half a
// step into (0, 1); its samples have mean 0 and variance 1.
TEST(SplitMix64Test, NormalsAreBoxMullerOnTheNextTwoUniforms) {
  SplitMix64 n(11), u(11);
  for (int k = 0; k < 3; ++k) {
    const double u1 = u.uniform() + 0x1.0p-54;
    const double u2 = u.uniform();
    EXPECT_EQ(n.normal(), std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2));
  }
  constexpr int kSamples = 200000;
  double sum = 0.0, sum_squares = 0.0;
  int beyond_two = 0;
  for (int k = 0; k < kSamples; ++k) {
    const double x = n.normal();
    sum += x;
    sum_squares += x * x;
    beyond_two += std::fabs(x) > 2.0;
  }
  const double mean = sum / kSamples;
  EXPECT_NEAR(mean, 0.0, 5.0 / std::sqrt(kSamples));
  EXPECT_NEAR(sum_squares / kSamples - mean * mean, 1.0, 5.0 * std::sqrt(2.0 / kSamples));
  // P(|x| > 2) = 0.0455 for a normal; 5 standard errors of the count.
  EXPECT_NEAR(beyond_two / double{kSamples}, 0.0455, 5.0 * std::sqrt(0.0455 * 0.9545 / kSamples));
}

}  // namespace
}  // namespace delta
