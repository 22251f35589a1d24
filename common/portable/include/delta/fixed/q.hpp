// Fixed-point numbers with the Q format in the type: Q<I, F> holds a signed
// 32-bit value with a sign bit, I integer bits and F fractional bits
// (I + F = 31, ARM's Qm.n notation), so Q<7, 24> spans [-128, 128) with a
// step of 2^-24 and Q<1, 30> spans [-2, 2).
//
// - Add and subtract saturate at the type's range.
// - mul<R>() and div<R>() compute through 64-bit intermediates, round to the
//   nearest and saturate to the result format R.
// - Every rounding here is to the nearest, ties upwards: floor(x + 1/2), as
//   ARM's SMMULR does. It is one add before the shift, with no branch on
//   the sign; a tie (exactly half a step) goes towards +infinity, so that
//   -x may round to one step above -(x rounded).
// - Conversion from a floating-point literal exists only at compile time
//   (consteval): no float or double reaches the object code.
//
// No heap, no exceptions, no floating point: this header builds for the
// host and for Cortex-M alike, and gives bit-identical results on both.
#pragma once

#include <compare>
#include <cstdint>
#include <type_traits>

#if defined(__ARM_FEATURE_DSP)
#include <arm_acle.h>  // __qadd, __qsub: Cortex-M4's saturating add and subtract
#endif

namespace delta::fx {

namespace detail {

// Not constexpr: calling it from a consteval function is a compile error,
// which is how an out-of-range constant is reported.
inline void fixed_point_constant_out_of_range() {}

// The extreme of the sign of a 64-bit value given its high word, out of
// line: GCC would otherwise work out the sign ahead of every in-range test.
[[gnu::cold, gnu::noinline]] constexpr std::int32_t saturated_of_sign(std::int32_t high_word) {
  return high_word < 0 ? INT32_MIN : INT32_MAX;
}

}  // namespace detail

// The rounding and saturation every Q operation uses, for integer code that
// works on raw values (sums of products rounded once, log scalings).

// v saturated to 32 bits.
constexpr std::int32_t saturate32(std::int64_t v) {
  // In range when the high word is the sign of the low one: one compare on
  // a 32-bit machine for the common case, laid out as the branch not taken
  // (a taken branch refills the Cortex-M4's pipeline: 2 to 4 cycles).
  const auto low = static_cast<std::int32_t>(v);
  if (static_cast<std::int32_t>(v >> 32) == (low >> 31)) [[likely]] {
    return low;
  }
  return detail::saturated_of_sign(static_cast<std::int32_t>(v >> 32));
}

// v / 2^shift rounded to nearest, ties upwards; shift may be <= 0 (a left
// shift, saturating later).
constexpr std::int64_t shift_round(std::int64_t v, int shift) {
  if (shift <= 0) {
    const int left = -shift;
    if (left >= 62) return v > 0 ? INT64_MAX : (v < 0 ? INT64_MIN : 0);
    const std::int64_t limit = INT64_MAX >> left;
    if (v > limit) return INT64_MAX;
    if (v < -limit) return INT64_MIN;
    return v * (std::int64_t{1} << left);
  }
  if (shift >= 63) return 0;
  const std::int64_t half = std::int64_t{1} << (shift - 1);
  return (v + half) >> shift;
}

// The same for a 32-bit value and 0 < shift < 31 (no 64-bit arithmetic).
constexpr std::int32_t shift_round32(std::int32_t v, int shift) {
  const std::int32_t half = std::int32_t{1} << (shift - 1);
  return (v + half) >> shift;
}

// The primitives the Cortex-M4 does in one instruction each (QADD, QSUB,
// SSAT, SMULL, SMMLAR; GCC does not always find them). Their portable forms
// give the same bits: the Cortex-M image checks the two against each other
// on random and extreme operands (tests/golden, "asm-vs-portable").
namespace portable {

constexpr std::int32_t add_saturate(std::int32_t a, std::int32_t b) {
  std::int32_t r = 0;
  if (__builtin_add_overflow(a, b, &r)) return a < 0 ? INT32_MIN : INT32_MAX;
  return r;
}
constexpr std::int32_t sub_saturate(std::int32_t a, std::int32_t b) {
  std::int32_t r = 0;
  if (__builtin_sub_overflow(a, b, &r)) return a < 0 ? INT32_MIN : INT32_MAX;
  return r;
}
template <int Shift>
constexpr std::int32_t narrow(std::int64_t v) {
  static_assert(Shift > 0 && Shift < 32);
  return saturate32(shift_round(v, Shift));
}
constexpr std::int64_t wide_product(std::int32_t a, std::int32_t b) {
  return std::int64_t{a} * b;
}
constexpr std::int32_t add_high_product(std::int32_t c, std::int32_t a, std::int32_t b) {
  return static_cast<std::int32_t>(
      static_cast<std::uint32_t>(c) +
      static_cast<std::uint32_t>((std::int64_t{a} * b + (std::int64_t{1} << 31)) >> 32));
}

}  // namespace portable

// a + b and a - b, saturated to 32 bits (QADD, QSUB). They also keep the
// result a plain 32-bit value for the widening multiplies after it, where
// the branch of the portable form makes GCC multiply in 64 bits.
constexpr std::int32_t add_saturate(std::int32_t a, std::int32_t b) {
#if defined(__ARM_FEATURE_DSP)
  if (!std::is_constant_evaluated()) return __qadd(a, b);
#endif
  return portable::add_saturate(a, b);
}
constexpr std::int32_t sub_saturate(std::int32_t a, std::int32_t b) {
#if defined(__ARM_FEATURE_DSP)
  if (!std::is_constant_evaluated()) return __qsub(a, b);
#endif
  return portable::sub_saturate(a, b);
}

// saturate32(shift_round(v, Shift)) for 0 < Shift < 32. With the
// Cortex-M4's SSAT the range test is on the rounded value's high word
// before the shift: r / 2^Shift fits 32 bits exactly when r's high word
// fits Shift bits.
template <int Shift>
constexpr std::int32_t narrow(std::int64_t v) {
  static_assert(Shift > 0 && Shift < 32);
#if defined(__ARM_FEATURE_DSP)
  if (!std::is_constant_evaluated()) {
    const std::int64_t r = v + (std::int64_t{1} << (Shift - 1));
    const auto high = static_cast<std::int32_t>(r >> 32);
    std::int32_t high_saturated = 0;
    asm("ssat %0, %1, %2" : "=r"(high_saturated) : "I"(Shift), "r"(high));
    if (high_saturated == high) [[likely]] {
      return static_cast<std::int32_t>(
          static_cast<std::uint32_t>(static_cast<std::uint64_t>(r) >> Shift));
    }
    return detail::saturated_of_sign(high);
  }
#endif
  return portable::narrow<Shift>(v);
}

// a * b in 64 bits (SMULL).
constexpr std::int64_t wide_product(std::int32_t a, std::int32_t b) {
#if defined(__ARM_FEATURE_DSP)
  if (!std::is_constant_evaluated()) {
    std::uint32_t low = 0;
    std::int32_t high = 0;
    asm("smull %0, %1, %2, %3" : "=r"(low), "=r"(high) : "r"(a), "r"(b));
    return static_cast<std::int64_t>(
        static_cast<std::uint64_t>(static_cast<std::uint32_t>(high)) << 32 | low);
  }
#endif
  return portable::wide_product(a, b);
}

// c + (a * b) / 2^32 rounded to nearest, ties upwards (SMMLAR; the sum
// wraps at 32 bits, so callers keep it in range).
constexpr std::int32_t add_high_product(std::int32_t c, std::int32_t a, std::int32_t b) {
#if defined(__ARM_FEATURE_DSP)
  if (!std::is_constant_evaluated()) {
    std::int32_t r = 0;
    asm("smmlar %0, %1, %2, %3" : "=r"(r) : "r"(a), "r"(b), "r"(c));
    return r;
  }
#endif
  return portable::add_high_product(c, a, b);
}

template <int IntBits, int FracBits>
class Q {
  static_assert(IntBits >= 0 && FracBits >= 0 && IntBits + FracBits == 31,
                "Q<I, F> is a 32-bit format: sign + I + F bits, so I + F must be 31");

 public:
  static constexpr int kIntBits = IntBits;
  static constexpr int kFracBits = FracBits;

  constexpr Q() = default;

  // The value with this raw representation (value = raw / 2^F).
  static constexpr Q from_raw(std::int32_t raw) {
    Q q;
    q.raw_ = raw;
    return q;
  }
  // A whole number, saturated.
  static constexpr Q from_int(std::int32_t v) {
    return from_raw(saturate32(shift_round(v, -FracBits)));
  }
  // A compile-time constant from a floating-point literal, rounded to
  // nearest (ties upwards, like every rounding here); out of range does not
  // compile. Computed in long double, whatever the literal's type.
  template <class Real>
  static consteval Q from(Real v) {
    const long double scaled =
        static_cast<long double>(v) * static_cast<long double>(std::int64_t{1} << FracBits) + 0.5L;
    if (scaled >= 2147483648.0L || scaled < -2147483648.0L) {
      detail::fixed_point_constant_out_of_range();
    }
    // floor(): the cast truncates towards zero.
    auto r = static_cast<std::int64_t>(scaled);
    if (static_cast<long double>(r) > scaled) --r;
    return from_raw(static_cast<std::int32_t>(r));
  }
  static constexpr Q max() { return from_raw(INT32_MAX); }
  static constexpr Q min() { return from_raw(INT32_MIN); }
  static constexpr Q zero() { return from_raw(0); }

  constexpr std::int32_t raw() const { return raw_; }

  friend constexpr Q operator+(Q a, Q b) { return from_raw(add_saturate(a.raw_, b.raw_)); }
  friend constexpr Q operator-(Q a, Q b) { return from_raw(sub_saturate(a.raw_, b.raw_)); }
  constexpr Q operator-() const { return from_raw(sub_saturate(0, raw_)); }
  constexpr Q& operator+=(Q o) { return *this = *this + o; }
  constexpr Q& operator-=(Q o) { return *this = *this - o; }
  friend constexpr auto operator<=>(Q a, Q b) = default;
  friend constexpr bool operator==(Q a, Q b) = default;

  // Multiplication by a whole number, saturated.
  constexpr Q scaled_by(std::int32_t k) const {
    return from_raw(saturate32(std::int64_t{raw_} * k));
  }
  // Division by 2^n, rounded.
  constexpr Q halved(int n) const {
    return from_raw(static_cast<std::int32_t>(shift_round(raw_, n)));
  }

 private:
  std::int32_t raw_{0};
};

// The formats the project uses, with the quantity they hold.
using Q1_30 = Q<1, 30>;    // sines, cosines, unit vectors, ratios in [-2, 2)
using Q3_28 = Q<3, 28>;    // angles [rad], up to +/- 8 rad
using Q7_24 = Q<7, 24>;    // lengths [m], positions, squared lengths [m^2]
using Q10_21 = Q<10, 21>;  // angular velocities [rad/s], up to +/- 1024
using Q14_17 = Q<14, 17>;  // angular accelerations [rad/s^2], up to +/- 16384
using Q12_19 = Q<12, 19>;  // torques [N m], currents [A], gains, up to +/- 4096
using Q16_15 = Q<16, 15>;  // controller gains [N m/rad], up to +/- 65536

template <class T>
constexpr T abs(T v) {
  return v < T::zero() ? -v : v;
}

// r = a * b in format R, rounded to nearest and saturated.
template <class R, int IA, int FA, int IB, int FB>
constexpr R mul(Q<IA, FA> a, Q<IB, FB> b) {
  const std::int64_t p = wide_product(a.raw(), b.raw());
  constexpr int kShift = FA + FB - R::kFracBits;
  if constexpr (kShift > 0 && kShift < 32) {
    return R::from_raw(narrow<kShift>(p));
  } else {
    return R::from_raw(saturate32(shift_round(p, kShift)));
  }
}

// r = a / b in format R, rounded to nearest and saturated; b = 0 gives the
// format's extreme of a's sign (callers check divisors first).
template <class R, int IA, int FA, int IB, int FB>
constexpr R div(Q<IA, FA> a, Q<IB, FB> b) {
  if (b.raw() == 0) return a.raw() >= 0 ? R::max() : R::min();
  // a / b * 2^FR = a_raw * 2^shift / b_raw with shift = FR - FA + FB.
  const int shift = R::kFracBits - FA + FB;
  std::int64_t num = a.raw();
  std::int64_t den = b.raw();
  if (den < 0) {
    num = -num;
    den = -den;
  }
  int post = 0;  // a left shift of the quotient when shift > 31
  if (shift >= 0) {
    const int s = shift > 31 ? 31 : shift;
    post = shift - s;
    num *= std::int64_t{1} << s;
  } else {
    if (-shift > 31) return R::zero();
    den *= std::int64_t{1} << -shift;
  }
  // q + rem / den with |rem| < den: to the nearest, ties upwards.
  std::int64_t q = num / den;
  const std::int64_t rem = num % den;
  if (2 * rem >= den) {
    ++q;
  } else if (2 * rem < -den) {
    --q;
  }
  return R::from_raw(saturate32(shift_round(q, -post)));
}

// n / d as a Q1.30 fraction, rounded to nearest (d > 0, n <= d): tick ratios
// of any length, without a detour through a format that could saturate.
constexpr Q<1, 30> ratio(std::uint32_t n, std::uint32_t d) {
  if (d == 0) return Q<1, 30>::zero();
  if (n < d && d < (1u << 16)) {
    // Two 32-bit divisions of 15 bits each (a hardware UDIV on Cortex-M4)
    // instead of a 64-bit one: n * 2^30 / d = (q1 * 2^15 + q2), rounded.
    const std::uint32_t q1 = (n << 15) / d, r1 = (n << 15) % d;
    const std::uint32_t q2 = (r1 << 15) / d, r2 = (r1 << 15) % d;
    return Q<1, 30>::from_raw(static_cast<std::int32_t>((q1 << 15) + q2 + (2 * r2 >= d ? 1u : 0u)));
  }
  const std::int64_t num = std::int64_t{n} << 30;
  return Q<1, 30>::from_raw(saturate32((num + d / 2) / d));
}

// The same value in another format, rounded to nearest and saturated.
template <class R, int I, int F>
constexpr R convert(Q<I, F> a) {
  return R::from_raw(saturate32(shift_round(a.raw(), F - R::kFracBits)));
}

}  // namespace delta::fx
