#include "delta/splitmix.hpp"

#include <gtest/gtest.h>

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

// A uniform is the output's top 53 bits over 2^53; pairs are consecutive
// uniforms, interleaved.
TEST(SplitMix64Test, UniformsAreTheTopBitsAndPairsInterleave) {
  SplitMix64 u(0);
  EXPECT_EQ(u.uniform(), static_cast<double>(0xE220A8397B1DCDAFull >> 11) * 0x1.0p-53);
  SplitMix64 pairs(7), single(7);
  double first[3], second[3];
  pairs.fill_pairs(first, second, 3);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(first[k], single.uniform());
    EXPECT_EQ(second[k], single.uniform());
  }
  EXPECT_EQ(pairs.next(), single.next());
}

}  // namespace
}  // namespace delta
