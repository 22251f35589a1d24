// Test-side conversions between double and the fixed-point formats (tests
// only: the core itself never sees a double).
#pragma once

#include <cmath>
#include <cstdint>

#include "delta/fixed/q.hpp"

namespace testq {

template <class Q>
Q to_q(double v) {
  return Q::from_raw(static_cast<std::int32_t>(std::llround(std::ldexp(v, Q::kFracBits))));
}

template <class Q>
double to_d(Q v) {
  return std::ldexp(static_cast<double>(v.raw()), -Q::kFracBits);
}

}  // namespace testq
