#include "host_id/signal.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <cstdio>
#include <numbers>
#include <vector>

namespace host_id {
namespace {

// |H(e^{jw})| of the cascade.
double gain(const std::array<Biquad, 2>& f, double freq_hz, double fs_hz) {
  const std::complex<double> z = std::polar(1.0, 2.0 * std::numbers::pi * freq_hz / fs_hz);
  std::complex<double> h = 1.0;
  for (const auto& s : f) {
    h *= (s.b0 + s.b1 / z + s.b2 / (z * z)) / (1.0 + s.a1 / z + s.a2 / (z * z));
  }
  return std::abs(h);
}

TEST(SignalTest, ButterworthHasUnityDcGainAndMinus3dBAtCutoff) {
  const auto f = butterworth4_lowpass(20.0, 1000.0);
  EXPECT_NEAR(gain(f, 0.0, 1000.0), 1.0, 1e-12);
  EXPECT_NEAR(gain(f, 20.0, 1000.0), std::sqrt(0.5), 1e-9);
  // Fourth order: -80 dB per decade, about 1e-4 one decade above.
  EXPECT_NEAR(gain(f, 200.0, 1000.0), 1e-4, 0.5e-4);
  EXPECT_NEAR(gain(f, 2.0, 1000.0), 1.0, 1e-7);
}

TEST(SignalTest, FiltfiltKeepsSlowSignalWithoutLagAndRemovesFastOne) {
  const double fs = 1000.0;
  std::vector<double> x(4000);
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double t = static_cast<double>(i) / fs;
    x[i] = 0.3 + std::sin(2 * std::numbers::pi * 1.0 * t) +
           0.2 * std::sin(2 * std::numbers::pi * 150.0 * t);
  }
  const auto y = filtfilt(butterworth4_lowpass(20.0, fs), x, 150);
  double worst_inside = 0.0, worst_end = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double t = static_cast<double>(i) / fs;
    const double e = std::abs(y[i] - 0.3 - std::sin(2 * std::numbers::pi * 1.0 * t));
    double& worst = (i < 150 || i + 150 >= x.size()) ? worst_end : worst_inside;
    worst = std::max(worst, e);
  }
  // Zero phase: no lag inside (a 1 Hz sine delayed by one sample would be off
  // by 6e-3); what is left is the decayed end transient.
  EXPECT_LT(worst_inside, 1e-5);
  // The last sample carries -0.16 of the fast component; the reflection
  // pivots on a line through the end samples, so the end is not pinned to it.
  EXPECT_LT(worst_end, 0.02);
}

// A ramp reflected oddly about its own line is a longer ramp, which the
// zero-phase filter (unity gain at DC, no lag) gives back, ends included:
// with no padding, padding clamped to the series, and the usual padding.
// Reflecting the wrong samples, or running a pass from the wrong end,
// bends the ends.
TEST(SignalTest, FiltfiltGivesARampBackToItsEnds) {
  const auto filter = butterworth4_lowpass(20.0, 1000.0);
  for (const std::size_t n : {2u, 3u, 40u, 700u}) {
    for (const std::size_t pad : {0u, 1u, 150u, 1000u}) {
      std::vector<double> x(n);
      for (std::size_t i = 0; i < n; ++i) x[i] = 0.25 + 0.003 * static_cast<double>(i);
      const std::vector<double> y = filtfilt(filter, x, pad);
      ASSERT_EQ(y.size(), n);
      // Padding shorter than the filter's settling (three periods of the
      // cut-off, 150 samples) leaves the transient of a pass started as if
      // the series were constant.
      // There, y stays within the range of the extended ramp.
      const std::size_t used = std::min(pad, n - 1);
      const double extended_rise = 0.003 * static_cast<double>(n - 1 + 2 * used);
      const double tolerance = used >= 150 ? 5e-5 : extended_rise;
      for (std::size_t i = 0; i < n; ++i) {
        ASSERT_NEAR(y[i], x[i], tolerance) << n << " samples, pad " << pad << ", sample " << i;
      }
    }
  }
}

// The filter written out plainly for one series, as a reference: the odd
// reflection about lines through the end samples (m = max(3, pad / 3) of
// them), each pass started in its steady state, the two sections in direct
// form II transposed.
std::vector<double> plain_filtfilt(const std::array<Biquad, 2>& f, std::vector<double> x,
                                   std::size_t pad) {
  const std::size_t n = x.size();
  if (n < 2) return x;
  pad = std::min(pad, n - 1);
  const std::size_t m = std::min(n, std::max<std::size_t>(3, pad / 3));
  const auto end_value = [&](std::size_t first, double at) {
    double st = 0, sx = 0, stt = 0, stx = 0;
    for (std::size_t i = first; i < first + m; ++i) {
      const double t = static_cast<double>(i);
      st += t, sx += x[i], stt += t * t, stx += t * x[i];
    }
    const double md = static_cast<double>(m), den = md * stt - st * st;
    if (!(den > 0.0)) return x[first];
    const double slope = (md * stx - st * sx) / den;
    return (sx - slope * st) / md + slope * at;
  };
  const double x0 = end_value(0, 0.0), xn = end_value(n - m, static_cast<double>(n - 1));
  std::vector<double> y;
  for (std::size_t i = 0; i < pad; ++i) y.push_back(2.0 * x0 - x[pad - i]);
  y.insert(y.end(), x.begin(), x.end());
  for (std::size_t i = 0; i < pad; ++i) y.push_back(2.0 * xn - x[n - 2 - i]);
  const auto pass = [&f](std::vector<double>& v) {
    const Biquad &s = f[0], &u = f[1];
    double z1 = v[0] - s.b0 * v[0], z2 = s.b2 * v[0] - s.a2 * v[0];
    double w1 = v[0] - u.b0 * v[0], w2 = u.b2 * v[0] - u.a2 * v[0];
    for (double& in : v) {
      const double mid = s.b0 * in + z1;
      z1 = s.b1 * in - s.a1 * mid + z2;
      z2 = s.b2 * in - s.a2 * mid;
      const double out = u.b0 * mid + w1;
      w1 = u.b1 * mid - u.a1 * out + w2;
      w2 = u.b2 * mid - u.a2 * out;
      in = out;
    }
  };
  pass(y);
  std::reverse(y.begin(), y.end());
  pass(y);
  std::reverse(y.begin(), y.end());
  return {y.begin() + static_cast<std::ptrdiff_t>(pad),
          y.begin() + static_cast<std::ptrdiff_t>(pad + n)};
}

// filtfilt() is that reference to the last bit, ends, short series and
// padding clamped to the series included.
TEST(SignalTest, FiltfiltIsThePlainFilterBitForBit) {
  const auto filter = butterworth4_lowpass(20.0, 1000.0);
  for (const std::size_t n : {2u, 3u, 40u, 700u}) {
    for (const std::size_t pad : {0u, 1u, 150u, 1000u}) {
      std::vector<double> x(n);
      for (std::size_t k = 0; k < n; ++k) {
        const double t = static_cast<double>(k) / 1000.0;
        x[k] = 0.2 + std::sin(2.0 * std::numbers::pi * 1.3 * t) +
               0.05 * std::sin(2.0 * std::numbers::pi * 170.0 * t);
      }
      const std::vector<double> want = plain_filtfilt(filter, x, pad);
      const std::vector<double> got = filtfilt(filter, x, pad);
      for (std::size_t k = 0; k < n; ++k) {
        ASSERT_EQ(got[k], want[k]) << n << " samples, pad " << pad << ", sample " << k;
      }
    }
  }
}

// filtfilt_lanes filters each series where at() says it lies, exactly as
// filtfilt() filters it alone, leaves a series that is zero throughout, and
// touches nothing between the series; with more series than it steps
// together (10), in blocks.
TEST(SignalTest, FiltfiltLanesFiltersEachSeriesInItsPlace) {
  const auto filter = butterworth4_lowpass(20.0, 1000.0);
  const std::size_t n = 700, stride = 12, lanes = 10, pad = 150;
  std::vector<double> data(n * stride, -7.0);
  for (std::size_t k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) / 1000.0;
    for (std::size_t l = 0; l < lanes; ++l) {
      const double f = 0.7 + 0.4 * static_cast<double>(l);
      data[k * stride + l] = l == 1 ? 0.0
                                    : std::sin(2.0 * std::numbers::pi * f * t) + 0.3 * t +
                                          0.01 * std::sin(2.0 * std::numbers::pi * 230.0 * t);
    }
  }
  const std::vector<double> start = data;
  filtfilt_lanes(filter, n, lanes, pad, [&](std::size_t k) { return &data[k * stride]; });
  for (std::size_t l = 0; l < stride; ++l) {
    std::vector<double> series(n);
    for (std::size_t k = 0; k < n; ++k) series[k] = start[k * stride + l];
    const std::vector<double> expected = l < lanes ? filtfilt(filter, series, pad) : series;
    bool changed = false;
    for (std::size_t k = 0; k < n; ++k) {
      ASSERT_EQ(data[k * stride + l], expected[k]) << "series " << l << ", sample " << k;
      changed = changed || data[k * stride + l] != start[k * stride + l];
    }
    EXPECT_EQ(changed, l != 1 && l < lanes) << "series " << l;
  }
}

TEST(SignalTest, FivePointDifferencesOfASineAreFourthOrderAccurate) {
  const double h = 1e-3, w = 2 * std::numbers::pi * 2.0;
  std::vector<double> x(1000);
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = std::sin(w * static_cast<double>(i) * h);
  double e1 = 0.0, e2 = 0.0;
  for (std::size_t i = 2; i + 2 < x.size(); ++i) {
    const double t = static_cast<double>(i) * h;
    const Derivatives d = uniform_derivatives_at(x.data(), x.size(), h, i);
    e1 = std::max(e1, std::abs(d.first - w * std::cos(w * t)));
    e2 = std::max(e2, std::abs(d.second + w * w * std::sin(w * t)));
  }
  // (w h)^4 / 30 relative: about 8e-10 * w and 8e-10 * w^2 (plus rounding).
  EXPECT_LT(e1 / w, 1e-9);
  EXPECT_LT(e2 / (w * w), 1e-6);
}

TEST(SignalTest, NonUniformDifferencesAreExactForQuadratics) {
  const std::vector<double> t{0.0, 0.001, 0.0025, 0.003, 0.0052};
  std::vector<double> x;
  for (double ti : t) x.push_back(2.0 + 3.0 * ti - 40.0 * ti * ti);
  for (std::size_t i = 1; i + 1 < t.size(); ++i) {
    const Derivatives d = nonuniform_derivatives_at(t.data(), x.data(), t.size(), i);
    EXPECT_NEAR(d.first, 3.0 - 80.0 * t[i], 1e-9);
    EXPECT_NEAR(d.second, -80.0, 1e-6);
  }
}

// Every uniform stencil, the ends' included, is exact for a quadratic, on
// series as short as three samples.
TEST(SignalTest, UniformDifferencesAreExactForQuadraticsAtEverySample) {
  const double h = 0.01;
  for (const std::size_t n : {3u, 4u, 5u, 6u, 40u}) {
    std::vector<double> x(n);
    for (std::size_t i = 0; i < n; ++i) {
      const double ti = h * static_cast<double>(i);
      x[i] = 2.0 + 3.0 * ti - 40.0 * ti * ti;
    }
    for (std::size_t i = 0; i < n; ++i) {
      const Derivatives d = uniform_derivatives_at(x.data(), n, h, i);
      EXPECT_NEAR(d.first, 3.0 - 80.0 * h * static_cast<double>(i), 1e-9) << n << ", " << i;
      EXPECT_NEAR(d.second, -80.0, 1e-8) << n << ", " << i;
    }
  }
}

// The state cut-off's choice prices the filter by the closed form of a
// bilinear 4th-order Butterworth: |H|^2 = 1 / (1 + (tan(w/2) / tan(wc/2))^8).
TEST(SignalTest, TheButterworthsGainIsItsClosedForm) {
  for (const double fc : {10.0, 20.0, 47.0, 180.0}) {
    const auto f = butterworth4_lowpass(fc, 1000.0);
    for (double freq = 0.5; freq < 500.0; freq *= 1.3) {
      const double r =
          std::tan(std::numbers::pi * freq / 1000.0) / std::tan(std::numbers::pi * fc / 1000.0);
      EXPECT_NEAR(std::pow(gain(f, freq, 1000.0), 2), 1.0 / (1.0 + std::pow(r, 8)), 1e-12)
          << fc << " Hz, at " << freq << " Hz";
    }
  }
}

// A joint angle with its exact second derivative, at 1 kHz for 20 s,
// quantised as a 17-bit encoder does.
struct Motion {
  std::vector<double> q, qdd;
};

Motion quantised(const Motion& exact) {
  const double lsb = 2.0 * std::numbers::pi / 131072.0;
  Motion m = exact;
  for (double& v : m.q) v = lsb * std::round(v / lsb);
  return m;
}

// Minimum-jerk moves of 0.3 rad back and forth, segment_s each.
Motion pick_and_place_like(double segment_s) {
  Motion m;
  for (int i = 0; i < 20000; ++i) {
    const double t = i / 1000.0;
    const int seg = static_cast<int>(t / segment_s);
    const double s = t / segment_s - seg;
    const double dir = seg % 2 == 0 ? 1.0 : -1.0;
    const double w = s * s * s * (10.0 - 15.0 * s + 6.0 * s * s);
    const double ddw = 60.0 * s * (1.0 - s) * (1.0 - 2.0 * s) / (segment_s * segment_s);
    m.q.push_back(0.3 * (seg % 2 == 0 ? w : 1.0 - w));
    m.qdd.push_back(0.3 * dir * ddw);
  }
  return m;
}

// An excitation of five harmonics of 0.2 Hz.
Motion slow_fourier() {
  Motion m;
  for (int i = 0; i < 20000; ++i) {
    const double t = i / 1000.0;
    double q = 0.0, qdd = 0.0;
    for (int k = 1; k <= 5; ++k) {
      const double w = 2.0 * std::numbers::pi * 0.2 * k;
      q += 0.3 / k * std::sin(w * t + k);
      qdd -= 0.3 / k * w * w * std::sin(w * t + k);
    }
    m.q.push_back(q);
    m.qdd.push_back(qdd);
  }
  return m;
}

// RMS of qdd from q filtered at cutoff_hz and differentiated, against the
// exact one, away from the ends.
double qdd_error(const Motion& noisy, const Motion& exact, double cutoff_hz) {
  const auto q = filtfilt(butterworth4_lowpass(cutoff_hz, 1000.0), noisy.q,
                          static_cast<std::size_t>(std::ceil(3000.0 / cutoff_hz)));
  double sum = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 1000; i + 1000 < q.size(); ++i, ++n) {
    const double e = uniform_derivatives_at(q.data(), q.size(), 1e-3, i).second - exact.qdd[i];
    sum += e * e;
  }
  return std::sqrt(sum / static_cast<double>(n));
}

// The cut-off chosen from the samples alone (from 10 Hz up) does about as
// well as the best one a grid finds with the exact qdd known, on motions
// whose best cut-offs differ by a factor of five; and it reads the
// encoder's noise.
TEST(SignalTest, TheStateCutoffFromALogsSpectrumIsNearTheBestForItsMotion) {
  double previous_hz = 0.0;
  for (const Motion& exact :
       {slow_fourier(), pick_and_place_like(0.5), pick_and_place_like(0.25)}) {
    const Motion noisy = quantised(exact);
    const StateCutoff c = choose_state_cutoff({{noisy.q.data(), noisy.q.size()}}, 1000.0, 10.0);
    ASSERT_TRUE(c.from_content);
    const double lsb = 2.0 * std::numbers::pi / 131072.0;
    EXPECT_NEAR(c.noise_rms_rad, lsb / std::sqrt(12.0), 0.15 * lsb / std::sqrt(12.0));
    double best = 1e300, best_hz = 0.0;
    for (double fc = 10.0; fc < 200.0; fc *= 1.05) {
      const double e = qdd_error(noisy, exact, fc);
      if (e < best) {
        best = e;
        best_hz = fc;
      }
    }
    const double chosen = qdd_error(noisy, exact, c.cutoff_hz);
    std::printf("cut-off chosen %.1f Hz (qdd error %.3g rad/s^2), best %.1f Hz (%.3g)\n",
                c.cutoff_hz, chosen, best_hz, best);
    EXPECT_LT(chosen, 1.25 * best);
    EXPECT_GT(c.cutoff_hz, 1.3 * previous_hz);  // faster motion, higher cut-off
    EXPECT_GE(c.cutoff_hz, 10.0);
    previous_hz = c.cutoff_hz;
  }
}

TEST(SignalTest, TheStateCutoffFallsBackWhereTheLogCannotTell) {
  const std::vector<double> still(20000, 0.25), short_one(200, 0.0);
  const StateCutoff a = choose_state_cutoff({{still.data(), still.size()}}, 1000.0, 20.0);
  EXPECT_FALSE(a.from_content);
  EXPECT_EQ(a.cutoff_hz, 20.0);
  const Motion m = quantised(pick_and_place_like(0.25));
  const StateCutoff b = choose_state_cutoff({{m.q.data(), 200}}, 1000.0, 20.0);
  EXPECT_FALSE(b.from_content);
  EXPECT_EQ(b.cutoff_hz, 20.0);
  EXPECT_FALSE(choose_state_cutoff({}, 1000.0, 15.0).from_content);
}

}  // namespace
}  // namespace host_id
