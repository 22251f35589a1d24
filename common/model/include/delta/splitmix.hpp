// SplitMix64 (Steele, Lea and Flood): a small, fully specified generator, so
// that a seed gives the same numbers on every platform and standard library
// (PSO's swarm, simulated and emulated noise, random excitations), and
// normal numbers from it.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numbers>

namespace delta {

class SplitMix64 {
 public:
  explicit SplitMix64(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform in [0, 1): the output's top 53 bits.
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  // A standard normal (Box-Muller) from the next two uniforms; the first is
  // moved half a step into (0, 1), so that its logarithm is finite.
  double normal() {
    const double u1 = uniform() + 0x1.0p-54;
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
  }
  // count pairs of uniforms of 32 bits, both from one output: the first of
  // each pair (its top half over 2^32) into first[k], the second (its bottom
  // half) into second[k]. Half the outputs of count pairs of uniform(), for
  // a swarm whose moves need 32 bits of randomness, not 53.
  void fill_pairs(double* first, double* second, std::size_t count) {
    for (std::size_t k = 0; k < count; ++k) {
      const std::uint64_t z = next();
      first[k] = static_cast<double>(static_cast<std::uint32_t>(z >> 32)) * 0x1.0p-32;
      second[k] = static_cast<double>(static_cast<std::uint32_t>(z)) * 0x1.0p-32;
    }
  }

 private:
  std::uint64_t state_;
};

}  // namespace delta
