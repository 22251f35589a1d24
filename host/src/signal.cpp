#include "host_id/signal.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <utility>

namespace host_id {

std::array<Biquad, 2> butterworth4_lowpass(double cutoff_hz, double sample_rate_hz) {
  // Analog prototype poles of a 4th-order Butterworth: quality factors
  // 1 / (2 cos(pi/8)) and 1 / (2 cos(3 pi/8)).
  const double pi = 3.14159265358979323846;
  const double k = std::tan(pi * cutoff_hz / sample_rate_hz);  // pre-warped
  std::array<Biquad, 2> sections{};
  const double qs[2] = {1.0 / (2.0 * std::cos(pi / 8.0)), 1.0 / (2.0 * std::cos(3.0 * pi / 8.0))};
  for (int i = 0; i < 2; ++i) {
    const double q = qs[i];
    const double norm = 1.0 / (1.0 + k / q + k * k);
    Biquad& s = sections[static_cast<unsigned>(i)];
    s.b0 = k * k * norm;
    s.b1 = 2.0 * s.b0;
    s.b2 = s.b0;
    s.a1 = 2.0 * (k * k - 1.0) * norm;
    s.a2 = (1.0 - k / q + k * k) * norm;
  }
  return sections;
}

namespace {

// The value at sample `at` of the least-squares line through the m samples
// first .. first + m of one lane (in sample units), so that a noisy end
// sample does not pin the filtered signal.
double line_end_value(const double* x, std::size_t stride, std::size_t first, std::size_t m,
                      double at) {
  double st = 0, sx = 0, stt = 0, stx = 0;
  for (std::size_t i = 0; i < m; ++i) {
    const double t = static_cast<double>(first + i);
    const double v = x[(first + i) * stride];
    st += t;
    sx += v;
    stt += t * t;
    stx += t * v;
  }
  const double md = static_cast<double>(m);
  const double den = md * stt - st * st;
  if (!(den > 0.0)) return x[first * stride];
  const double slope = (md * stx - st * sx) / den;
  return (sx - slope * st) / md + slope * at;
}

}  // namespace

FiltfiltBlock::FiltfiltBlock(std::size_t n, std::size_t pad, std::size_t max_lanes)
    : n_(0), pad_(0), max_lanes_(std::min(max_lanes, kMaxLanes)) {
  resize(n, pad);
}

void FiltfiltBlock::resize(std::size_t n, std::size_t pad) {
  n_ = n;
  pad_ = std::min(pad, n - 1);
  if (ext_.size() < (n_ + 2 * pad_) * max_lanes_) ext_.resize((n_ + 2 * pad_) * max_lanes_);
}

void FiltfiltBlock::run(const std::array<Biquad, 2>& filter, std::size_t lanes) {
  extend_and_forward(filter, lanes);
  with_lanes(lanes, [&](auto w) {
    constexpr std::size_t W = decltype(w)::value;
    double* x = ext_.data();
    cascade::run<W>(filter, x, n_ + 2 * pad_, true, pad_,
                    [x](std::size_t i, const double* out) { std::copy_n(out, W, x + i * W); });
  });
}

void FiltfiltBlock::extend_and_forward(const std::array<Biquad, 2>& filter, std::size_t lanes) {
  lanes_ = lanes;
  const std::size_t w = lanes;
  double* x = ext_.data() + pad_ * w;  // the samples, as sample() placed them
  // Odd reflection about robust end values: 2 x0 - x[pad..1], x,
  // 2 xn - x[n-2..n-1-pad], with x0 and xn from lines through the ends.
  const std::size_t m = std::min(n_, std::max<std::size_t>(3, pad_ / 3));
  for (std::size_t l = 0; l < w; ++l) {
    const double x0 = line_end_value(x + l, w, 0, m, 0.0);
    const double xn = line_end_value(x + l, w, n_ - m, m, static_cast<double>(n_ - 1));
    for (std::size_t i = 0; i < pad_; ++i) {
      ext_[i * w + l] = 2.0 * x0 - x[(pad_ - i) * w + l];
      ext_[(pad_ + n_ + i) * w + l] = 2.0 * xn - x[(n_ - 2 - i) * w + l];
    }
  }
  with_lanes(w, [&](auto lanes_w) {
    constexpr std::size_t W = decltype(lanes_w)::value;
    double* ext = ext_.data();
    cascade::run<W>(filter, ext, n_ + 2 * pad_, false, 0,
                    [ext](std::size_t i, const double* out) { std::copy_n(out, W, ext + i * W); });
  });
}

void filtfilt_lanes(const std::array<Biquad, 2>& filter, double* data, std::size_t n,
                    std::size_t lanes, std::size_t stride, std::size_t pad) {
  std::vector<std::ptrdiff_t> offset(lanes);
  for (std::size_t l = 0; l < lanes; ++l) offset[l] = static_cast<std::ptrdiff_t>(l);
  filtfilt_lanes(filter, n, lanes, pad, [&](std::size_t k) {
    return LaneRef{data + k * stride, offset.data()};
  });
}

std::vector<double> filtfilt(const std::array<Biquad, 2>& filter, const std::vector<double>& x,
                             std::size_t pad) {
  std::vector<double> y = x;
  filtfilt_lanes(filter, y.data(), y.size(), 1, 1, pad);
  return y;
}

}  // namespace host_id
