// Between double and the fixed-point formats (delta/fixed/q.hpp), for the
// code that prepares values for the controller (its configuration, a fitted
// model) and for tests: the core itself never sees a double. The rounding
// is q.hpp's, to the nearest with ties upwards: floor(v 2^F + 1/2).
#pragma once

#include <cmath>
#include <cstdint>
#include <optional>

#include "delta/fixed/q.hpp"

namespace delta {

// v in format Q; nothing when v is not finite or does not fit the format.
template <class Q>
std::optional<Q> to_q(double v) {
  const double rounded = std::floor(std::ldexp(v, Q::kFracBits) + 0.5);
  if (!(rounded >= -2147483648.0 && rounded <= 2147483647.0)) return std::nullopt;
  return Q::from_raw(static_cast<std::int32_t>(rounded));
}

// v in format Q, the format's extreme of v's sign when it does not fit
// (zero for NaN).
template <class Q>
Q to_q_saturated(double v) {
  if (std::isnan(v)) return Q::zero();
  if (const auto q = to_q<Q>(v)) return *q;
  return v > 0 ? Q::max() : Q::min();
}

// The value a Q number holds.
template <class Q>
double to_double(Q v) {
  return std::ldexp(static_cast<double>(v.raw()), -Q::kFracBits);
}

}  // namespace delta
