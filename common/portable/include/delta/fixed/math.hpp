// Fixed-point sin/cos, atan2, sqrt, exp and tanh: integer arithmetic only,
// so results are bit-identical on every target. Their error bounds against
// double are asserted over the whole input domain by
// tests/unit/common/fixed_math_test.cpp; the measured figures are in
// docs/design/fixed-point-core.md ("Accuracy, measured by the tests").
#pragma once

#include <cstdint>

#include "delta/fixed/q.hpp"

namespace delta::fx {

struct SinCos {
  Q1_30 sin;
  Q1_30 cos;
};

// sin and cos of any angle in the Q3.28 range (about +/- 8 rad).
SinCos sincos(Q3_28 angle_rad);

// cos alone, bit-identical to sincos(angle).cos at about half the work.
Q1_30 cos(Q3_28 angle_rad);

// The angle of (x, y) in (-pi, pi], from two raw values of the same Q
// format; atan2(0, 0) is 0.
Q3_28 atan2_raw(std::int64_t y, std::int64_t x);

template <int I, int F>
Q3_28 atan2(Q<I, F> y, Q<I, F> x) {
  return atan2_raw(y.raw(), x.raw());
}

// e^-x for x >= 0 (x <= 0 gives 1): x log2(e) = k + f, e^-x = 2^-k 2^-f,
// with 2^-f (f in [0, 1)) a degree-7 polynomial.
Q1_30 exp_neg(Q10_21 x);

// tanh(x) = (1 - e^-2|x|) / (1 + e^-2|x|), with the sign of x.
Q1_30 tanh(Q10_21 x);

// 1 / D in Q2.30 for D = den / 2^32 in [1/2, 1), den in [2^31, 2^32): a
// seed within 0.4 % from a table, then two Newton steps r <- r (2 - D r)
// (relative error below 1e-9). A few multiplies where a 64-bit division is
// a library call on Cortex-M4.
std::uint32_t reciprocal_q30(std::uint32_t den);

// A divisor b != 0 made ready for several quotients a / b: its reciprocal
// once, then one multiply per quotient (quotient() is the case of one;
// shift_ is k below).
template <int IB, int FB>
class Divisor {
 public:
  explicit Divisor(Q<IB, FB> b) : negative_(b.raw() < 0) {
    const auto magnitude = negative_ ? static_cast<std::uint32_t>(-std::int64_t{b.raw()})
                                     : static_cast<std::uint32_t>(b.raw());
    shift_ = __builtin_clz(magnitude);
    reciprocal_q30_ = reciprocal_q30(magnitude << shift_);
  }
  // a / b in format R, rounded to nearest and saturated.
  template <class R, int IA, int FA>
  R divide(Q<IA, FA> a) const {
    // a / b = a_raw r 2^(k - 62) in raw units of 2^(FB - FA).
    const std::int64_t p = std::int64_t{a.raw()} * static_cast<std::int64_t>(reciprocal_q30_);
    const std::int64_t q = shift_round(p, 62 - shift_ - R::kFracBits + FA - FB);
    return R::from_raw(saturate32(negative_ ? -q : q));
  }

 private:
  bool negative_;
  int shift_{0};
  std::uint32_t reciprocal_q30_{0};
};

// a / b in format R through reciprocal_q30(): within 1e-9 relative (and
// the rounding of R), saturated; b = 0 gives the extreme of a's sign.
template <class R, int IA, int FA, int IB, int FB>
R quotient(Q<IA, FA> a, Q<IB, FB> b) {
  if (b.raw() == 0) return a.raw() >= 0 ? R::max() : R::min();
  return Divisor<IB, FB>(b).template divide<R>(a);
}

// Square root of an unsigned 64-bit integer, rounded to nearest (up to 2^32).
std::uint64_t isqrt_round(std::uint64_t v);

// sqrt(v) in format R; negative v gives 0 (callers check first).
template <class R, int I, int F>
R sqrt(Q<I, F> v) {
  static_assert(2 * R::kFracBits - F >= 0 && 2 * R::kFracBits - F <= 31,
                "sqrt: the result format must keep sqrt(raw * 2^(2 FR - F)) within 63 bits");
  if (v.raw() <= 0) return R::zero();
  const std::uint64_t scaled = static_cast<std::uint64_t>(v.raw()) << (2 * R::kFracBits - F);
  const std::uint64_t r = isqrt_round(scaled);
  return R::from_raw(r > static_cast<std::uint64_t>(INT32_MAX) ? INT32_MAX
                                                               : static_cast<std::int32_t>(r));
}

inline constexpr Q3_28 kPi = Q3_28::from_raw(843314857);      // pi in Q3.28
inline constexpr Q3_28 kHalfPi = Q3_28::from_raw(421657428);  // pi / 2
inline constexpr Q3_28 kTwoPi = Q3_28::from_raw(1686629713);  // 2 pi

}  // namespace delta::fx
