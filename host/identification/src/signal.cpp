#include "host_id/signal.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstddef>
#include <numbers>
#include <unsupported/Eigen/FFT>
#include <vector>

namespace host_id {

std::array<Biquad, 2> butterworth4_lowpass(double cutoff_hz, double sample_rate_hz) {
  // Analog prototype poles of a 4th-order Butterworth: quality factors
  // 1 / (2 cos(pi/8)) and 1 / (2 cos(3 pi/8)).
  using std::numbers::pi;
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

void filtfilt_in_place(const std::array<Biquad, 2>& filter, std::vector<double>& x,
                       std::size_t pad) {
  filtfilt_lanes(filter, x.size(), 1, pad, [&x](std::size_t k) { return &x[k]; });
}

std::vector<double> filtfilt(const std::array<Biquad, 2>& filter, std::vector<double> x,
                             std::size_t pad) {
  filtfilt_in_place(filter, x, pad);
  return x;
}

namespace {

// The Welch spectrum of the spans in windows of l samples, in arbitrary
// units (only its shape matters), summed over every window of every span.
// Each window is pre-whitened: the spectrum of its second differences,
// divided by their gain (2 - 2 cos w)^2, so that the strong slow motion
// does not leak through the window's sidelobes into the frequencies where
// signal and noise are told apart.
std::vector<double> welch_spectrum(const std::vector<Span>& spans, std::size_t l,
                                   std::size_t& windows) {
  std::vector<double> power(l / 2 + 1, 0.0);
  std::vector<double> hann(l), x(l);
  for (std::size_t i = 0; i < l; ++i) {
    hann[i] = 0.5 - 0.5 * std::cos(2.0 * std::numbers::pi * static_cast<double>(i) /
                                   static_cast<double>(l));
  }
  Eigen::FFT<double> fft;
  std::vector<std::complex<double>> spectrum;
  // At most kMaxWindows, spread over the spans: more add little to the
  // estimate but cost time on a long log.
  constexpr std::size_t kMaxWindows = 48;
  std::size_t all = 0;
  for (const Span& span : spans) all += span.n >= l + 2 ? (span.n - l - 2) / (l / 2) + 1 : 0;
  const std::size_t hop = l / 2 * ((all + kMaxWindows - 1) / kMaxWindows);
  windows = 0;
  for (const Span& span : spans) {
    for (std::size_t first = 1; span.n >= l + 2 && first + l + 1 <= span.n; first += hop) {
      double mean = 0.0;
      for (std::size_t i = 0; i < l; ++i) {
        const double* q = span.x + first + i;
        x[i] = q[1] - 2.0 * q[0] + q[-1];
        mean += x[i] / static_cast<double>(l);
      }
      for (std::size_t i = 0; i < l; ++i) x[i] = (x[i] - mean) * hann[i];
      fft.fwd(spectrum, x);
      for (std::size_t k = 1; k < power.size(); ++k) power[k] += std::norm(spectrum[k]);
      ++windows;
    }
  }
  for (std::size_t k = 1; k < power.size(); ++k) {
    const double g = 2.0 - 2.0 * std::cos(2.0 * std::numbers::pi * static_cast<double>(k) /
                                          static_cast<double>(l));
    power[k] /= g * g;
  }
  return power;
}

// The noise floor of the spectrum: its mean over the top of the band
// (0.25 to 0.45 cycles per sample of windows of l samples).
double noise_floor(const std::vector<double>& power, std::size_t l) {
  std::vector<double> top;
  for (std::size_t k = 0; k < power.size(); ++k) {
    const double f = static_cast<double>(k) / static_cast<double>(l);  // cycles per sample
    if (f >= 0.25 && f <= 0.45) top.push_back(power[k]);
  }
  double floor = 0.0;
  for (const double p : top) floor += p / static_cast<double>(top.size());
  return floor;
}

// The end of the last band (10 % wide, at least 3 bins) below 0.2 cycles
// per sample that stands above four times the floor; 0 if none does.
// Above it, what rises over the floor (quantisation's own lines) is noise.
std::size_t signal_edge(const std::vector<double>& power, std::size_t l, double floor) {
  std::size_t edge = 0;
  for (std::size_t k = 1;
       k < power.size() && static_cast<double>(k) / static_cast<double>(l) < 0.2;) {
    const std::size_t end = std::min(power.size(), k + std::max<std::size_t>(3, k / 10));
    double band = 0.0;
    for (std::size_t i = k; i < end; ++i) band += power[i] / static_cast<double>(end - k);
    if (band > 4.0 * floor) edge = end;
    k = end;
  }
  return edge;
}

// The signal (the spectrum less the floor, below the edge) and each bin's
// weight: the squared gain of the second difference that qdd takes.
struct WeightedSignal {
  std::vector<double> signal, weight;
  double total{0.0};
};

WeightedSignal weighted_signal(const std::vector<double>& power, std::size_t l, double floor,
                               std::size_t edge) {
  WeightedSignal s{std::vector<double>(power.size(), 0.0), std::vector<double>(power.size(), 0.0)};
  for (std::size_t k = 1; k < power.size(); ++k) {
    const double w = 2.0 * std::numbers::pi * static_cast<double>(k) / static_cast<double>(l);
    const double d2 = -2.0 * std::cos(2.0 * w) + 32.0 * std::cos(w) - 30.0;  // x 1 / (12 h^2)
    s.weight[k] = d2 * d2;
    if (k < edge) s.signal[k] = std::max(0.0, power[k] - floor);
    s.total += s.signal[k] * s.weight[k];
  }
  return s;
}

// The cut-off from lowest_hz up to 0.2 fs, in steps of 5 %, whose filter
// loses the least signal and lets the least noise through (weighted).
void choose_best_cutoff(const WeightedSignal& s, std::size_t l, double floor, double fs,
                        double lowest_hz, StateCutoff& choice) {
  double best = 0.0;
  // The filter's gain |H|^2 at w, forward and backward: the bilinear
  // transform of a 4th-order Butterworth is 1 / (1 + (tan(w/2) / tan(wc/2))^8)
  // in magnitude squared, so G is its square.
  std::vector<double> tan_half(s.signal.size());
  for (std::size_t k = 1; k < s.signal.size(); ++k) {
    tan_half[k] = std::tan(std::numbers::pi * static_cast<double>(k) / static_cast<double>(l));
  }
  for (double fc = lowest_hz; fc <= 0.2 * fs; fc *= 1.05) {
    const double tan_c = std::tan(std::numbers::pi * fc / fs);
    double error = 0.0;
    for (std::size_t k = 1; k < s.signal.size(); ++k) {
      const double r = tan_half[k] / tan_c, r2 = r * r, r4 = r2 * r2;
      const double g = 1.0 / (1.0 + r4 * r4);
      error += s.weight[k] * ((1.0 - g) * (1.0 - g) * s.signal[k] + g * g * floor);
    }
    if (!choice.from_content || error < best) {
      best = error;
      choice.cutoff_hz = fc;
      choice.from_content = true;
    }
  }
}

}  // namespace

StateCutoff choose_state_cutoff(const std::vector<Span>& spans, double fs, double lowest_hz) {
  StateCutoff choice{lowest_hz, 0.0, false};
  std::size_t longest = 0;
  for (const Span& s : spans) longest = std::max(longest, s.n);
  std::size_t l = 4096;
  while (l + 2 > longest && l > 0) l /= 2;
  if (l < 256 || !(fs > 0.0)) return choice;
  std::size_t windows = 0;
  const std::vector<double> power = welch_spectrum(spans, l, windows);
  const double floor = noise_floor(power, l);
  // Hann windows of l samples: a white variance v gives sum |X|^2 = v * 3 l / 8 per bin.
  choice.noise_rms_rad =
      std::sqrt(floor / (static_cast<double>(windows) * 3.0 * static_cast<double>(l) / 8.0));
  const WeightedSignal signal = weighted_signal(power, l, floor, signal_edge(power, l, floor));
  if (!(signal.total > 0.0)) return choice;  // no motion to judge by
  choose_best_cutoff(signal, l, floor, fs, lowest_hz, choice);
  return choice;
}

}  // namespace host_id
