// Zero-phase low-pass filtering and numerical differentiation of sampled
// signals, for logs without qd and qdd columns.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

namespace host_id {

// One second-order section, direct form II transposed:
// y = b0 x + z1; z1 = b1 x - a1 y + z2; z2 = b2 x - a2 y.
struct Biquad {
  double b0{1}, b1{0}, b2{0}, a1{0}, a2{0};
};

// A 4th-order Butterworth low-pass as two sections (bilinear transform with
// pre-warping). Requires 0 < cutoff_hz < sample_rate_hz / 2.
std::array<Biquad, 2> butterworth4_lowpass(double cutoff_hz, double sample_rate_hz);

// Runs the filter forward and backward (zero phase, magnitude squared), in
// place. The ends are extended by odd reflection over pad samples about
// values from lines through the end samples, and each pass starts in its
// steady state, so that the ends carry no start-up transient. A series of
// fewer than two samples is left as it is.
void filtfilt_in_place(const std::array<Biquad, 2>& filter, std::vector<double>& x,
                       std::size_t pad);
std::vector<double> filtfilt(const std::array<Biquad, 2>& filter, std::vector<double> x,
                             std::size_t pad);

// filtfilt_in_place on `lanes` series of n samples that lie where the caller
// says: at(k)[l] is sample k of series l, read once and written once with
// its filtered value. A series that is zero throughout is left as it is (its
// filtered value is zero).
template <class At>
void filtfilt_lanes(const std::array<Biquad, 2>& filter, std::size_t n, std::size_t lanes,
                    std::size_t pad, At at) {
  std::vector<double> x(n);
  for (std::size_t l = 0; l < lanes; ++l) {
    bool any = false;
    for (std::size_t k = 0; k < n; ++k) {
      x[k] = at(k)[l];
      any = any || x[k] != 0.0;
    }
    if (!any) continue;
    filtfilt_in_place(filter, x, pad);
    for (std::size_t k = 0; k < n; ++k) at(k)[l] = x[k];
  }
}

// The cut-off for q's filter before its five-point second differences that
// makes qdd's expected squared error least, judged from q's own content:
// - the Welch spectrum of q (Hann windows of up to 4096 samples, half
//   overlapping, at most 48 spread over a long log, pre-whitened by second
//   differences so that the slow motion does not leak into the rest);
// - its white noise floor, the mean of the spectrum between 0.25 and 0.45
//   of the sample rate;
// - the signal, the spectrum less that floor, below the last band (10 %
//   wide) that stands above four times the floor;
// - for each cut-off on a grid from lowest_hz to a fifth of the sample rate
//   (5 % steps), the distortion (1 - G)^2 S plus the noise G^2 N, both
//   weighted by the squared response of the five-point second difference,
//   with G the filter's forward-backward gain |H|^2.
// spans: the series (each joint's q in each segment), all sampled at
// sample_rate_hz.
struct StateCutoff {
  double cutoff_hz{0};
  double noise_rms_rad{0};   // the floor as white noise per sample, RMS
  bool from_content{false};  // false: too little to judge by (no span of
                             // 258 samples, or no motion): lowest_hz
};
struct Span {
  const double* x;
  std::size_t n;
};
StateCutoff choose_state_cutoff(const std::vector<Span>& spans, double sample_rate_hz,
                                double lowest_hz);

// The first and second derivatives at one sample.
struct Derivatives {
  double first{0}, second{0};
};

// Of uniformly sampled x[0..n) with spacing h, at sample i of n >= 3: the
// five-point central stencils (error O(h^4)) inside,
// three-point and one-sided stencils at the two samples of each end.
inline Derivatives uniform_derivatives_at(const double* x, std::size_t n, double h, std::size_t i) {
  const auto at = [&](std::size_t k) { return x[k]; };
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
inline Derivatives nonuniform_derivatives_at(const double* t, const double* x, std::size_t n,
                                             std::size_t i) {
  const auto at = [&](std::size_t k) { return x[k]; };
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
