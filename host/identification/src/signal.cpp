#include "host_id/signal.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

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

// The two sections' states of one series.
struct CascadeState {
  double z1, z2, w1, w2;

  // The steady state for a constant input x (unity DC gain).
  static CascadeState steady(const Biquad& s, const Biquad& u, double x) {
    return {x - s.b0 * x, s.b2 * x - s.a2 * x, x - u.b0 * x, u.b2 * x - u.a2 * x};
  }
  double step(const Biquad& s, const Biquad& u, double in) {
    const double mid = s.b0 * in + z1;
    z1 = s.b1 * in - s.a1 * mid + z2;
    z2 = s.b2 * in - s.a2 * mid;
    const double out = u.b0 * mid + w1;
    w1 = u.b1 * mid - u.a1 * out + w2;
    w2 = u.b2 * mid - u.a2 * out;
    return out;
  }
};

}  // namespace

void filtfilt_in_place(const std::array<Biquad, 2>& filter, std::vector<double>& x,
                       std::size_t pad_asked) {
  const std::size_t n = x.size();
  if (n < 2) return;
  const std::size_t pad = std::min(pad_asked, n - 1);
  // Odd reflection about robust end values: 2 x0 - x[pad..1], x,
  // 2 xn - x[n-2..n-1-pad], with x0 and xn from lines through the ends.
  // Only the reflected ends are stored; x is filtered where it is.
  const std::size_t m = std::min(n, std::max<std::size_t>(3, pad / 3));
  const double x0 = line_end_value(x.data(), 1, 0, m, 0.0);
  const double xn = line_end_value(x.data(), 1, n - m, m, static_cast<double>(n - 1));
  std::vector<double> head(pad), tail(pad);
  for (std::size_t i = 0; i < pad; ++i) {
    head[i] = 2.0 * x0 - x[pad - i];
    tail[i] = 2.0 * xn - x[n - 2 - i];
  }
  const Biquad& s = filter[0];
  const Biquad& u = filter[1];
  CascadeState forward = CascadeState::steady(s, u, pad > 0 ? head.front() : x.front());
  for (const double v : head) forward.step(s, u, v);
  for (double& v : x) v = forward.step(s, u, v);
  for (double& v : tail) v = forward.step(s, u, v);
  // Backward from the end of the tail; only x's samples are kept.
  CascadeState backward = CascadeState::steady(s, u, pad > 0 ? tail.back() : x.back());
  for (std::size_t i = pad; i-- > 0;) backward.step(s, u, tail[i]);
  for (std::size_t i = n; i-- > 0;) x[i] = backward.step(s, u, x[i]);
}

std::vector<double> filtfilt(const std::array<Biquad, 2>& filter, std::vector<double> x,
                             std::size_t pad) {
  filtfilt_in_place(filter, x, pad);
  return x;
}

}  // namespace host_id
