// Zero-phase low-pass filtering and numerical differentiation of sampled
// signals, for logs without qd and qdd columns.
#pragma once

#include <algorithm>
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

namespace filtfilt_detail {

// At most this many lanes are stepped together: filtfilt_lanes takes more
// in blocks of this many.
constexpr std::size_t kMaxLanes = 8;

// The values at sample `at_sample` of the least-squares lines through
// samples first .. first + m of each lane, so that a noisy end sample does
// not pin the filtered signal.
template <class At>
std::array<double, kMaxLanes> line_end_values(const At& at, std::size_t lanes, std::size_t first,
                                              std::size_t m, double at_sample) {
  double st = 0, stt = 0;
  std::array<double, kMaxLanes> sx{}, stx{};
  for (std::size_t i = 0; i < m; ++i) {
    const double t = static_cast<double>(first + i);
    const auto x = at(first + i);
    st += t;
    stt += t * t;
    for (std::size_t l = 0; l < lanes; ++l) {
      sx[l] += x[l];
      stx[l] += t * x[l];
    }
  }
  const double md = static_cast<double>(m);
  const double den = md * stt - st * st;
  const auto x = at(first);
  std::array<double, kMaxLanes> out{};
  for (std::size_t l = 0; l < lanes; ++l) {
    if (!(den > 0.0)) {
      out[l] = x[l];
      continue;
    }
    const double slope = (md * stx[l] - st * sx[l]) / den;
    out[l] = (sx[l] - slope * st) / md + slope * at_sample;
  }
  return out;
}

// The two sections' states of each lane, stepped side by side. The states
// are the object's own (on its thread's stack): in small blocks on the
// heap, two threads' states could share a cache line, written each sample.
class Cascade {
 public:
  Cascade(const std::array<Biquad, 2>& f, std::size_t lanes) : s_(f[0]), u_(f[1]), lanes_(lanes) {}
  // The steady state for each lane's constant input x[l] (unity DC gain).
  template <class X>
  void start(const X& x) {
    for (std::size_t l = 0; l < lanes_; ++l) {
      const double v = x[l];
      z1_[l] = v - s_.b0 * v;
      z2_[l] = s_.b2 * v - s_.a2 * v;
      w1_[l] = v - u_.b0 * v;
      w2_[l] = u_.b2 * v - u_.a2 * v;
    }
  }
  // One sample of each lane in, its output written over it.
  template <class X>
  void step(X&& x) {
    for (std::size_t l = 0; l < lanes_; ++l) {
      const double in = x[l];
      const double mid = s_.b0 * in + z1_[l];
      z1_[l] = s_.b1 * in - s_.a1 * mid + z2_[l];
      z2_[l] = s_.b2 * in - s_.a2 * mid;
      const double out = u_.b0 * mid + w1_[l];
      w1_[l] = u_.b1 * mid - u_.a1 * out + w2_[l];
      w2_[l] = u_.b2 * mid - u_.a2 * out;
      x[l] = out;
    }
  }

 private:
  Biquad s_, u_;
  std::size_t lanes_;
  std::array<double, kMaxLanes> z1_{}, z2_{}, w1_{}, w2_{};
};

// Lanes first .. first + kMaxLanes of what at(k) gives.
template <class At>
struct SomeLanes {
  At& at;
  std::size_t first;
  auto operator()(std::size_t k) const {
    struct Lanes {
      decltype(at(k)) all;
      std::size_t first;
      double& operator[](std::size_t l) const { return all[first + l]; }
    };
    return Lanes{at(k), first};
  }
};

// filtfilt_lanes on at most kMaxLanes lanes.
template <class At>
void filtfilt_few(const std::array<Biquad, 2>& filter, std::size_t n, std::size_t lanes,
                  std::size_t pad_asked, const At& at) {
  const std::size_t pad = std::min(pad_asked, n - 1);
  // Odd reflection about robust end values (filtfilt_in_place): only the
  // reflected ends are stored, lane by lane.
  const std::size_t m = std::min(n, std::max<std::size_t>(3, pad / 3));
  const auto x0 = line_end_values(at, lanes, 0, m, 0.0);
  const auto xn = line_end_values(at, lanes, n - m, m, static_cast<double>(n - 1));
  std::vector<double> head(pad * lanes), tail(pad * lanes);
  for (std::size_t i = 0; i < pad; ++i) {
    const auto a = at(pad - i);
    const auto b = at(n - 2 - i);
    for (std::size_t l = 0; l < lanes; ++l) {
      head[i * lanes + l] = 2.0 * x0[l] - a[l];
      tail[i * lanes + l] = 2.0 * xn[l] - b[l];
    }
  }
  Cascade forward(filter, lanes);
  if (pad > 0) {
    forward.start(&head[0]);
    for (std::size_t i = 0; i < pad; ++i) forward.step(&head[i * lanes]);
  } else {
    forward.start(at(0));
  }
  for (std::size_t k = 0; k < n; ++k) forward.step(at(k));
  for (std::size_t i = 0; i < pad; ++i) forward.step(&tail[i * lanes]);
  // Backward from the end of the tail; only the series' samples are kept.
  Cascade backward(filter, lanes);
  if (pad > 0) {
    backward.start(&tail[(pad - 1) * lanes]);
    for (std::size_t i = pad; i-- > 0;) backward.step(&tail[i * lanes]);
  } else {
    backward.start(at(n - 1));
  }
  for (std::size_t k = n; k-- > 0;) backward.step(at(k));
}

}  // namespace filtfilt_detail

// filtfilt_in_place on `lanes` series of n samples at once, each series'
// samples where the caller says: at(k)[l] is sample k of series l (a
// double&). The series are stepped side by side, sample by sample, so that
// their filters' recurrences overlap (a block of kMaxLanes at a time). Each
// series' bits are filtfilt_in_place's.
template <class At>
void filtfilt_lanes(const std::array<Biquad, 2>& filter, std::size_t n, std::size_t lanes,
                    std::size_t pad, At at) {
  using filtfilt_detail::kMaxLanes;
  if (n < 2) return;
  for (std::size_t first = 0; first < lanes; first += kMaxLanes) {
    filtfilt_detail::filtfilt_few(filter, n, std::min(kMaxLanes, lanes - first), pad,
                                  filtfilt_detail::SomeLanes<At>{at, first});
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
