#include "host_id/signal.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <vector>

namespace host_id {
namespace {

constexpr double kPi = 3.14159265358979323846;

// |H(e^{jw})| of the cascade.
double gain(const std::array<Biquad, 2>& f, double freq_hz, double fs_hz) {
  const std::complex<double> z = std::polar(1.0, 2.0 * kPi * freq_hz / fs_hz);
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
    x[i] = 0.3 + std::sin(2 * kPi * 1.0 * t) + 0.2 * std::sin(2 * kPi * 150.0 * t);
  }
  const auto y = filtfilt(butterworth4_lowpass(20.0, fs), x, 150);
  double worst_inside = 0.0, worst_end = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double t = static_cast<double>(i) / fs;
    const double e = std::abs(y[i] - 0.3 - std::sin(2 * kPi * 1.0 * t));
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

// Lanes only share the pass over time: each series comes out exactly as
// filtfilt() gives it alone, whatever the lanes' count (one block of one to
// six lanes, pairs and an odd one, and more than a block) and stride, and
// what lies between the lanes is left alone.
TEST(SignalTest, FiltfiltLanesEqualsFiltfiltOfEachSeriesBitForBit) {
  const auto filter = butterworth4_lowpass(20.0, 1000.0);
  const std::size_t n = 700, stride = 9, pad = 150;
  std::vector<double> start(n * stride);
  for (std::size_t k = 0; k < n; ++k) {
    for (std::size_t l = 0; l < stride; ++l) {
      const double t = static_cast<double>(k) / 1000.0;
      start[k * stride + l] = std::sin(2.0 * kPi * (0.7 + static_cast<double>(l)) * t) +
                              0.01 * std::sin(2.0 * kPi * 230.0 * t + static_cast<double>(l));
    }
  }
  for (std::size_t lanes = 1; lanes <= 8; ++lanes) {
    std::vector<double> data = start;
    filtfilt_lanes(filter, data.data(), n, lanes, stride, pad);
    for (std::size_t l = 0; l < stride; ++l) {
      std::vector<double> series(n);
      for (std::size_t k = 0; k < n; ++k) series[k] = start[k * stride + l];
      const std::vector<double> alone = l < lanes ? filtfilt(filter, series, pad) : series;
      for (std::size_t k = 0; k < n; ++k) {
        ASSERT_EQ(data[k * stride + l], alone[k])
            << lanes << " lanes: lane " << l << ", sample " << k;
      }
    }
  }
}

// A block's two ways of giving its result, left in the block (filtered())
// or handed out as the backward pass finishes each sample, give the same
// bits, each sample once, in time order backward.
TEST(SignalTest, ABlockHandsOutWhatItWouldLeaveInPlace) {
  const auto filter = butterworth4_lowpass(20.0, 1000.0);
  const std::size_t n = 500, pad = 150;
  for (std::size_t lanes = 1; lanes <= FiltfiltBlock::kMaxLanes; ++lanes) {
    FiltfiltBlock in_place(n, pad), handed_out(n, pad);
    for (std::size_t k = 0; k < n; ++k) {
      for (std::size_t l = 0; l < lanes; ++l) {
        const double t = static_cast<double>(k) / 1000.0;
        const double v = std::cos(2.0 * kPi * (1.3 + static_cast<double>(l)) * t) + 0.1 * t;
        in_place.sample(k, l, lanes) = v;
        handed_out.sample(k, l, lanes) = v;
      }
    }
    in_place.run(filter, lanes);
    std::size_t next = n;
    handed_out.run(filter, lanes, [&](std::size_t k, const double* values) {
      ASSERT_EQ(k + 1, next) << lanes << " lanes";
      next = k;
      for (std::size_t l = 0; l < lanes; ++l) {
        ASSERT_EQ(values[l], in_place.filtered_lane(l)[k * lanes])
            << lanes << " lanes: " << l << ", " << k;
      }
    });
    EXPECT_EQ(next, 0u) << lanes << " lanes";
  }
}

TEST(SignalTest, FivePointDifferencesOfASineAreFourthOrderAccurate) {
  const double h = 1e-3, w = 2 * kPi * 2.0;
  std::vector<double> x(1000);
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = std::sin(w * static_cast<double>(i) * h);
  double e1 = 0.0, e2 = 0.0;
  for (std::size_t i = 2; i + 2 < x.size(); ++i) {
    const double t = static_cast<double>(i) * h;
    const Derivatives d = uniform_derivatives_at(x.data(), 1, x.size(), h, i);
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
    const Derivatives d = nonuniform_derivatives_at(t.data(), x.data(), 1, t.size(), i);
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
      const Derivatives d = uniform_derivatives_at(x.data(), 1, n, h, i);
      EXPECT_NEAR(d.first, 3.0 - 80.0 * h * static_cast<double>(i), 1e-9) << n << ", " << i;
      EXPECT_NEAR(d.second, -80.0, 1e-8) << n << ", " << i;
    }
  }
}

// Preprocessing differentiates each joint's q where the filter left it,
// every third value of the block: through a stride the stencils give, at
// every sample (the ends too), exactly what they give on the same values
// side by side.
TEST(SignalTest, DerivativesThroughAStrideAreThoseOfTheSeriesAlone) {
  for (const std::size_t n : {3u, 4u, 5u, 6u, 40u}) {
    std::vector<double> t(n), x(n), strided(3 * n, -7.0);
    for (std::size_t i = 0; i < n; ++i) {
      t[i] = 0.001 * static_cast<double>(i) + (i % 3 == 1 ? 2e-4 : 0.0);
      x[i] = std::sin(3.0 * t[i]) + 0.5 * t[i] * t[i] * static_cast<double>(i % 5);
      strided[3 * i + 1] = x[i];
    }
    for (std::size_t i = 0; i < n; ++i) {
      const Derivatives u = uniform_derivatives_at(strided.data() + 1, 3, n, 0.001, i);
      const Derivatives ua = uniform_derivatives_at(x.data(), 1, n, 0.001, i);
      const Derivatives v = nonuniform_derivatives_at(t.data(), strided.data() + 1, 3, n, i);
      const Derivatives va = nonuniform_derivatives_at(t.data(), x.data(), 1, n, i);
      EXPECT_EQ(u.first, ua.first) << n << " samples, sample " << i;
      EXPECT_EQ(u.second, ua.second) << n << " samples, sample " << i;
      EXPECT_EQ(v.first, va.first) << n << " samples, sample " << i;
      EXPECT_EQ(v.second, va.second) << n << " samples, sample " << i;
    }
  }
}

}  // namespace
}  // namespace host_id
