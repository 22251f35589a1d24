// The tracking error of a run, measured by the controller: per joint the
// sum of the squared errors q_ref - q and the largest |q_ref - q|, over the
// trajectory's ticks (after the approach). Integer only: an error is
// |q_ref - q| in Q3.28, saturated at 8 rad (far past any fault limit), then
// rounded to Q3.20 (2^-20 rad, about 1 urad) and squared, so that the sum's
// unit is 2^-40 rad^2 and 64 bits hold an hour at 10 kHz of 0.1 rad errors;
// a sum that would pass 2^64 stays at the largest value.
#pragma once

#include <array>
#include <cstdint>

#include "delta/fixed/kinematics.hpp"
#include "delta/fixed/q.hpp"

namespace fw {

struct TrackingStats {
  std::array<std::uint64_t, 3> sum_sq_rad2_q40{};  // sum of (error in 2^-20 rad)^2
  std::array<delta::fx::Q3_28, 3> max_abs_rad{};
  std::uint32_t ticks{0};

  void add(const delta::fx::JointAnglesQ& reference, const delta::fx::JointAnglesQ& q) {
    for (unsigned j = 0; j < 3; ++j) {
      const delta::fx::Q3_28 error = delta::fx::abs(reference[j] - q[j]);  // saturated
      const std::uint32_t e20 = (static_cast<std::uint32_t>(error.raw()) + (1u << 7)) >> 8;
      std::uint64_t& sum = sum_sq_rad2_q40[j];
      if (__builtin_add_overflow(sum, std::uint64_t{e20} * e20, &sum)) sum = UINT64_MAX;
      if (error > max_abs_rad[j]) max_abs_rad[j] = error;
    }
    ++ticks;
  }
};

}  // namespace fw
