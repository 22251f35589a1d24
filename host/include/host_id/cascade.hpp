// The 4th-order low-pass of signal.hpp as it runs: two second-order
// sections in cascade over lanes of samples laid out side by side, two lanes
// to a register. Here so that a caller can take each sample as the pass
// finishes it (FiltfiltBlock::run with a sink).
#pragma once

#include <array>
#include <cstddef>

#include "host_id/lane_pair.hpp"

namespace host_id {

// One second-order section, direct form II transposed:
// y = b0 x + z1; z1 = b1 x - a1 y + z2; z2 = b2 x - a2 y.
struct Biquad {
  double b0{1}, b1{0}, b2{0}, a1{0}, a2{0};
};

namespace cascade {

// The two sections' states of one lane (T = double) or one pair (LanePair).
template <class T>
struct State {
  T z1, z2, w1, w2;

  // The steady state for a constant input x (unity DC gain).
  static State steady(const Biquad& s, const Biquad& u, T x) {
    return {x - s.b0 * x, s.b2 * x - s.a2 * x, x - u.b0 * x, u.b2 * x - u.a2 * x};
  }
  T step(const Biquad& s, const Biquad& u, T in) {
    const T mid = s.b0 * in + z1;
    z1 = s.b1 * in - s.a1 * mid + z2;
    z2 = s.b2 * in - s.a2 * mid;
    const T out = u.b0 * mid + w1;
    w1 = u.b1 * mid - u.a1 * out + w2;
    w2 = u.b2 * mid - u.a2 * out;
    return out;
  }
};

// Runs the two sections over samples n - 1 down to `stop` (backward) or 0 up
// to n - 1 (forward) of a buffer of n samples of W lanes each (sample i at
// x[i W .. i W + W)), starting each section of each lane in the steady
// state for a constant input equal to the lane's first sample in the
// direction of the pass. sink(i, out) takes sample i's W outputs (out may
// alias x's sample i). W is a template argument so that the states live in
// registers, two lanes to a register, and the lanes and sections run side by
// side. The coefficients are copied first: the compiler cannot know that x
// does not overlap the filter, and would load them again after every store.
template <std::size_t W, class Sink>
void run(const std::array<Biquad, 2>& filter, const double* x, std::size_t n, bool backward,
         std::size_t stop, Sink sink) {
  constexpr std::size_t kPairs = W / 2;
  constexpr bool kOdd = W % 2 == 1;
  const Biquad s = filter[0];
  const Biquad u = filter[1];
  const double* first = backward ? x + (n - 1) * W : x;
  std::array<State<LanePair>, kPairs> pairs;
  for (std::size_t p = 0; p < kPairs; ++p) {
    pairs[p] = State<LanePair>::steady(s, u, load_pair(first + 2 * p));
  }
  State<double> last = State<double>::steady(s, u, first[W - 1]);
  const std::size_t count = backward ? n - stop : n;
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t i = backward ? n - 1 - k : k;
    const double* v = x + i * W;
    double out[W];
    for (std::size_t p = 0; p < kPairs; ++p) {
      store_pair(out + 2 * p, pairs[p].step(s, u, load_pair(v + 2 * p)));
    }
    if constexpr (kOdd) out[W - 1] = last.step(s, u, v[W - 1]);
    sink(i, static_cast<const double*>(out));
  }
}

}  // namespace cascade
}  // namespace host_id
