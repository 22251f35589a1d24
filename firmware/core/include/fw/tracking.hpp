// The tracking error of a run, measured by the controller: per joint the
// sum of the squared errors q_ref - q and the largest |q_ref - q|, over the
// trajectory's ticks (after the approach). Integer only: errors are summed
// as squares of Q3.20 (2^-20 rad, about 1 urad), so that the sum's unit is
// 2^-40 rad^2 and 64 bits hold an hour at 10 kHz of 0.1 rad errors; a sum
// that would pass 2^64 stays at the largest value.
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
      const std::int64_t e = std::int64_t{reference[j].raw()} - q[j].raw();
      const std::uint64_t magnitude = static_cast<std::uint64_t>(e < 0 ? -e : e);
      const std::uint64_t e20 = (magnitude + (1u << 7)) >> 8;  // Q3.28 -> Q3.20, rounded
      const std::uint64_t square = e20 * e20;
      std::uint64_t& sum = sum_sq_rad2_q40[j];
      sum = sum > UINT64_MAX - square ? UINT64_MAX : sum + square;
      const std::int64_t kept =
          magnitude > INT32_MAX ? INT32_MAX : static_cast<std::int64_t>(magnitude);
      if (kept > max_abs_rad[j].raw()) {
        max_abs_rad[j] = delta::fx::Q3_28::from_raw(static_cast<std::int32_t>(kept));
      }
    }
    ++ticks;
  }
};

}  // namespace fw
