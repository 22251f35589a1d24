// Two doubles computed side by side: the scalar type that lets the
// kinematics templates (kinematics.hpp) work on two samples at once. Each
// lane's arithmetic is exactly the scalar code's (the same IEEE operations in
// the same order, one instruction for both lanes where the target has one),
// so a value's bits do not depend on whether it was computed alone or in a
// pair. The two chains of a sample's kinematics are long and latency-bound
// (square roots and divisions one after another); side by side, each waits
// while the other computes.
//
// A comparison gives a PairMask. In an `if`, a mask is true where either lane
// is: the kinematics' `if (!(ok)) return failure;` fails the pair when either
// sample fails, and the caller computes each sample alone to learn which.
// Where the lanes must go their own ways, pick() chooses per lane.
#pragma once

#include <cmath>
#include <cstdint>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace delta {

class PairMask {
 public:
  using Lanes = std::int64_t __attribute__((vector_size(2 * sizeof(std::int64_t))));
  explicit PairMask(Lanes m) : m_(m) {}
  // Either lane.
  explicit operator bool() const { return m_[0] != 0 || m_[1] != 0; }
  friend PairMask operator!(PairMask a) { return PairMask(a.m_ == 0); }
  Lanes lanes() const { return m_; }

 private:
  Lanes m_;
};

class DoublePair {
 public:
  using Lanes = double __attribute__((vector_size(2 * sizeof(double))));
  DoublePair() : v_{0.0, 0.0} {}
  // A constant in both lanes (implicit: the templates' T(0), T(2) * a).
  DoublePair(double both) : v_{both, both} {}  // NOLINT(google-explicit-constructor)
  DoublePair(double first, double second) : v_{first, second} {}
  explicit DoublePair(Lanes v) : v_(v) {}
  double first() const { return v_[0]; }
  double second() const { return v_[1]; }
  Lanes lanes() const { return v_; }

  friend DoublePair operator+(DoublePair a, DoublePair b) { return DoublePair(a.v_ + b.v_); }
  friend DoublePair operator-(DoublePair a, DoublePair b) { return DoublePair(a.v_ - b.v_); }
  friend DoublePair operator*(DoublePair a, DoublePair b) { return DoublePair(a.v_ * b.v_); }
  friend DoublePair operator/(DoublePair a, DoublePair b) { return DoublePair(a.v_ / b.v_); }
  friend DoublePair operator-(DoublePair a) { return DoublePair(-a.v_); }
  friend PairMask operator<(DoublePair a, DoublePair b) { return PairMask(a.v_ < b.v_); }
  friend PairMask operator>(DoublePair a, DoublePair b) { return PairMask(a.v_ > b.v_); }
  friend PairMask operator<=(DoublePair a, DoublePair b) { return PairMask(a.v_ <= b.v_); }
  friend PairMask operator>=(DoublePair a, DoublePair b) { return PairMask(a.v_ >= b.v_); }
  // Found by argument-dependent lookup, as the kinematics call them.
  // Correctly rounded in both lanes, as std::sqrt.
  friend DoublePair sqrt(DoublePair a) {
#if defined(__SSE2__)
    return DoublePair(reinterpret_cast<Lanes>(_mm_sqrt_pd(reinterpret_cast<__m128d>(a.v_))));
#else
    return {std::sqrt(a.v_[0]), std::sqrt(a.v_[1])};
#endif
  }
  friend DoublePair abs(DoublePair a) {
    return {std::abs(a.v_[0]), std::abs(a.v_[1])};
  }

 private:
  Lanes v_;
};

// where ? a : b, per lane (vec3.hpp has the scalar one).
inline DoublePair pick(PairMask where, DoublePair a, DoublePair b) {
  return DoublePair(where.lanes() != 0 ? a.lanes() : b.lanes());
}

}  // namespace delta
