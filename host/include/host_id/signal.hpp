// Zero-phase low-pass filtering and numerical differentiation of sampled
// signals, for logs without qd and qdd columns.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <type_traits>
#include <utility>
#include <vector>

#include "host_id/cascade.hpp"
#include "host_id/huge_pages.hpp"

namespace host_id {

// A 4th-order Butterworth low-pass as two sections (bilinear transform with
// pre-warping). Requires 0 < cutoff_hz < sample_rate_hz / 2.
std::array<Biquad, 2> butterworth4_lowpass(double cutoff_hz, double sample_rate_hz);

// Runs the filter forward and backward (zero phase, magnitude squared). The
// ends are extended by odd reflection over pad samples and the filter starts
// in its steady state, so that the ends carry no start-up transient.
std::vector<double> filtfilt(const std::array<Biquad, 2>& filter, const std::vector<double>& x,
                             std::size_t pad);

// The same, in place, on `lanes` series at once: sample k of series l is
// data[k * stride + l] (lanes <= stride). Each series is filtered exactly as
// filtfilt() filters it alone; the lanes only let one pass over time serve
// them all, so the recursion's latency is paid once, not once per series.
void filtfilt_lanes(const std::array<Biquad, 2>& filter, double* data, std::size_t n,
                    std::size_t lanes, std::size_t stride, std::size_t pad);

// Up to six series of n samples, extended at both ends by odd reflection
// over pad samples and filtered forward and backward: the work of
// filtfilt_lanes, with the samples placed and taken by the caller.
class FiltfiltBlock {
 public:
  static constexpr std::size_t kMaxLanes = 6;
  // n >= 2; room for up to max_lanes lanes.
  FiltfiltBlock(std::size_t n, std::size_t pad, std::size_t max_lanes = kMaxLanes);
  // Makes the block serve series of n samples, keeping its buffer (one
  // block serves many series without allocating again).
  void resize(std::size_t n, std::size_t pad);
  // Sample k of lane l of the block being filled (lanes: as given to run()).
  double& sample(std::size_t k, std::size_t l, std::size_t lanes) {
    return ext_[(pad_ + k) * lanes + l];
  }
  void run(const std::array<Biquad, 2>& filter, std::size_t lanes);
  // run(), each sample's filtered lanes handed to put(k, values) as the
  // backward pass finishes them (k = n - 1 down to 0) instead of being left
  // in the block: one pass over the block fewer, and none over the
  // reflected samples before the first.
  template <class Put>
  void run(const std::array<Biquad, 2>& filter, std::size_t lanes, Put put) {
    extend_and_forward(filter, lanes);
    with_lanes(lanes, [&](auto w) {
      cascade::run<decltype(w)::value>(filter, ext_.data(), n_ + 2 * pad_, true, pad_,
                                       [&](std::size_t i, const double* out) {
                                         if (i < pad_ + n_) put(i - pad_, out);
                                       });
    });
  }
  // Lane l's filtered samples after run(): sample k at [k * lanes].
  const double* filtered_lane(std::size_t l) const { return ext_.data() + pad_ * lanes_ + l; }

 private:
  // The reflected ends, then the forward pass, in place.
  void extend_and_forward(const std::array<Biquad, 2>& filter, std::size_t lanes);
  // f(std::integral_constant<std::size_t, lanes>{}), lanes 1 .. kMaxLanes.
  template <class F>
  static void with_lanes(std::size_t lanes, F f) {
    with_lanes(lanes, f, std::make_index_sequence<kMaxLanes>());
  }
  template <class F, std::size_t... W>
  static void with_lanes(std::size_t lanes, F f, std::index_sequence<W...>) {
    ((lanes == W + 1 ? f(std::integral_constant<std::size_t, W + 1>{}) : void()), ...);
  }
  std::size_t n_, pad_, lanes_{0}, max_lanes_;
  SeriesVector<double> ext_;  // the lanes, interleaved, with their reflected ends
};

// Where sample k of a set of lanes lives: lane l at at[offset[l]].
template <class Offset = std::ptrdiff_t>
struct LaneRef {
  double* at;
  const Offset* offset;
  double& operator[](std::size_t l) const { return at[offset[l]]; }
};
template <class Offset>
LaneRef(double*, const Offset*) -> LaneRef<Offset>;

// filtfilt_lanes where the caller says where each sample lives: at(k) is
// sample k of every lane (lanes 0..lanes-1), each read once and written
// once with its filtered value, in `block`'s buffer. A group of lanes that
// is zero throughout is left as it is (its filtered value is zero).
template <class At>
void filtfilt_lanes(const std::array<Biquad, 2>& filter, std::size_t n, std::size_t lanes,
                    std::size_t pad, At at, FiltfiltBlock& block) {
  if (n < 2 || lanes == 0) return;
  block.resize(n, pad);
  for (std::size_t first = 0; first < lanes; first += FiltfiltBlock::kMaxLanes) {
    const std::size_t w = std::min(FiltfiltBlock::kMaxLanes, lanes - first);
    bool any = false;
    for (std::size_t k = 0; k < n; ++k) {
      const auto x = at(k);
      for (std::size_t l = 0; l < w; ++l) {
        const double v = x[first + l];
        block.sample(k, l, w) = v;
        any = any || v != 0.0;
      }
    }
    if (!any) continue;
    block.run(filter, w, [&](std::size_t k, const double* values) {
      const auto x = at(k);
      for (std::size_t l = 0; l < w; ++l) x[first + l] = values[l];
    });
  }
}

template <class At>
void filtfilt_lanes(const std::array<Biquad, 2>& filter, std::size_t n, std::size_t lanes,
                    std::size_t pad, At at) {
  if (n < 2 || lanes == 0) return;
  FiltfiltBlock block(n, pad, std::min(lanes, FiltfiltBlock::kMaxLanes));
  filtfilt_lanes(filter, n, lanes, pad, at, block);
}

// The first and second derivatives at one sample.
struct Derivatives {
  double first{0}, second{0};
};

// Of uniformly sampled x with spacing h, at sample i of n >= 3 (sample k
// at x[k * stride]): the five-point central stencils (error O(h^4)) inside,
// three-point and one-sided stencils at the two samples of each end.
inline Derivatives uniform_derivatives_at(const double* x, std::size_t stride, std::size_t n,
                                          double h, std::size_t i) {
  const auto at = [&](std::size_t k) { return x[k * stride]; };
  const auto central3 = [&](std::size_t k) {
    return Derivatives{(at(k + 1) - at(k - 1)) / (2.0 * h),
                       (at(k + 1) - 2.0 * at(k) + at(k - 1)) / (h * h)};
  };
  if (i == 0) return {(-3.0 * at(0) + 4.0 * at(1) - at(2)) / (2.0 * h), central3(1).second};
  if (i + 1 == n) {
    return {(3.0 * at(n - 1) - 4.0 * at(n - 2) + at(n - 3)) / (2.0 * h), central3(n - 2).second};
  }
  if (i == 1 || i + 2 == n) return central3(i);
  return {(-at(i + 2) + 8.0 * at(i + 1) - 8.0 * at(i - 1) + at(i - 2)) / (12.0 * h),
          (-at(i + 2) + 16.0 * at(i + 1) - 30.0 * at(i) + 16.0 * at(i - 1) - at(i - 2)) /
              (12.0 * h * h)};
}

// The same on non-uniform times t: three-point stencils (error O(h^2)),
// exact for quadratics; one-sided first differences at the ends.
inline Derivatives nonuniform_derivatives_at(const double* t, const double* x, std::size_t stride,
                                             std::size_t n, std::size_t i) {
  const auto at = [&](std::size_t k) { return x[k * stride]; };
  const auto second = [&](std::size_t k) {
    const double hm = t[k] - t[k - 1];
    const double hp = t[k + 1] - t[k];
    return 2.0 * ((at(k + 1) - at(k)) / hp - (at(k) - at(k - 1)) / hm) / (hm + hp);
  };
  if (i == 0) return {(at(1) - at(0)) / (t[1] - t[0]), second(1)};
  if (i + 1 == n) return {(at(n - 1) - at(n - 2)) / (t[n - 1] - t[n - 2]), second(n - 2)};
  const double hm = t[i] - t[i - 1];
  const double hp = t[i + 1] - t[i];
  return {(at(i + 1) * hm * hm - at(i - 1) * hp * hp + at(i) * (hp * hp - hm * hm)) /
              (hm * hp * (hm + hp)),
          second(i)};
}

}  // namespace host_id
